"""The race results table, each column once (its header with its cell) for the console (rich) and
the HTML report, and the time format every table and page uses."""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

from rich.table import Table

from boxbox.torcs.results import RaceResult

KMH_PER_MPS = 3.6


def fmt_time(seconds: float | None) -> str:
    """'1:02.345' (or '42.345' under a minute); '-' for no time (None, 0, NaN)."""
    if not seconds or math.isnan(seconds):
        return "-"
    minutes, sec = divmod(float(seconds), 60.0)
    return f"{int(minutes)}:{sec:06.3f}" if minutes else f"{sec:.3f}"


def fmt_num(value, fmt: str = "{:.2f}") -> str:
    """`value` in `fmt`; '-' for none (None, NaN)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return fmt.format(value)


def driver_label(d: dict) -> str:
    """'name (module:idx)' of a driver of a result.json ('?' for what it lacks)."""
    return f"{d.get('name', '?')} ({d.get('module', '?')}:{d.get('idx', '?')})"


@dataclass(frozen=True)
class Column:
    """A column of the results table: its header and its cell, plain text from a driver as
    result.json holds it (the HTML report reads those, the console DriverResult's asdict; a field
    an older file lacks reads as its default).  `left`: text, aligned left on the console;
    `console_cell`: the console's cell where it adds rich markup."""

    header: str
    cell: Callable[[dict], str]
    left: bool = False
    console_cell: Callable[[dict], str] | None = None


def _penalty(d: dict) -> str:
    return fmt_num(d.get("penalty_time"), "{:.1f}") if d.get("penalty_time") else "-"


def _top_speed(d: dict) -> str:
    return fmt_num((d.get("top_speed") or 0) * KMH_PER_MPS, "{:.1f}") if d.get("top_speed") else "-"


COLUMNS = {c.header: c for c in (
    Column("#", lambda d: str(d.get("rank") or "-")),
    Column("driver", driver_label, left=True,
           console_cell=lambda d: f"{d.get('name', '?')} [dim]({d.get('module', '?')}:{d.get('idx', '?')})[/]"),
    Column("car", lambda d: d.get("car", ""), left=True),
    Column("laps", lambda d: str(d.get("laps", 0))),
    Column("time", lambda d: fmt_time(d.get("time"))),
    Column("best lap", lambda d: fmt_time(d.get("best_lap"))),
    Column("lap times", lambda d: " ".join(fmt_time(t) for t in d.get("lap_times", [])), left=True),
    Column("damage", lambda d: str(d.get("damage", 0))),
    Column("pits", lambda d: str(d.get("pit_stops", 0))),
    Column("penalty", _penalty),
    Column("penalty s", _penalty),
    Column("top km/h", _top_speed),
    Column("step µs (median)", lambda d: fmt_num(d.get("step_us_median"), "{:.1f}")),
)}
# which columns each table shows, by header
CONSOLE_RESULTS = ("#", "driver", "car", "laps", "time", "best lap", "lap times", "damage", "pits", "penalty")
HTML_RESULTS = ("#", "driver", "car", "laps", "time", "best lap", "damage", "pits", "penalty s", "top km/h",
                "step µs (median)")


def console_rows(table: Table, headers: Sequence[str], drivers: Sequence[dict]) -> Table:
    """`table` with the columns `headers` (COLUMNS) and a row per driver."""
    columns = [COLUMNS[h] for h in headers]
    for c in columns:
        table.add_column(c.header, justify="left" if c.left else "right")
    for d in drivers:
        table.add_row(*((c.console_cell or c.cell)(d) for c in columns))
    return table


def html_table(headers: Sequence[str], drivers: Sequence[dict], cls: str = "") -> str:
    """An HTML table of the columns `headers` (COLUMNS), a row per driver, every cell escaped."""
    columns = [COLUMNS[h] for h in headers]
    head = "".join(f"<th>{html.escape(c.header)}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c.cell(d))}</td>" for c in columns) + "</tr>"
                   for d in drivers)
    return f'<table class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def results_table(result: RaceResult) -> Table:
    title = (f"{result.track} ({result.category}), {result.car}, {result.laps} laps, skill level {result.skill_level}, "
             f"{result.wall_s:.2f} s wall")
    if result.error:
        title += " [red](race stopped)[/]"
    return console_rows(Table(title=title), CONSOLE_RESULTS, [asdict(d) for d in result.drivers])
