"""A race's names and numbers checked against the installed TORCS, before anything starts.

Shared by the command line and Python callers: each check raises boxbox.errors.UsageError with one
line that says what to do.  They read the installed TORCS, so call them after the set-up
(`setup.ensure_ready`): on a fresh machine there is nothing to check against before it.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from boxbox.errors import UsageError
from boxbox.torcs import catalog
from boxbox.torcs.paths import MAX_PYTHON_CARS
from boxbox.torcs.wire import MAX_OPPONENTS

if TYPE_CHECKING:
    from boxbox.robot.base import RaceOptions

# Cars in one race: the race file's driver list declares at most 40 (`racefile.race_xml`), and the
# bridge hands a Python car at most wire.MAX_OPPONENTS others.
MAX_CARS = min(40, MAX_OPPONENTS + 1)


def check_opponents(entries: Iterable[str]) -> list[tuple[str, int]]:
    """'module:idx' entries -> (module, idx), each installed and none twice (TORCS aborts on a
    driver entered twice: both cars share the robot's state)."""
    opponents: list[tuple[str, int]] = []
    for entry in entries:
        module, idx = catalog.parse_opponent(entry)
        if (module, idx) in opponents:
            raise UsageError(f"opponent {module}:{idx} is given twice; TORCS races each driver once, "
                             f"so pick another index (`boxbox robots` lists them)")
        opponents.append((module, idx))
    return opponents


def check_field(python_cars: int, opponents: int) -> None:
    """The grid: at most MAX_PYTHON_CARS Python cars and MAX_CARS cars in all."""
    if python_cars > MAX_PYTHON_CARS:
        raise UsageError(f"{python_cars} Python cars: at most {MAX_PYTHON_CARS} race together; drop some --robot")
    total = python_cars + opponents
    if total > MAX_CARS:
        raise UsageError(f"{total} cars in one race: at most {MAX_CARS} race together; "
                         f"drop {total - MAX_CARS} opponent(s)")


def check_robots(specs: list[str], options: RaceOptions, track: str, car: str,
                 setup_budget_s: float | None = None) -> list[str]:
    """Each Python robot's class loaded and its settings checked, a robot that is not boxbox's own
    in a child process within the set-up budget (robot/loader.py), before the set-up, on the command
    line and in boxbox.race alike; the names its cars race under."""
    from boxbox.robot.loader import IMPORT_BUDGET_S, robot_names

    check_field(len(specs), 0)
    check_car_setup(options.car_setup, car)
    names = robot_names(specs, lambda cls: cls.check_setup(options, track, car),
                        IMPORT_BUDGET_S if setup_budget_s is None else setup_budget_s)
    return [f"{name} {i + 1}" for i, name in enumerate(names)]


def check_car_setup(values: dict, car: str) -> None:
    """The car setup's settings (--set, --setup: CarSetup's field names) against what the car allows,
    before TORCS starts: a value outside its range is a one-line error naming the range."""
    if not values:
        return
    from boxbox.model.car_setup import setup_from
    from boxbox.torcs.car_setup import car_settings

    catalog.check_car(car)
    problem = car_settings(car).problem(setup_from(values))
    if problem:
        raise UsageError(f"car setup: {problem}; give a value in range, or none for the car's own")


def check_pit_laps(track: str, pit_laps: Iterable[int], laps: int) -> None:
    """Stops asked for must come before the last lap, on a track that has a pit lane."""
    stops = sorted(pit_laps)
    if stops and stops[-1] >= laps:
        raise UsageError(f"--pit-laps {','.join(map(str, stops))}: a stop must come before the last lap "
                         f"({laps} laps); ask for earlier laps or a longer race")
    if stops and not catalog.has_pit_lane(track):
        raise UsageError(f"track '{track}' has no pit lane, so --pit-laps cannot be met; choose a track with pits")


def check_race(track: str, car: str, python_cars: int, opponents: Iterable[str] = (),
               pit_laps: Iterable[int] = (), laps: int = 1) -> tuple[str, list[tuple[str, int]]]:
    """Every check of one race; returns the track's category and the opponents as (module, idx)."""
    category = catalog.check_track(track)
    catalog.check_car(car)
    checked = check_opponents(opponents)
    check_field(python_cars, len(checked))
    check_pit_laps(track, pit_laps, laps)
    return category, checked


def check_grid_position(position: int | str | None, opponents: int) -> int | None:
    """The Python cars' first grid slot as a number (None: pole); 'last' is behind every TORCS robot."""
    if position is None:
        return None
    slot = opponents + 1 if position == "last" else int(position)
    if not 1 <= slot <= opponents + 1:
        raise UsageError(f"grid position {slot} is behind the field: with {opponents} TORCS robots the Python "
                         f"cars can start from 1 to {opponents + 1} (or 'last')")
    return slot
