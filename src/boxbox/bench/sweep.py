"""`boxbox sweep`: one robot alone on every installed track, and on one track with every car.

A reliability check, built on the bench (same parallel races, same cache): per race, whether it
finished, its time, damage, pit stops, and what the robot host counted on every drive step (time
stuck below 1 m/s outside the pit, the longest such spell, time with the car's centre off the
track).  Each race is held to three targets: finished, damage under 1000, no stuck spell over 10 s.
"""

from __future__ import annotations

import shlex
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from boxbox.bench.cache import package_version
from boxbox.bench.solo import BenchSpec, plan, race_or_recall, row_of
from boxbox.files import write_json_atomic, write_text_atomic
from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.options import LearningMode
from boxbox.report.tables import fmt_time
from boxbox.torcs import catalog
from boxbox.torcs.setup import Overlay

MAX_DAMAGE = 1000  # a race's damage must stay under this
MAX_STUCK_S = 10.0  # and no stuck spell may be longer


@dataclass
class SweepSpec:
    robot: str = "boxbox"
    car: str = "car1-trb1"  # the car on every track
    cars_track: str = "g-track-1"  # the track every car races on
    laps: int = 3
    jobs: int = 2
    use_cache: bool = True
    learning: LearningMode = "fresh"
    tracks: list[str] | None = None  # None: every installed track
    cars: list[str] | None = None  # None: every installed car
    skill_level: SkillLevel = DEFAULT_SKILL_LEVEL
    step_budget_ms: int = 200
    cluster: str | None = None  # a Ray cluster's address: the races run there (bench/cluster.py)


@dataclass
class SweepResult:
    spec: SweepSpec
    rows: list[dict] = field(default_factory=list)
    wall_s: float = 0.0
    raced: int = 0
    cached: int = 0
    command: str = ""

    @property
    def failed(self) -> list[dict]:
        return [r for r in self.rows if r["misses"]]

    def summary(self) -> str:
        races = list({(r["track"], r["car"]): r for r in self.rows}.values())  # a race in both parts counts once
        n, bad = len(races), sum(bool(r["misses"]) for r in races)
        finished = sum(r["finished"] for r in races)
        worst_damage = max(self.rows, key=lambda r: r["damage"], default=None)
        worst_stuck = max(self.rows, key=lambda r: r["longest_stuck_s"] or 0.0, default=None)
        text = f"{n - bad} of {n} races met every target; {finished} of {n} finished"
        if worst_damage:
            text += f"; most damage {worst_damage['damage']} ({worst_damage['track']}, {worst_damage['car']})"
        if worst_stuck:
            text += (f"; longest stuck spell {worst_stuck['longest_stuck_s'] or 0.0:.2f} s "
                     f"({worst_stuck['track']}, {worst_stuck['car']})")
        return text

    def to_json(self) -> dict:
        return {"command": self.command, "robot": self.spec.robot, "laps": self.spec.laps,
                "targets": {"finished": True, "damage_below": MAX_DAMAGE, "longest_stuck_s_at_most": MAX_STUCK_S},
                "wall_s": round(self.wall_s, 1), "raced": self.raced, "cached": self.cached,
                "summary": self.summary(), "rows": self.rows}

    def table(self) -> Table:
        table = Table(title=f"sweep: {self.spec.robot}, {self.spec.laps} laps, alone, skill level "
                            f"{self.spec.skill_level.torcs_name}; "
                            f"targets: finished, damage < {MAX_DAMAGE}, stuck spells <= {MAX_STUCK_S:g} s")
        for col in COLUMNS:
            table.add_column(col, justify="left" if col in ("part", "track", "car", "result") else "right",
                             no_wrap=col != "result")
        for i, r in enumerate(self.rows):
            cells = _cells(r)
            if r["misses"]:
                cells[-1] = f"[red]{escape(cells[-1])}[/]"
            nxt = self.rows[i + 1]["part"] if i + 1 < len(self.rows) else r["part"]
            table.add_row(*cells, end_section=nxt != r["part"])
        return table

    def markdown(self) -> str:
        lines = [f"# Sweep: {self.spec.robot} on every track and with every car", "",
                 "Made by", "", "```", self.command, "```", "",
                 f"on {time.strftime('%Y-%m-%d')}, boxbox sources {package_version()}, "
                 f"{self.raced} races raced and {self.cached} from the bench cache in {self.wall_s:.0f} s. "
                 f"Each race: the robot alone, {self.spec.laps} laps, learning `{self.spec.learning}`. "
                 f"Targets: finished, damage under {MAX_DAMAGE}, no stuck spell longer than {MAX_STUCK_S:g} s.", "",
                 f"**{self.summary()}.**", "",
                 "Stuck: time below 1 m/s outside the pit; longest: the longest such spell; off track: time with "
                 "the car's centre beyond a track edge (the pit lane does not count). Counted by the robot host "
                 "on every drive step (0.020 or 0.022 s).", "",
                 "| " + " | ".join(COLUMNS) + " |",
                 "|" + "|".join("---" if c in ("part", "track", "car", "result") else "---:" for c in COLUMNS) + "|"]
        for r in self.rows:
            lines.append("| " + " | ".join(c.replace("|", "/") for c in _cells(r)) + " |")
        return "\n".join(lines) + "\n"


COLUMNS = ["part", "track", "car", "finished", "laps", "time", "damage", "pits", "stuck s", "longest stuck s",
           "off track s", "result"]


def _cells(r: dict) -> list[str]:
    def num(v) -> str:
        return "-" if v is None else f"{v:.2f}"

    return [r["part"], f"{r['track']} ({r['category']})", r["car"], "yes" if r["finished"] else "no",
            str(r["laps"]), fmt_time(r["time"]), str(r["damage"]), str(r["pit_stops"]), num(r["stuck_s"]),
            num(r["longest_stuck_s"]), num(r["off_track_s"]), "; ".join(r["misses"]) or "ok"]


def misses(row: dict, laps: int) -> list[str]:
    """The targets a sweep row misses, each in a few words."""
    out = []
    if row["error"]:
        out.append(row["error"].splitlines()[0])
    elif row["laps"] < laps:
        out.append(f"not finished: {row['laps']}/{laps} laps")
    if row["damage"] >= MAX_DAMAGE:
        out.append(f"damage {row['damage']} >= {MAX_DAMAGE}")
    if row["longest_stuck_s"] is None and not row["error"]:
        out.append("stuck time not measured")
    elif (row["longest_stuck_s"] or 0.0) > MAX_STUCK_S:
        out.append(f"stuck {row['longest_stuck_s']:.1f} s > {MAX_STUCK_S:g} s")
    return out


def sweep_specs(spec: SweepSpec) -> list[tuple[str, BenchSpec]]:
    tracks = spec.tracks if spec.tracks is not None else list(catalog.tracks())
    cars = spec.cars if spec.cars is not None else catalog.cars()
    def part(tracks: list[str], cars: list[str]) -> BenchSpec:
        return BenchSpec(tracks=tracks, cars=cars, robots=[spec.robot], laps=spec.laps, jobs=spec.jobs,
                         use_cache=spec.use_cache, learning=spec.learning, skill_level=spec.skill_level,
                         step_budget_ms=spec.step_budget_ms)

    return [("every track", part(tracks, [spec.car])), ("every car", part([spec.cars_track], cars))]


def check(spec: SweepSpec) -> None:
    """Every name and number checked before anything races (UsageError)."""
    for _, bench in sweep_specs(spec):
        plan(bench)


def run_sweep(spec: SweepSpec, overlay: Overlay, console: Console) -> SweepResult:
    started = time.perf_counter()
    planned = []  # (part, track, car, robot, job)
    for part, bench in sweep_specs(spec):
        rows, _ = plan(bench)
        planned += [(part, *row) for row in rows]
    unique = list({job.key: job for *_, job in planned}.values())
    outcomes, todo = race_or_recall(unique, overlay, spec.jobs, spec.use_cache, console, spec.cluster)
    result = SweepResult(spec=spec, raced=len(todo), cached=len(unique) - len(todo))
    for part, track, car, robot, job in planned:
        row = row_of(track, car, robot, job, *outcomes[job.key])
        row["part"] = part
        row["finished"] = not row["error"] and row["laps"] >= spec.laps
        row["misses"] = misses(row, spec.laps)
        result.rows.append(row)
    result.wall_s = time.perf_counter() - started
    return result


def command_line() -> str:
    """The command as typed (`boxbox ...`), for the table's heading."""
    return " ".join(shlex.quote(a) for a in ["boxbox", *sys.argv[1:]])


def write_outputs(result: SweepResult, json_file: Path | None, markdown_file: Path | None) -> None:
    if json_file:
        write_json_atomic(json_file, result.to_json(), indent=1)
    if markdown_file:
        write_text_atomic(markdown_file, result.markdown())
