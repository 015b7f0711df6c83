"""Race results: TORCS's results file merged with what the robot host measured."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, field
from pathlib import Path

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

    @property
    def is_python(self) -> bool:
        """A car driven by a Python robot (through boxbox's bridge), not by one of TORCS's robots."""
        return is_python_module(self.module)


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

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict) -> RaceResult:
        """The inverse of to_json (result.json, the bench cache)."""
        fields = dict(data)
        fields["drivers"] = [DriverResult(**d) for d in fields.get("drivers", [])]
        return cls(**fields)


def _attrs(section: ET.Element) -> dict[str, str]:
    return {a.get("name"): a.get("val") for a in section if a.tag in ("attnum", "attstr")}


def parse_results_file(path: Path) -> list[dict[str, str]]:
    """The `Rank` entries of a TORCS results file, in rank order."""
    root = ET.parse(path).getroot()
    for section in root.iter("section"):
        if section.get("name") == "Rank":
            return [_attrs(entry) for entry in section.findall("section")]
    return []


def find_results_file(local_dir: Path) -> Path | None:
    files = sorted((local_dir / "results").glob("*/results-*.xml"))
    return files[-1] if files else None


def driver_from_rank(rank: int, entry: dict[str, str]) -> DriverResult:
    def num(key: str) -> float:
        try:
            return float(entry.get(key, 0) or 0)
        except ValueError:
            return 0.0

    return DriverResult(
        name=entry.get("name", ""), module=entry.get("module", ""), idx=int(num("idx")), car=entry.get("car", ""),
        car_index=int(num("index")), laps=int(num("laps")), time=num("time"), best_lap=num("best lap time"),
        damage=int(num("dammages")), pit_stops=int(num("pits stops")), penalty_time=num("penaltytime"),
        top_speed=num("top speed"), rank=rank)


def leader_lap_times(progress: list[tuple[int, float]]) -> list[float]:
    """Lap times from TORCS's console lines (leader laps, sim time at that lap)."""
    times, last = [], 0.0
    for _, t in sorted(progress):
        times.append(round(t - last, 3))
        last = t
    return times
