"""`boxbox bench-learning`: does what a robot learns make its next races faster?

Per track, N races in a row share one learning store (a new one per run, in the cache's
bench-learning folder): race 1 starts from nothing, like `--learning fresh`, and every later race
from what the ones before it learned, like `--learning on` would after them.  The table gives each
race's time and damage and the last race against the first: learning that only ratchets down
(a turn slowed for good by one bad lap) shows as a last race slower than the first.
"""

from __future__ import annotations

import shutil
from concurrent.futures import ThreadPoolExecutor

from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from boxbox.cache import cache_dir
from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.robot.base import RaceOptions
from boxbox.torcs import catalog, launch
from boxbox.torcs.setup import Overlay


def _track_series(overlay: Overlay, track: str, laps: int, races: int, robot: str, cpu: int,
                  skill_level: SkillLevel, advance) -> dict:
    """The races of one track in a row on one learning store."""
    store = cache_dir() / "bench-learning" / f"{track}--{robot.replace('/', '_').replace(':', '_')}"
    shutil.rmtree(store, ignore_errors=True)
    rows = []
    for _ in range(races):
        cfg = launch.RaceConfig(track=track, category=catalog.check_track(track), laps=laps, robots=[robot], cpu=cpu,
                                options=RaceOptions(learning_dir=str(store)), skill_level=skill_level,
                                telemetry=False)
        result = launch.run_race(cfg, overlay)
        d = result.drivers[0]
        rows.append({"time": d.time, "damage": d.damage, "laps": d.laps, "error": result.error})
        advance()
    return {"track": track, "races": rows}


def run_learning_bench(overlay: Overlay, tracks: list[str], laps: int, races: int, robot: str, jobs: int,
                       console: Console, skill_level: SkillLevel = DEFAULT_SKILL_LEVEL) -> tuple[Table, list]:
    for t in tracks:
        catalog.check_track(t)
    with Progress(console=console, transient=True) as bar, ThreadPoolExecutor(jobs) as pool:
        task = bar.add_task(f"learning: {len(tracks)} tracks x {races} races", total=len(tracks) * races)
        futures = [pool.submit(_track_series, overlay, t, laps, races, robot, i % jobs, skill_level,
                               lambda: bar.advance(task)) for i, t in enumerate(tracks)]
        series = [f.result() for f in futures]
    return learning_table(series, laps, robot, skill_level), series


def learning_table(series: list[dict], laps: int, robot: str, skill_level: SkillLevel) -> Table:
    races = max(len(s["races"]) for s in series)
    table = Table(title=f"bench-learning: {robot}, {races} races of {laps} laps in a row on one learning store "
                        f"(race 1 = learning fresh), car1-trb1, skill level {skill_level.torcs_name}")
    table.add_column("track")
    for i in range(races):
        table.add_column(f"race {i + 1} s (damage)", justify="right")
    table.add_column("last - first s", justify="right")
    for s in series:
        rs = s["races"]
        cells = [f"{r['time']:.3f} ({r['damage']:.0f})" + (" error" if r["error"] else "") for r in rs]
        delta = rs[-1]["time"] - rs[0]["time"]
        mark = "[green]" if delta <= 0.0 else "[red]"
        table.add_row(s["track"], *cells, f"{mark}{delta:+.3f}[/]")
    return table
