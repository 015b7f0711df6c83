"""Test a robot's `drive()` without racing (docs/robots.md, "Testing a robot without TORCS").

`load_track` and `load_car` give the `Track` and `Car` a race gives `on_track`, read from the
installed TORCS by a 0-lap race the first time (under a second) and from the cache after
(torcs/track_record.py); `make_state` builds a `State` from the fields a test cares about; and
`recorded_states` yields the `State` of each drive step of a race already run, from its run dir's
states.parquet, which every race with telemetry writes (torcs/telemetry.py).
"""

from __future__ import annotations

import numbers
from collections.abc import Iterator
from pathlib import Path

from boxbox.errors import UsageError
from boxbox.model import Car, Opponent, State, Track
from boxbox.model.names import NoSuchField

DEFAULT_TRACK = "e-track-2"  # `boxbox race`'s defaults
DEFAULT_CAR = "car1-trb1"
# A car standing on the track's middle at the start line of a 1-lap race, alone, in first gear:
# every State field a test does not name.
STATE_DEFAULTS: dict[str, float] = {name: 0.0 for name in State._fields if name != "opponents"}
STATE_DEFAULTS.update(to_right_m=5.0, to_left_m=5.0,  # on the middle of a 10 m wide road
                      gear=1.0, fuel_l=50.0, laps=1.0, total_laps=1.0, position=1.0,
                      # each wheel's suspension travel at rest (0 is on the packers); car1-trb1 rests at about 0.1 m
                      travel_fr_m=0.1, travel_fl_m=0.1, travel_rr_m=0.1, travel_rl_m=0.1)


def load_track(name: str, car: str = DEFAULT_CAR) -> Track:
    """The track `name` as a robot's `on_track` gets it (with `car`: the pit boxes are the car's)."""
    from boxbox.torcs.track_record import recorded_track

    return recorded_track(name, car)[0]


def load_car(name: str = DEFAULT_CAR, track: str = DEFAULT_TRACK) -> Car:
    """The car `name` as a robot's `on_track` gets it on `track` (its box and grid slot are the
    track's; every constant is the car's)."""
    from boxbox.torcs.track_record import recorded_track

    return recorded_track(track, name)[1]


def make_state(**fields: float | tuple[Opponent, ...]) -> State:
    """A State with the given fields, the rest from STATE_DEFAULTS (`n_opponents` counts the
    `opponents` given).  Numbers are made floats, as TORCS sends them; a name that is no field is a
    TypeError naming the nearest fields."""
    values: dict = dict(STATE_DEFAULTS, opponents=())
    for name, value in fields.items():
        if name not in values:
            raise TypeError(str(NoSuchField(State, name)))
        if name == "opponents":
            if not all(isinstance(o, Opponent) for o in value):  # type: ignore[union-attr]
                raise TypeError("make_state: opponents must be a tuple of boxbox.model.Opponent")
            values[name] = tuple(value)  # type: ignore[arg-type]
        elif isinstance(value, numbers.Real) and not isinstance(value, bool):
            values[name] = float(value)
        else:
            raise TypeError(f"make_state: {name} must be a number, not {type(value).__name__} ({value!r})")
    if "n_opponents" not in fields:
        values["n_opponents"] = float(len(values["opponents"]))
    return State(**values)


def recorded_states(run_dir: str | Path, car: int = 0) -> Iterator[State]:
    """The State of each drive step of a Python car (its robot index: 0 for the first `--robot`) in
    the race run in `run_dir`, in order, as its robot got them, without the other cars: opponents
    are not recorded at every step, so `opponents` is () (`n_opponents` says how many there were).
    A pit stop is not a drive step: its state is not among them."""
    from boxbox.torcs.rundir import RunDir
    from boxbox.torcs.telemetry import load_states

    path = RunDir(run_dir).states
    if not path.is_file():
        raise UsageError(f"no {path.name} in {run_dir}: race with telemetry (without --no-telemetry) and "
                         "--run-dir, or use the run dir a race printed")
    rows = load_states(path, car)
    if not len(rows):
        raise UsageError(f"{path} holds no drive step of car {car} (0 is the first --robot)")
    make = State._make
    for row in rows.tolist():
        row.append(())
        yield make(row)
