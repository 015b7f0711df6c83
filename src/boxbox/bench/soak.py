"""`boxbox soak`: long runs, watching the Python processes for growth in memory and open files.

Two parts:
  long   one long race (200 laps by default: the robot plans several pit stops); at every lap the
         robot host's and this process's resident memory (VmRSS) and open file descriptors are read
         (psutil).
  many   many short races back to back (200 x 1 lap by default) in this one process, as a robot
         author's session does; after each race this process's memory, open files, threads and
         children are read, and processes left behind are counted.

Growth is the least-squares slope over the samples after a warm-up (the first 10 % of the laps,
or of the races), given per 100 laps or per 100 races, next to the first and last value.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import psutil
from rich.console import Console
from rich.table import Table

from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.robot.base import RaceOptions
from boxbox.torcs import catalog, launch
from boxbox.torcs.setup import Overlay

# --- process readings (psutil) -----------------------------------------------------------------

def _process(pid: int | None) -> psutil.Process:
    return psutil.Process(pid)  # None: this process


def rss_kb(pid: int | None = None) -> int | None:
    """Resident memory (VmRSS) in kB, None when the process is gone."""
    try:
        return _process(pid).memory_info().rss // 1024
    except psutil.Error:
        return None


def open_fds(pid: int | None = None) -> int | None:
    try:
        return _process(pid).num_fds()
    except psutil.Error:
        return None


def threads(pid: int | None = None) -> int:
    try:
        return _process(pid).num_threads()
    except psutil.Error:
        return 0


def children(pid: int | None = None) -> list[int]:
    try:
        return [child.pid for child in _process(pid).children()]
    except psutil.Error:
        return []


def processes_mentioning(text: str) -> list[int]:
    """Live processes whose command line mentions text (a run dir)."""
    found = []
    for proc in psutil.process_iter(["cmdline"]):
        if proc.pid != os.getpid() and text in " ".join(proc.info["cmdline"] or ()):
            found.append(proc.pid)
    return found


def forked_children() -> list[int]:
    """Live children of this process running this same program: the robot host, which the
    launcher forks (its command line is the launcher's, so it cannot be found by the run dir)."""
    me = psutil.Process()
    mine = me.cmdline()
    found = []
    for child in me.children():
        try:
            if child.cmdline() == mine and child.status() != psutil.STATUS_ZOMBIE:
                found.append(child.pid)
        except psutil.Error:
            continue
    return found


def slope(xs: list[float], ys: list[float | None]) -> float | None:
    """Least-squares slope of ys over xs (samples where y is None left out)."""
    pairs = np.array([(x, y) for x, y in zip(xs, ys, strict=True) if y is not None], dtype=float)
    if len(pairs) < 2 or np.ptp(pairs[:, 0]) == 0:
        return None
    return float(np.polyfit(pairs[:, 0], pairs[:, 1], 1)[0])


# --- the runs ----------------------------------------------------------------------------------

@dataclass
class SoakSpec:
    track: str = "g-track-1"
    car: str = "car1-trb1"
    robot: str = "boxbox"
    long_laps: int = 200
    races: int = 200
    race_laps: int = 1
    telemetry: bool = True  # the races record telemetry (kept in the host's memory until the race ends)
    keep_runs: bool = False
    skill_level: SkillLevel = DEFAULT_SKILL_LEVEL


@dataclass
class Series:
    """One measured quantity over laps or races."""

    name: str
    unit: str
    xs: list[float] = field(default_factory=list)
    ys: list[float | None] = field(default_factory=list)

    def add(self, x: float, y: float | None) -> None:
        self.xs.append(x)
        self.ys.append(y)

    def figures(self, warmup_share: float = 0.1) -> dict:
        vals = [(x, y) for x, y in zip(self.xs, self.ys, strict=True) if y is not None]
        if not vals:
            return {"name": self.name, "unit": self.unit, "samples": 0}
        start = vals[0][0] + warmup_share * (vals[-1][0] - vals[0][0])
        steady = [(x, y) for x, y in vals if x >= start] or vals
        k = slope([x for x, _ in steady], [y for _, y in steady])
        return {"name": self.name, "unit": self.unit, "samples": len(vals), "values": vals, "first": vals[0][1],
                "after_warmup": steady[0][1], "last": vals[-1][1], "min": min(y for _, y in vals),
                "max": max(y for _, y in vals), "slope_per_100": None if k is None else round(100 * k, 2)}


@dataclass
class SoakResult:
    spec: SoakSpec
    long: dict = field(default_factory=dict)
    many: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        return {"spec": dataclasses.asdict(self.spec), "long": self.long, "many": self.many}


def _options(spec: SoakSpec, learning_dir: str, laps: int) -> RaceOptions:
    return RaceOptions(laps=laps, learning_dir=learning_dir)


def run_long(spec: SoakSpec, overlay: Overlay, work: Path, console: Console) -> dict:
    """One long race; host and launcher sampled at every lap."""
    run_dir = work / "long"
    cfg = launch.RaceConfig(track=spec.track, category=catalog.check_track(spec.track), car=spec.car,
                            laps=spec.long_laps, robots=[spec.robot], robot_names=[f"{spec.robot} 1"],
                            options=_options(spec, str(work / "learning"), spec.long_laps), run_dir=run_dir,
                            telemetry=spec.telemetry, skill_level=spec.skill_level)
    host_rss, host_fds = Series("robot host memory (VmRSS)", "kB"), Series("robot host open files", "fds")
    me_rss, me_fds = Series("launcher memory (VmRSS)", "kB"), Series("launcher open files", "fds")
    host_pid: list[int] = []
    spec_path = str(run_dir / "host-spec.json")

    def progress(lap: int, sim: float) -> None:
        if not host_pid:
            host_pid.extend((processes_mentioning(spec_path) or forked_children())[:1])
        if host_pid:
            host_rss.add(lap, rss_kb(host_pid[0]))
            host_fds.add(lap, open_fds(host_pid[0]))
        me_rss.add(lap, rss_kb())
        me_fds.add(lap, open_fds())
        if lap % 20 == 0:
            console.print(f"[dim]soak long race: lap {lap}/{spec.long_laps}, sim {sim:.0f} s, "
                          f"host {host_rss.ys[-1] if host_rss.ys else '?'} kB[/]")

    started = time.perf_counter()
    result = launch.run_race(cfg, overlay, progress)
    wall = time.perf_counter() - started
    me = next((d for d in result.drivers if d.is_python), None)
    return {"track": spec.track, "skill_level": spec.skill_level.torcs_name, "laps": spec.long_laps,
            "wall_s": round(wall, 1), "error": result.error,
            "laps_done": me.laps if me else 0, "race_time_s": me.time if me else 0.0,
            "pit_stops": me.pit_stops if me else 0, "damage": me.damage if me else 0,
            "lap_times_recorded": len(me.lap_times) if me else 0,
            "leftover_processes": len(processes_mentioning(str(run_dir))) + len(forked_children()),
            "series": [s.figures() for s in (host_rss, host_fds, me_rss, me_fds)]}


def run_many(spec: SoakSpec, overlay: Overlay, work: Path, console: Console,
             on_race: Callable[[int], None] | None = None) -> dict:
    """Short races back to back in this process; this process sampled after each."""
    category = catalog.check_track(spec.track)
    rss, fds = Series("launcher memory (VmRSS)", "kB"), Series("launcher open files", "fds")
    thr, kids = Series("launcher threads", ""), Series("launcher child processes", "")
    leftovers = errors = finished = 0
    started = time.perf_counter()
    for i in range(1, spec.races + 1):
        run_dir = work / "many" / f"race-{i:04d}"
        cfg = launch.RaceConfig(track=spec.track, category=category, car=spec.car, laps=spec.race_laps,
                                robots=[spec.robot], robot_names=[f"{spec.robot} 1"],
                                options=_options(spec, str(work / "learning"), spec.race_laps), run_dir=run_dir,
                                telemetry=spec.telemetry, skill_level=spec.skill_level)
        result = launch.run_race(cfg, overlay)
        errors += bool(result.error)
        finished += any(d.is_python and d.laps >= spec.race_laps for d in result.drivers)
        leftovers += len(processes_mentioning(str(run_dir))) + len(forked_children())
        rss.add(i, rss_kb())
        fds.add(i, open_fds())
        thr.add(i, threads())
        kids.add(i, len(children()))
        if not spec.keep_runs:
            shutil.rmtree(run_dir, ignore_errors=True)
        if on_race:
            on_race(i)
        if i % 20 == 0:
            console.print(f"[dim]soak: race {i}/{spec.races}, launcher {rss.ys[-1]} kB, {fds.ys[-1]} fds[/]")
    wall = time.perf_counter() - started
    return {"track": spec.track, "skill_level": spec.skill_level.torcs_name, "races": spec.races,
            "laps_each": spec.race_laps, "wall_s": round(wall, 1),
            "finished": finished, "errors": errors, "leftover_processes": leftovers,
            "series": [s.figures() for s in (rss, fds, thr, kids)]}


def run_soak(spec: SoakSpec, overlay: Overlay, console: Console, parts=("long", "many")) -> SoakResult:
    work = Path(tempfile.mkdtemp(prefix="boxbox-soak-"))
    result = SoakResult(spec=spec)
    try:
        if "long" in parts and spec.long_laps:
            result.long = run_long(spec, overlay, work, console)
        if "many" in parts and spec.races:
            result.many = run_many(spec, overlay, work, console)
    finally:
        if spec.keep_runs:
            console.print(f"[dim]soak runs kept in {work}[/]")
        else:
            shutil.rmtree(work, ignore_errors=True)
    return result


def tables(result: SoakResult) -> list[Table]:
    out = []
    for part, data in (("long", result.long), ("many", result.many)):
        if not data:
            continue
        if part == "long":
            title = (f"soak: one {data['laps']}-lap race on {data['track']} ({data['skill_level']}): "
                     f"{data['laps_done']} laps, "
                     f"{data['pit_stops']} pit stops, damage {data['damage']}, {data['wall_s']} s wall, "
                     f"leftover processes {data['leftover_processes']}"
                     + (f", error: {data['error']}" if data['error'] else ""))
            per = "per 100 laps"
        else:
            title = (f"soak: {data['races']} races of {data['laps_each']} lap(s) on {data['track']} "
                     f"({data['skill_level']}), back to back: "
                     f"{data['finished']} finished, {data['errors']} errors, leftover processes "
                     f"{data['leftover_processes']}, {data['wall_s']} s wall")
            per = "per 100 races"
        table = Table(title=title)
        for col in ("measure", "unit", "first", "after warm-up", "last", "min", "max", f"slope {per}"):
            table.add_column(col, justify="left" if col in ("measure", "unit") else "right")
        for s in data["series"]:
            if not s.get("samples"):
                table.add_row(s["name"], s["unit"], *["-"] * 6)
                continue
            table.add_row(s["name"], s["unit"], *(str(s[k]) for k in ("first", "after_warmup", "last", "min", "max")),
                          "-" if s["slope_per_100"] is None else f"{s['slope_per_100']:+.2f}")
        out.append(table)
    return out
