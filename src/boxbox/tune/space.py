"""The search space of a study: Optuna distributions built from a robot's declared parameters."""

from __future__ import annotations

from typing import Any

from boxbox.robot.tunable import ParamSpace


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
