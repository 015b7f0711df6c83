"""Rich tables for results, and the time format every table and page uses."""

from __future__ import annotations

import math

from rich.table import Table

from boxbox.torcs.results import RaceResult


def fmt_time(seconds: float | None) -> str:
    """'1:02.345' (or '42.345' under a minute); '-' for no time (None, 0, NaN)."""
    if not seconds or math.isnan(seconds):
        return "-"
    minutes, sec = divmod(float(seconds), 60.0)
    return f"{int(minutes)}:{sec:06.3f}" if minutes else f"{sec:.3f}"


def results_table(result: RaceResult) -> Table:
    title = (f"{result.track} ({result.category}), {result.car}, {result.laps} laps, skill level {result.skill_level}, "
             f"{result.wall_s:.2f} s wall")
    if result.error:
        title += " [red](race stopped)[/]"
    table = Table(title=title)
    for col in ("#", "driver", "car", "laps", "time", "best lap", "lap times", "damage", "pits", "penalty"):
        table.add_column(col, justify="left" if col in ("driver", "car", "lap times") else "right")
    for d in result.drivers:
        table.add_row(str(d.rank or "-"), f"{d.name} [dim]({d.module}:{d.idx})[/]", d.car, str(d.laps),
                      fmt_time(d.time), fmt_time(d.best_lap), " ".join(fmt_time(t) for t in d.lap_times),
                      str(d.damage), str(d.pit_stops), f"{d.penalty_time:.1f}" if d.penalty_time else "-")
    return table
