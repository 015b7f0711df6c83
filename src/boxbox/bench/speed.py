"""`boxbox bench-speed`: how much wall time a Python robot costs compared with a C++ robot."""

from __future__ import annotations

import statistics

from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.robot.loader import load_robot_class
from boxbox.torcs import catalog, launch
from boxbox.torcs.setup import Overlay


def run_speed_bench(overlay: Overlay, track: str, laps: int, runs: int, robot: str, against: str,
                    console: Console, skill_level: SkillLevel = DEFAULT_SKILL_LEVEL) -> Table:
    category = catalog.check_track(track)
    module, idx = catalog.parse_opponent(against)
    load_robot_class(robot)
    py_cfg = launch.RaceConfig(track=track, category=category, laps=laps, robots=[robot], skill_level=skill_level)
    c_cfg = launch.RaceConfig(track=track, category=category, laps=laps, robots=[], opponents=[(module, idx)],
                              skill_level=skill_level)
    walls: dict[str, list[float]] = {robot: [], against: []}
    medians: list[float] = []
    p99s: list[float] = []
    race_times: dict[str, float] = {}
    with Progress(console=console, transient=True) as bar:
        task = bar.add_task(f"{track}, {laps} laps", total=2 * runs)
        for _ in range(runs):  # alternate so that machine noise hits both alike
            for label, cfg in ((robot, py_cfg), (against, c_cfg)):
                result = launch.run_race(cfg, overlay)
                if result.error:
                    raise RuntimeError(f"{label}: {result.error.splitlines()[0]}")
                walls[label].append(result.wall_s)
                d = result.drivers[0]
                race_times[label] = d.time
                if d.step_us_median is not None and d.step_us_p99 is not None:
                    medians.append(d.step_us_median)
                    p99s.append(d.step_us_p99)
                bar.advance(task)
    py_wall, c_wall = statistics.median(walls[robot]), statistics.median(walls[against])
    table = Table(title=f"bench-speed: {track}, {laps} laps, car1-trb1, {runs} runs each (median wall time), "
                        f"skill level {skill_level.torcs_name}")
    for col in ("robot", "wall s (median)", "wall s (all)", "race time s", "ratio to " + against,
                "step median us", "step p99 us"):
        table.add_column(col, justify="right")
    table.add_row(robot, f"{py_wall:.2f}", " ".join(f"{w:.2f}" for w in walls[robot]), f"{race_times[robot]:.2f}",
                  f"{py_wall / c_wall:.2f}x", f"{statistics.median(medians):.1f}", f"{statistics.median(p99s):.1f}")
    table.add_row(against, f"{c_wall:.2f}", " ".join(f"{w:.2f}" for w in walls[against]),
                  f"{race_times[against]:.2f}", "1.00x", "-", "-")
    return table
