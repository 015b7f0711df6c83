"""Tunable parameters: how any robot class declares the parameters `boxbox tune` may search.

A robot declares them with class attributes (the boxbox robot does, with `TutorialParams`):

    @dataclass(frozen=True)
    class MyParams:
        gain: float = 1.0          # the defaults are the robot's own values
        wide_line: bool = False

    class MyRobot(Robot):
        param_class = MyParams
        param_bounds = {"gain": Bound(0.1, 10.0, log=True)}   # search range (log scale here)
        param_choices = {}                                     # str parameters: their values

        def on_track(self, track, car):
            super().on_track(track, car)
            self.p = robot_params(self)    # MyParams with --set / --setup / tune's values applied

A number is searchable when it has a finite declared range; a bool or a str with declared choices
always is. Values reach the robot through the race's settings (`boxbox race --set`, `--setup FILE`,
`boxbox.race(settings=...)`, `RaceOptions.robot_args["set"]`), checked before TORCS starts.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from boxbox.errors import UsageError
from boxbox.model.car_setup import SETTING_NAMES
from boxbox.robot.params import Bound, example_setting


@dataclass(frozen=True)
class ParamSpace:
    """A robot's declared parameters: defaults, types, ranges and choices."""

    robot: str
    defaults: dict[str, Any]
    bounds: dict[str, Bound]
    choices: dict[str, tuple]
    listed_by: str = "boxbox params"  # the command that lists the parameters, for the errors

    def kind(self, name: str) -> type:
        return type(self.defaults[name])

    def bound(self, name: str) -> Bound:
        return self.bounds.get(name, Bound())

    def searchable(self, name: str) -> bool:
        kind = self.kind(name)
        if kind is bool:
            return True
        if kind is str:
            return len(self.choices.get(name, ())) > 1
        if kind in (int, float):
            b = self.bound(name)
            return math.isfinite(b.lo) and math.isfinite(b.hi) and b.lo < b.hi
        return False

    def range_text(self, name: str) -> str:
        """What a study searches `name` over, as text ("" for a name it cannot search)."""
        if not self.searchable(name):
            return ""
        kind = self.kind(name)
        if kind is bool:
            return "false, true"
        if kind is str:
            return ", ".join(map(str, self.choices[name]))
        b = self.bound(name)
        return f"{b.lo:g} to {b.hi:g}{' (log)' if b.log else ''}"

    def searchable_names(self) -> list[str]:
        return [n for n in self.defaults if self.searchable(n)]

    def pick(self, names: list[str]) -> list[str]:
        """The names asked for, checked: each declared and searchable (UsageError naming the nearest
        valid ones and the command that lists them all: a study's space holds some 30 of the car's)."""
        valid = self.searchable_names()
        where = f"`{self.listed_by}` lists every one, with its range"
        for name in names:
            if name not in valid:
                near = difflib.get_close_matches(name, valid, n=3)  # best first
                either = f"{', '.join(near[:-1])} or {near[-1]}" if len(near) > 1 else "".join(near)
                hint = f" (did you mean {either}?)" if near else ""
                why = "has no range to search" if name in self.defaults else "is not a parameter"
                raise UsageError(f"--params: '{name}' {why} of robot {self.robot}{hint}; {where}")
        if not names:
            raise UsageError(f"--params: name at least one parameter of robot {self.robot}, e.g. "
                             f"--params {valid[0] if valid else 'NAME'}; {where}")
        return names

    def check(self, settings: dict, origin: str) -> dict:
        """settings with each value checked against its declared type, range and choices."""
        out = {}
        for key, value in settings.items():
            if key not in self.defaults:
                near = difflib.get_close_matches(key, list(self.defaults), n=1)
                hint = f" (did you mean {near[0]}?)" if near else ""
                raise UsageError(f"{origin}: unknown parameter '{key}' of robot {self.robot}{hint}")
            out[key] = self._coerce(key, value, origin)
        return out

    def _coerce(self, key: str, value: Any, origin: str) -> Any:
        kind = self.kind(key)
        if kind in (int, float) and isinstance(value, int | float) and not isinstance(value, bool):
            b = self.bound(key)
            if kind is int and value != int(value):
                raise UsageError(f"{origin}: {key} must be a whole number, got {value!r}")
            if not (math.isfinite(value) and b.lo <= value <= b.hi):
                upper = "" if math.isinf(b.hi) else f" to {b.hi:g}"
                raise UsageError(f"{origin}: {key} must be a finite number from {b.lo:g}{upper}, got {value!r}")
            return kind(value)
        if kind is bool and isinstance(value, bool):
            return value
        if kind is str and isinstance(value, str):
            allowed = self.choices.get(key)
            if allowed and value not in allowed:
                raise UsageError(f"{origin}: {key} must be one of {', '.join(allowed)}, got '{value}'")
            return value
        wanted = {bool: "true or false", float: "a number", int: "a whole number"}.get(kind, f"a {kind.__name__}")
        raise UsageError(f"{origin}: {key} must be {wanted}, got {value!r}; "
                         f"{example_setting(key, self.defaults[key], origin)}")


def param_space(cls: type) -> ParamSpace:
    """The parameters robot class `cls` declares (UsageError when it declares none)."""
    params_cls = getattr(cls, "param_class", None)
    name = getattr(cls, "name", cls.__name__)
    if params_cls is None or not dataclasses.is_dataclass(params_cls):
        raise UsageError(f"robot class {cls.__name__} declares no tunable parameters: give it `param_class = "
                         "SomeDataclass` and `param_bounds = {name: Bound(lo, hi)}` (see docs/tuning.md)")
    defaults = {f.name: f.default for f in dataclasses.fields(params_cls)
                if f.default is not dataclasses.MISSING}
    bounds = dict(getattr(cls, "param_bounds", {}) or {})
    choices = {k: tuple(v) for k, v in (getattr(cls, "param_choices", {}) or {}).items()}
    unknown = sorted((set(bounds) | set(choices)) - set(defaults))
    if unknown:
        raise UsageError(f"robot {name} declares bounds or choices for unknown parameters: {', '.join(unknown)}")
    return ParamSpace(robot=name, defaults=defaults, bounds=bounds, choices=choices)


def declares_params(cls: type) -> bool:
    return dataclasses.is_dataclass(getattr(cls, "param_class", None))


def robot_params(robot: Any) -> Any:
    """The robot's `param_class` instance with the race's settings (robot_args["set"]) applied."""
    cls = type(robot)
    space = param_space(cls)
    values = space.check(dict(robot.options.robot_args.get("set") or {}), "settings")
    return cls.param_class(**{**space.defaults, **values})


def read_setup(path: str | Path) -> dict:
    """The parameter values of a setup file (flat TOML: `name = value`, as `boxbox tune` writes)."""
    import tomllib

    try:
        data = tomllib.loads(Path(path).read_text())
    except tomllib.TOMLDecodeError as exc:
        raise UsageError(f"{path}: not valid TOML ({exc}); a setup holds lines like mu_scale = 0.9") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{path}: cannot be read: {exc}") from None
    for key, value in data.items():
        numbers = isinstance(value, list) and all(isinstance(v, int | float) for v in value)  # gear_ratios = [...]
        if not (isinstance(value, bool | int | float | str) or numbers):
            raise UsageError(f"{path}: {key} must be a number, true/false, a string or a list of numbers, "
                             f"not a {type(value).__name__}")
    return data


def check_setup_for(robot_classes: list[type], setup: dict, origin: str) -> None:
    """A setup's keys and values checked against each robot that declares parameters (the car
    setup's, CarSetup's field names, are every robot's: torcs/checks.py checks them against the car)."""
    params = {key: value for key, value in setup.items() if key not in SETTING_NAMES}
    for cls in robot_classes:
        if declares_params(cls):
            param_space(cls).check(params, origin)


def write_setup(path: Path, values: dict, header: list[str], robot: str | None = None) -> None:
    """Write values as a setup file (comments first, then how to race with it when `robot`, the
    spec of the robot they are for, is given), atomically."""
    from boxbox.files import write_text_atomic

    lines = [f"# {line}" for line in header]
    if robot is not None:
        lines.append(f"# race with it: {race_command(path, robot)}")
    for key, value in values.items():
        if isinstance(value, bool):
            text = "true" if value else "false"
        elif isinstance(value, str):
            text = '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
        else:
            text = repr(value)
        lines.append(f"{key} = {text}")
    write_text_atomic(path, "\n".join(lines) + "\n")


def race_command(setup: Path, robot: str) -> str:
    """The command that races `robot` (a --robot spec) with a setup file: --robot only for another
    robot than the default one, which races without it."""
    import shlex

    from boxbox.robot.loader import DEFAULT_ROBOT

    spec = "" if robot == DEFAULT_ROBOT else f" --robot {shlex.quote(robot)}"
    return f"boxbox race{spec} --setup {shlex.quote(str(setup))}"
