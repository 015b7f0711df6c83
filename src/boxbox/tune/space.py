"""The search space of a study: Optuna distributions built from a robot's declared parameters and
the car's setup (model/car_setup.py: each setting the car allows, searched over its range)."""

from __future__ import annotations

from typing import Any

from boxbox.robot.params import Bound
from boxbox.robot.tunable import ParamSpace, declares_params, param_space


def tune_space(cls: type, car: str, spec: str | None = None) -> ParamSpace:
    """What a study of robot class `cls` (given as `spec`, for the errors) on `car` may search: the
    robot's declared parameters, and the car's setup settings (final_drive_ratio, rear_spring_npm,
    gear_ratio_2, ...), each from the car's own value over the range its files allow (a fixed one is
    not searchable)."""
    import shlex

    from boxbox.robot.loader import DEFAULT_ROBOT
    from boxbox.torcs.car_setup import car_settings

    robot = param_space(cls) if declares_params(cls) else ParamSpace(getattr(cls, "name", cls.__name__), {}, {}, {})
    settings = car_settings(car).settings
    robot_option = "" if spec in (None, DEFAULT_ROBOT) else f" --robot {shlex.quote(str(spec))}"
    return ParamSpace(robot=robot.robot, defaults={**{k: s.value for k, s in settings.items()}, **robot.defaults},
                      bounds={**{k: Bound(s.lo, s.hi) for k, s in settings.items()}, **robot.bounds},
                      choices=robot.choices, listed_by=f"boxbox params{robot_option} --car {car}")


def distributions(space: ParamSpace, names: list[str]) -> dict[str, Any]:
    """name -> Optuna distribution: a declared range (log scale where declared) for numbers, the
    declared values for str parameters, both values for bools."""
    from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution

    out: dict[str, Any] = {}
    for name in space.pick(names):
        kind = space.kind(name)
        if kind is bool:
            out[name] = CategoricalDistribution((False, True))
        elif kind is str:
            out[name] = CategoricalDistribution(space.choices[name])
        else:
            b = space.bound(name)
            # a log scale cannot start at 0: the range then starts at a thousandth of its top
            lo = b.lo if not b.log or b.lo > 0 else b.hi * 1e-3
            if kind is int:
                out[name] = IntDistribution(int(lo), int(b.hi), log=b.log)
            else:
                out[name] = FloatDistribution(float(lo), float(b.hi), log=b.log)
    return out


def defaults_in_space(space: ParamSpace, dists: dict[str, Any]) -> dict[str, Any]:
    """The robot's declared defaults of the searched names, clipped into their ranges (the study's
    first trial, so the defaults are always among those compared)."""
    out = {}
    for name, dist in dists.items():
        value = space.defaults[name]
        if hasattr(dist, "low"):
            value = min(max(value, dist.low), dist.high)
        out[name] = value
    return out


def suggest(trial: Any, dists: dict[str, Any]) -> dict[str, Any]:
    """The trial's values of the searched parameters (a queued trial's own values come back as given)."""
    from optuna.distributions import CategoricalDistribution, IntDistribution

    values = {}
    for name, d in dists.items():
        if isinstance(d, CategoricalDistribution):
            values[name] = trial.suggest_categorical(name, d.choices)
        elif isinstance(d, IntDistribution):
            values[name] = trial.suggest_int(name, d.low, d.high, log=d.log)
        else:
            values[name] = trial.suggest_float(name, d.low, d.high, log=d.log)
    return values
