"""Race results: TORCS's results file merged with what the robot host measured, and saved.

`merge_drivers` is the one place the two sources meet: TORCS's results file (rank, race time,
best lap, damage, pit stops, penalty, top speed) and the host's figures per Python car (lap times,
step times, incidents, missed pit stops, the robot's report), plus the lap times the host saw of
every other car. `save_result` writes the result to the run dir first, then to `--json`.
"""

from __future__ import annotations

import json
import types
import typing
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

from boxbox.files import write_json_atomic
from boxbox.torcs.paths import ROBOT_MODULE


def is_python_module(module: str) -> bool:
    """Whether a result's module is boxbox's bridge: the car is driven by a Python robot."""
    return module == ROBOT_MODULE


@dataclass
class DriverResult:
    name: str
    module: str
    idx: int
    car: str
    car_index: int = -1
    laps: int = 0
    time: float = 0.0  # total race time (s), as TORCS writes it
    best_lap: float = 0.0
    lap_times: list[float] = field(default_factory=list)
    damage: int = 0
    pit_stops: int = 0
    penalty_time: float = 0.0
    top_speed: float = 0.0  # m/s
    rank: int = 0
    pit_events: list[dict] = field(default_factory=list)  # from the robot's race_report()
    report: dict = field(default_factory=dict)  # the rest of the robot's race_report()
    start_fuel_l: float | None = None  # Python robots only
    step_us_median: float | None = None
    step_us_p99: float | None = None
    # Python robots only, from every drive step (None: not measured): time below 1 m/s outside the
    # pit, the longest such spell, and time with the car's centre beyond a track edge (pit lane excluded)
    stuck_s: float | None = None
    longest_stuck_s: float | None = None
    off_track_s: float | None = None
    # pit stops the robot asked for (pit_request) that were not made: lap, reason, detail (torcs/pitwatch.py)
    missed_pit_stops: list[dict] = field(default_factory=list)

    @property
    def is_python(self) -> bool:
        """A car driven by a Python robot (through boxbox's bridge), not by one of TORCS's robots."""
        return is_python_module(self.module)

    @classmethod
    def from_json(cls, data: dict) -> DriverResult:
        """The driver `to_json` wrote (result.json, the bench cache); ValueError for a field of the
        wrong type (json_problem), TypeError for an unknown one."""
        problem = json_problem(cls, data)
        if problem:
            raise ValueError(problem)
        return cls(**data)


# a field's annotation -> the JSON values it takes (a float takes an int; JSON has no tuple)
_JSON_TYPES: dict[type, tuple[type, ...]] = {str: (str,), int: (int,), float: (int, float), list: (list,),
                                             dict: (dict,)}
_ITEM_NAMES: dict[tuple[type, ...], str] = {(int, float): "numbers", (dict,): "objects"}


def json_problem(cls: type, data: dict, where: str = "") -> str | None:
    """What makes `data` (a parsed result.json, or one of its drivers) other than dataclass `cls`,
    or None: each field present must have its type, from the field's annotation (a missing one is
    left out; a list of dataclasses is checked item by item by its reader)."""
    for name, (allowed, items) in _json_types(cls).items():
        if name not in data:
            continue
        value = data[name]
        if not isinstance(value, allowed) or (isinstance(value, bool) and bool not in allowed):
            names = " or ".join("null" if t is type(None) else t.__name__ for t in allowed)
            return f"{where}{name} is {json.dumps(value)[:40]}, not {names}"
        if items and not all(isinstance(v, items) and not isinstance(v, bool) for v in typing.cast(list, value)):
            return f"{where}{name} holds something other than {_ITEM_NAMES.get(items, 'its items')}"
    return None


def _json_types(cls: type) -> dict[str, tuple[tuple[type, ...], tuple[type, ...]]]:
    """Per field of dataclass `cls`: the types its JSON value may have, and those of a list's items
    (() when any)."""
    hints = typing.get_type_hints(cls)
    out = {}
    for f in fields(cls):
        hint = hints[f.name]
        union = typing.get_origin(hint) in (types.UnionType, typing.Union)
        allowed: tuple[type, ...] = ()
        items: tuple[type, ...] = ()
        for arg in typing.get_args(hint) if union else (hint,):
            if arg is type(None):
                allowed += (type(None),)
                continue
            allowed += _JSON_TYPES[typing.get_origin(arg) or arg]
            if typing.get_origin(arg) is list:
                items = _JSON_TYPES.get(typing.get_args(arg)[0], ())
        out[f.name] = (allowed, items)
    return out


@dataclass
class RaceResult:
    track: str
    category: str
    car: str
    laps: int
    wall_s: float = 0.0
    drivers: list[DriverResult] = field(default_factory=list)
    run_dir: str = ""
    error: str | None = None  # set when the race did not end properly
    skill_level: str = "semi-pro"  # TORCS's skill level of every car in the race
    # the race's time model (torcs/timing.py): step_budget_ms, setup_budget_ms, min_speed_mps,
    # sim_limit_s (None: no Python car measured the track), wall_limit_s
    limits: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict) -> RaceResult:
        """The inverse of to_json (result.json, the bench cache); ValueError for a field of the wrong
        type (json_problem), TypeError for an unknown one."""
        problem = json_problem(cls, data)
        if problem:
            raise ValueError(problem)
        given = dict(data)
        given["drivers"] = [DriverResult.from_json(d) for d in given.get("drivers", [])]
        return cls(**given)


def _attrs(section: ET.Element) -> dict[str, str]:
    return {a.get("name", ""): a.get("val", "") for a in section if a.tag in ("attnum", "attstr")}


def parse_results_file(path: Path) -> list[dict[str, str]]:
    """The `Rank` entries of a TORCS results file, in rank order."""
    root = ET.parse(path).getroot()
    for section in root.iter("section"):
        if section.get("name") == "Rank":
            return [_attrs(entry) for entry in section.findall("section")]
    return []


def driver_from_rank(rank: int, entry: dict[str, str]) -> DriverResult:
    def num(key: str) -> float:
        try:
            return float(entry.get(key, 0) or 0)
        except ValueError:
            return 0.0

    laps = max(0, int(num("laps")))  # TORCS writes -1 for a car that never crossed the start line
    return DriverResult(
        name=entry.get("name", ""), module=entry.get("module", ""), idx=int(num("idx")), car=entry.get("car", ""),
        car_index=int(num("index")), laps=laps, time=num("time"), best_lap=num("best lap time"),
        damage=int(num("dammages")), pit_stops=int(num("pits stops")), penalty_time=num("penaltytime"),
        top_speed=num("top speed"), rank=rank if laps > 0 else 0)  # no lap done: no place


def leader_lap_times(progress: list[tuple[int, float]]) -> list[float]:
    """Lap times from TORCS's console lines (leader laps, sim time at that lap)."""
    times, last = [], 0.0
    for _, t in sorted(progress):
        times.append(round(t - last, 3))
        last = t
    return times


def merge_drivers(entries: list[dict[str, str]], host: dict, python_names: list[str], car: str,
                  others: list[DriverResult], laps_seen: list[tuple[int, float]]) -> list[DriverResult]:
    """Every driver of the race: TORCS's ranking (`entries`, from its results file) with the host's
    figures (`host`: its summary, or its last lap's progress); without a results file (a race cut
    short) the Python cars (`python_names`) and the TORCS robots (`others`) with what is known."""
    ours = {c["robot_index"]: c for c in host.get("cars", [])}
    other_laps = {int(k): v for k, v in host.get("other_lap_times", {}).items()}
    if entries:
        drivers = [driver_from_rank(i, e) for i, e in enumerate(entries, start=1)]
    else:
        drivers = [DriverResult(name=n, module=ROBOT_MODULE, idx=i, car=car) for i, n in enumerate(python_names)]
        drivers += others
    for d in drivers:
        if d.is_python and d.idx in ours:
            _add_host_figures(d, ours[d.idx])
        elif d.car_index in other_laps:
            d.lap_times = [round(t, 3) for t in other_laps[d.car_index]]
        elif len(drivers) == 1:
            d.lap_times = leader_lap_times(laps_seen)
        if entries and d.laps == len(d.lap_times) + 1:
            add_final_lap(d)
        if not entries:
            d.laps = len(d.lap_times)
        if d.lap_times and not d.best_lap:
            d.best_lap = min(d.lap_times)
    return drivers


def _add_host_figures(d: DriverResult, mine: dict) -> None:
    d.lap_times = [round(t, 3) for t in mine["lap_times"]]
    d.step_us_median, d.step_us_p99 = mine.get("step_us_median"), mine.get("step_us_p99")
    d.start_fuel_l = mine.get("start_fuel_l")
    d.stuck_s, d.longest_stuck_s, d.off_track_s = (mine.get(k) for k in ("stuck_s", "longest_stuck_s", "off_track_s"))
    d.missed_pit_stops = list(mine.get("missed_pit_stops", []))
    report = dict(mine.get("report", {}))
    d.pit_events = report.pop("pit_events", [])
    d.report = report
    if d.car_index < 0 and mine.get("car_index") is not None:
        d.car_index = mine["car_index"]


def add_final_lap(d: DriverResult) -> None:
    """TORCS ends the race in the simulation step the line is crossed, often before the robot's
    next drive call, so the host may never see the last lap's time: it is the race time less the
    laps before it (checked against TORCS's best lap, which counts it)."""
    last = round(d.time - sum(d.lap_times), 3)
    if d.time > 0 and d.best_lap and last >= d.best_lap - 0.005:
        d.lap_times.append(last)


def save_result(result: RaceResult, paths: list[Path]) -> list[tuple[Path, str]]:
    """Write the result to each path in turn (the run dir's result.json first, then --json), each
    whole or not at all; returns the paths that could not be written, with why."""
    failed = []
    for path in paths:
        try:
            write_json_atomic(path, result.to_json(), indent=1)
        except OSError as exc:
            failed.append((path, exc.strerror or str(exc)))
    return failed
