"""`boxbox bench-pits`: the two ways into the box compared on real races.

Each track is raced with stops asked on laps 1..N-1 (`--pit-laps`), once per pit mode; the table
gives per mode and track the stops captured by TORCS, penalties, the stop error against the box
centre and the time from pit entry to pit exit.
"""

from __future__ import annotations

import statistics
from concurrent.futures import ProcessPoolExecutor

from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.options import PIT_MODES
from boxbox.robot.base import RaceOptions
from boxbox.torcs import catalog, launch
from boxbox.torcs.setup import Overlay


def _race(args) -> dict:
    overlay, track, laps, mode, cpu, skill_level = args
    stops = tuple(range(1, laps))
    cfg = launch.RaceConfig(track=track, category=catalog.check_track(track), laps=laps, robots=["boxbox"], cpu=cpu,
                            options=RaceOptions(pit_laps=stops, pit_mode=mode), skill_level=skill_level)
    result = launch.run_race(cfg, overlay)
    d = result.drivers[0]
    events = [e for e in d.pit_events if e.get("stop_time") is not None]
    errors = [abs(e["stop_error_m"]) for e in events]
    lane = [e["exit_time"] - e["entry_time"] for e in events if e.get("exit_time")]
    return {"track": track, "mode": mode, "asked": len(stops), "captured": d.pit_stops, "penalty": d.penalty_time,
            "gave_up": sum(1 for e in d.pit_events if e.get("gave_up")), "time": d.time,
            "error_mean_m": statistics.fmean(errors) if errors else None,
            "error_max_m": max(errors) if errors else None,
            "lane_mean_s": statistics.fmean(lane) if lane else None, "error": result.error}


def run_pit_bench(overlay: Overlay, tracks: list[str], laps: int, jobs: int, console: Console,
                  skill_level: SkillLevel = DEFAULT_SKILL_LEVEL) -> tuple[Table, list]:
    for t in tracks:
        catalog.check_track(t)
    work = [(overlay, t, laps, m, i % jobs, skill_level)
            for i, (t, m) in enumerate((t, m) for t in tracks for m in PIT_MODES)]
    rows = []
    with Progress(console=console, transient=True) as bar, ProcessPoolExecutor(jobs) as pool:
        task = bar.add_task(f"pit stops: {len(work)} races", total=len(work))
        for row in pool.map(_race, work):
            rows.append(row)
            bar.advance(task)
    table = Table(title=f"bench-pits: stops asked on laps 1..{laps - 1} of {laps}, car1-trb1, alone, "
                        f"skill level {skill_level.torcs_name}")
    for col in ("track", "mode", "captured", "penalty s", "gave up", "|stop error| mean m", "max m",
                "pit entry to exit s", "race time s"):
        table.add_column(col, justify="left" if col in ("track", "mode") else "right")
    fmt = lambda v, f: "-" if v is None else format(v, f)  # noqa: E731
    for r in rows:
        table.add_row(r["track"], r["mode"], f"{r['captured']}/{r['asked']}", f"{r['penalty']:.1f}", str(r["gave_up"]),
                      fmt(r["error_mean_m"], ".2f"), fmt(r["error_max_m"], ".2f"), fmt(r["lane_mean_s"], ".2f"),
                      f"{r['time']:.2f}" + (" (error)" if r["error"] else ""))
    return table, rows
