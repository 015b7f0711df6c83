"""`boxbox bench-field`: the robot under test from the back of a full field of TORCS robots.

On each track two races (issue #16): the robot starts last of ten behind nine TORCS robots in a
fixed grid order, then the same race with its slot taken by `inferno:3`, a TORCS robot in the same
car (car1-trb1), as the anchor.  Both are ordinary bench races (bench/solo.py): cached, raced in
parallel, their run dirs (result, telemetry) kept for `boxbox report`.

Figures per car: finishing place, gap to the winner, places gained on lap 1, its damage, the
damage of the whole field, and the laps lost in incidents: laps after the first more than
INCIDENT_S slower than the car's own median lap (lap 1 is left out: it holds the standing start).
Places and lap times of every car are known only in a race with a Python car (the robot host sees
them); the anchor race has none, so inferno:3's lap-1 gain and incidents are not measured.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from boxbox.bench.solo import BenchSpec, RaceJob, plan, race_or_recall
from boxbox.cache import cache_dir
from boxbox.errors import UsageError
from boxbox.files import write_json_atomic
from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.options import LearningMode
from boxbox.torcs.positions import positions_by_lap
from boxbox.torcs.results import DriverResult, RaceResult
from boxbox.torcs.setup import Overlay

FIELD = ("inferno:4", "berniw:3", "bt:2", "olethros:2", "lliaw:3", "tita:3", "damned:6", "bt:3", "berniw:4")
ANCHOR = "inferno:3"
CAR = "car1-trb1"  # the anchor's car: the robot under test drives the same
INCIDENT_S = 2.0  # a lap this much slower than the car's median lap was spoiled by an incident
LOW_DAMAGE = 300  # the racecraft target (issue #16, docs/racecraft.md): a race with less damage than this


@dataclass
class FieldSpec:
    tracks: list[str]
    robot: str = "boxbox"
    laps: int = 10
    jobs: int = 1
    use_cache: bool = True
    learning: LearningMode = "fresh"
    settings: dict | None = None
    skill_level: SkillLevel = DEFAULT_SKILL_LEVEL
    fuel_offset_l: float = 0.0  # added to the robot's start fuel (bench-field --repeats)
    step_budget_ms: int = 200
    cluster: str | None = None  # a Ray cluster's address: the races run there (bench/cluster.py)

    @property
    def start_slot(self) -> int:
        return len(FIELD) + 1


@dataclass
class FieldResult:
    spec: FieldSpec
    rows: list[dict] = field(default_factory=list)  # per track: the robot's row, then the anchor's
    wall_s: float = 0.0
    raced: int = 0
    cached: int = 0

    def to_json(self) -> dict:
        s = self.spec
        return {"tracks": s.tracks, "robot": s.robot, "anchor": ANCHOR, "field": list(FIELD), "laps": s.laps,
                "skill_level": s.skill_level.torcs_name, "learning": s.learning, "settings": s.settings or {},
                "incident_s": INCIDENT_S, "fuel_offset_l": s.fuel_offset_l, "rows": self.rows,
                "summary": self.summary()}

    def write_json(self, path) -> None:
        write_json_atomic(path, self.to_json(), indent=1)

    def summary(self) -> dict:
        robot = [r for r in self.rows if r["role"] == "robot"]
        anchor = {r["track"]: r for r in self.rows if r["role"] == "anchor"}
        races = [race_targets(r, anchor.get(r["track"])) for r in robot]
        return {"tracks": len(robot), "wins": sum(t.won for t in races),
                "max_damage": max((r["damage"] for r in robot), default=0),
                "low_damage": sum(t.low_damage for t in races),
                "ahead_of_anchor": sum(t.ahead_of_anchor for t in races),
                "field_damage_not_higher": sum(t.field_damage_not_higher for t in races),
                "every_target": sum(t.all_met for t in races)}

    def table(self) -> Table:
        s = self.spec
        table = Table(title=f"bench-field: {s.robot} and {ANCHOR} from P{s.start_slot} of {s.start_slot}, "
                            f"{s.laps} laps, {CAR}, skill level {s.skill_level.torcs_name}")
        for col in ("track", "car", "pos", "gap to winner", "lap-1 gain", "damage", "field damage",
                    f"incident laps (>{INCIDENT_S:g} s)", "winner", "run dir"):
            table.add_column(col, justify="left" if col in ("track", "car", "winner", "run dir") else "right",
                             no_wrap=col != "run dir")
        for n, r in enumerate(self.rows):
            first = r["role"] == "robot"
            style = "bold" if first else "dim"
            lost = "-" if r["incident_laps"] is None else f"{r['incident_laps']} ({r['incident_loss_s']:.1f} s)"
            table.add_row(r["track"] if first else "", f"[{style}]{r['entry']}[/]",
                          f"[{style}]{r['rank'] or '-'}[/]" if not r["error"] else "[red]error[/]",
                          _gap_text(r), "-" if r["lap1_gain"] is None else f"{r['lap1_gain']:+d}",
                          str(r["damage"]), str(r["field_damage"]), lost, r["winner"],
                          _first_line(r["error"]) if r["error"] else r["run_dir"].rsplit("/", 1)[-1],
                          end_section=not first and n < len(self.rows) - 1)
        return table

    def summary_line(self) -> str:
        m = self.summary()
        return (f"{self.spec.robot}: {m['wins']}/{m['tracks']} wins, damage under {LOW_DAMAGE} on "
                f"{m['low_damage']}/{m['tracks']} (highest {m['max_damage']}), "
                f"ahead of {ANCHOR} on {m['ahead_of_anchor']}/{m['tracks']}, field damage no higher than "
                f"with {ANCHOR} on {m['field_damage_not_higher']}/{m['tracks']}")


def _first_line(text: str, n: int = 80) -> str:
    line = text.splitlines()[0] if text else ""
    return f"[red]{escape(line if len(line) <= n else line[: n - 1] + '…')}[/]"


def ahead_of_anchor(r: dict, anchor: dict | None) -> bool:
    """Whether the robot's row r finished ahead of the anchor's row of the same track (an anchor
    not placed counts as behind; a robot not placed, or a failed race, as not ahead)."""
    if anchor is None or r["error"] or not r["rank"]:
        return False
    return not anchor["rank"] or r["rank"] < anchor["rank"]


class RaceTargets(NamedTuple):
    """One race of the robot against the racecraft targets."""

    won: bool
    low_damage: bool  # damage under LOW_DAMAGE
    ahead_of_anchor: bool
    field_damage_not_higher: bool  # than in the anchor's race

    @property
    def all_met(self) -> bool:
        """All four in the same race: what issue #16 asks for on 5 of the 6 tracks."""
        return self.won and self.low_damage and self.ahead_of_anchor and self.field_damage_not_higher


def race_targets(r: dict, anchor: dict | None) -> RaceTargets:
    """The robot's row r against the targets, with the anchor's row of the same track (None: no
    anchor race); a failed race has no damage figure, so it counts under none of them."""
    ok = not r["error"]
    return RaceTargets(r["rank"] == 1, ok and r["damage"] < LOW_DAMAGE, ahead_of_anchor(r, anchor),
                       ok and anchor is not None and r["field_damage"] <= anchor["field_damage"])


def _gap_text(r: dict) -> str:
    if r["laps_down"]:
        return f"+{r['laps_down']} lap{'s' if r['laps_down'] > 1 else ''}"
    return "-" if r["gap_s"] is None else ("winner" if r["rank"] == 1 else f"+{r['gap_s']:.3f}")


def incident_laps(lap_times: list[float], threshold_s: float = INCIDENT_S) -> tuple[int, float]:
    """(laps after the first slower than the median lap by more than threshold_s, the time they lost
    against the median); the median of all laps after the first."""
    later = lap_times[1:]
    if not later:
        return 0, 0.0
    median = statistics.median(later)
    slow = [t - median for t in later if t > median + threshold_s]
    return len(slow), round(sum(slow), 3)


def damage_taken(d: DriverResult) -> int:
    """Damage at the finish plus what pit stops repaired (known for Python cars, whose robot reports
    its stops; TORCS's results give only the damage at the finish)."""
    return d.damage + int(sum(e.get("repair") or 0 for e in d.pit_events if e.get("stop_time") is not None))


def car_figures(result: RaceResult, d: DriverResult, start_slot: int) -> dict:
    """The field figures of one car of a finished race."""
    winner = next((x for x in result.drivers if x.rank == 1), None)
    timed = [x for x in result.drivers if x.lap_times]
    lap1 = None
    if d.lap_times and len(timed) > 1:  # every car's laps: a race with a Python car (its host saw them)
        places = positions_by_lap([x.lap_times for x in timed])
        lap1 = start_slot - places[timed.index(d)][0]
    laps_down = (winner.laps - d.laps) if winner else 0
    gap = round(d.time - winner.time, 3) if winner and not laps_down and d.time else None
    lost = incident_laps(d.lap_times) if d.lap_times else None
    return {"rank": d.rank, "laps": d.laps, "time": round(d.time, 3), "gap_s": gap, "laps_down": laps_down,
            "lap1_gain": lap1, "damage": damage_taken(d), "field_damage": sum(damage_taken(x) for x in result.drivers),
            "incident_laps": lost[0] if lost else None, "incident_loss_s": lost[1] if lost else None,
            "winner": f"{winner.name} ({winner.module}:{winner.idx})" if winner else "-",
            "lap_times": list(d.lap_times)}


def _driver(result: RaceResult, role: str, entry: str) -> DriverResult | None:
    if role == "robot":
        return next((x for x in result.drivers if x.is_python), None)
    module, _, idx = entry.partition(":")
    return next((x for x in result.drivers if x.module == module and x.idx == int(idx)), None)


def _row(track: str, role: str, entry: str, outcome, start_slot: int) -> dict:
    result, error, cached = outcome
    row = {"track": track, "role": role, "entry": entry, "error": error, "cached": cached,
           "run_dir": result.run_dir if result else "", "rank": 0, "laps": 0, "time": 0.0, "gap_s": None,
           "laps_down": 0, "lap1_gain": None, "damage": 0, "field_damage": 0, "incident_laps": None,
           "incident_loss_s": None, "winner": "-", "lap_times": []}
    d = _driver(result, role, entry) if result else None
    if result is not None and d is None and not error:
        row["error"] = f"{entry} is not in the race's results"
    if result is not None and d is not None:
        row.update(car_figures(result, d, start_slot))
    return row


def _specs(spec: FieldSpec) -> tuple[BenchSpec, BenchSpec]:
    common: dict[str, Any] = {
        "tracks": spec.tracks, "cars": [CAR], "laps": spec.laps, "together": True, "jobs": spec.jobs,
        "use_cache": spec.use_cache, "learning": spec.learning, "settings": spec.settings,
        "skill_level": spec.skill_level, "fuel_offset_l": spec.fuel_offset_l, "step_budget_ms": spec.step_budget_ms,
        "cluster": spec.cluster}
    if spec.robot in FIELD or spec.robot == ANCHOR:
        raise UsageError(f"--robot {spec.robot} is already in the field; give a Python robot (boxbox, file.py:Class)")
    robot = BenchSpec(robots=[spec.robot, *FIELD], grid_position=spec.start_slot, **common)
    anchor = BenchSpec(robots=[*FIELD, ANCHOR], **common)
    return robot, anchor


def plan_field(spec: FieldSpec) -> list[tuple[str, str, str, RaceJob]]:
    """(track, role, entry, job) per row: the robot's race and the anchor's on each track; every
    name checked before anything races."""
    robot_spec, anchor_spec = _specs(spec)
    robot_rows, robots = plan(robot_spec)
    if robots[0].kind != "python":
        raise UsageError(f"--robot {spec.robot} is a TORCS robot; bench-field races a Python robot "
                         "(boxbox, file.py:Class) against TORCS's")
    anchor_rows, _ = plan(anchor_spec)
    robot_job = {t: job for t, _, r, job in robot_rows if r.entry == spec.robot}
    anchor_job = {t: job for t, _, r, job in anchor_rows if r.entry == ANCHOR}
    out = []
    for track in spec.tracks:
        out += [(track, "robot", spec.robot, robot_job[track]), (track, "anchor", ANCHOR, anchor_job[track])]
    for track, role, _, job in out:
        job.run_dir = str(runs_root() / f"{track}-{role}-{job.key[:12]}")
    return out


def runs_root() -> Path:
    """bench-field's run dirs: one per race (named by its cache key), never pruned with the
    automatic run dirs, so `boxbox report` works on every race of the table."""
    return cache_dir() / "bench-field"


def run_field(spec: FieldSpec, overlay: Overlay, console: Console) -> FieldResult:
    return run_fields([spec], overlay, console)[0]


def run_fields(specs: list[FieldSpec], overlay: Overlay, console: Console) -> list[FieldResult]:
    """Several bench-field runs (lengths, repeats) whose races run as one batch, with the first
    spec's jobs, cache and cluster: one tail of races finishing alone instead of one a run, and one
    connection to a cluster.  Each result's `wall_s` is the batch's."""
    started = time.perf_counter()
    plans = [plan_field(spec) for spec in specs]
    uniques = [list({job.key: job for *_, job in plan}.values()) for plan in plans]
    every = list({job.key: job for unique in uniques for job in unique}.values())
    first = specs[0]
    outcomes, todo = race_or_recall(every, overlay, first.jobs, first.use_cache, console, first.cluster)
    raced = {job.key for job in todo}
    wall_s = time.perf_counter() - started
    return [FieldResult(spec, [_row(track, role, entry, outcomes[job.key], spec.start_slot)
                               for track, role, entry, job in plan], wall_s=wall_s,
                        raced=sum(job.key in raced for job in unique),
                        cached=sum(job.key not in raced for job in unique))
            for spec, plan, unique in zip(specs, plans, uniques, strict=True)]
