"""`boxbox report RUN_DIR`: one self-contained HTML page for a race, from result.json and telemetry.parquet.

Figures (report/figures.py) are drawn with matplotlib (no pyplot, no display) and embedded as base64 PNG, so the page
is a single file that opens anywhere.  What the page shows is described in docs/report.md.
"""

from __future__ import annotations

import html
import json
import time
from pathlib import Path

import numpy as np

from boxbox.errors import UsageError
from boxbox.report.damage import (
    MERGE_S,
    MOVED_S,
    damage_by_lap,
    damage_incidents,
    moved_text,
    nearest_text,
)
from boxbox.report.figures import (
    _field_places,
    _img,
    fig_damage_map,
    fig_lap,
    fig_lap_times,
    fig_map,
    fig_pit,
    fig_positions,
)
from boxbox.report.tables import HTML_RESULTS, driver_label, fmt_time, html_table
from boxbox.report.tables import KMH_PER_MPS as KMH
from boxbox.report.tables import fmt_num as _num
from boxbox.torcs.results import DriverResult, RaceResult, is_python_module, json_problem

REPORT_FILE = "report.html"


# --- helpers ---------------------------------------------------------------------------------------
def _table(headers: list[str], rows: list[list[str]], cls: str = "") -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f'<table class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _positions_table(drivers: list[dict], places: list[list[int]]) -> str:
    laps = max(len(p) for p in places)
    rows = [[html.escape(driver_label(d))] + [str(row[k]) if k < len(row) else "-" for k in range(laps)]
            for d, row in zip(drivers, places, strict=True)]
    return _table(["driver"] + [str(k + 1) for k in range(laps)], rows, "num")


def _results_table(r: dict) -> str:
    return html_table(HTML_RESULTS, r["drivers"])


def _lap_table(drivers: list[dict]) -> str:
    timed = [d for d in drivers if d.get("lap_times")]
    if not timed:
        return "<p>No lap times.</p>"
    laps = max(len(d["lap_times"]) for d in timed)
    rows = []
    for lap in range(laps):
        row = [str(lap + 1)]
        for d in timed:
            lt = d["lap_times"]
            cell = fmt_time(lt[lap]) if lap < len(lt) else "-"
            if lap < len(lt) and lt[lap] == min(lt):
                cell = f"<b>{cell}</b>"
            row.append(cell)
        rows.append(row)
    return _table(["lap"] + [driver_label(d) for d in timed], rows, "num")


def _pit_table(drivers: list[dict]) -> str:
    rows = []
    for d in drivers:
        for e in d.get("pit_events", []):
            stand = (e["leave_time"] - e["stop_time"]) if e.get("leave_time") and e.get("stop_time") else None
            lane = (e["exit_time"] - e["entry_time"]) if e.get("exit_time") and e.get("entry_time") else None
            rows.append([html.escape(driver_label(d)), str(e.get("lap")), html.escape(str(e.get("mode", ""))),
                         _num(e.get("entry_time")), _num(e.get("stop_time")), _num(e.get("leave_time")),
                         _num(e.get("exit_time")), _num(stand), _num(lane), _num(e.get("stop_error_m"), "{:+.3f}"),
                         _num(e.get("fuel"), "{:.1f}"), _num(e.get("repair"), "{:.0f}"),
                         "yes" if e.get("gave_up") else ""])
    if not rows:
        return _pit_counts(drivers)
    return _table(["driver", "lap", "mode", "entry s", "stop s", "leave s", "exit s", "standing s", "entry to exit s",
                   "stop error m", "fuel l", "repair", "gave up"], rows, "num")


def _pit_counts(drivers: list[dict]) -> str:
    """No robot reported its pit events (race_report's pit_events): the stops TORCS counted, if any."""
    stopped = [d for d in drivers if d.get("pit_stops")]
    if not stopped:
        return "<p>No pit events.</p>"
    counts = ", ".join(f"{html.escape(driver_label(d))}: {d['pit_stops']} pit stop{'s' if d['pit_stops'] != 1 else ''}"
                       for d in stopped)
    return (f"<p>{counts} (as TORCS counts them). No robot reported the details: a robot with "
            "<code>boxbox.PitStops</code> gives them by returning <code>self.pits.report()</code> from "
            "<code>race_report()</code>.</p>")


CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; margin: 1.5em auto;
       max-width: 1100px; color: #222; padding: 0 1em; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.6em; }
.meta { color: #555; } .error { background: #fde8e8; border: 1px solid #d62728; padding: 0.6em; }
.error pre { font-family: ui-monospace, "DejaVu Sans Mono", Menlo, Consolas, monospace; white-space: pre-wrap;
             margin: 0.4em 0 0; font-size: 0.9em; }
.note { color: #555; font-size: 0.9em; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
th { background: #f2f2f2; } table.num td { text-align: right; } table.num td:first-child { text-align: left; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #e4e4e4; }
figcaption { color: #555; font-size: 0.85em; }
details { margin: 0.4em 0; } summary { cursor: pointer; font-weight: 600; }
"""


def _read_result(run_dir: Path) -> dict:
    result_file = run_dir / "result.json"
    if not result_file.exists():
        raise UsageError(f"{run_dir} has no result.json: give the run directory of a race "
                         "(printed after `boxbox race`, or chosen with --run-dir)")
    try:
        result = json.loads(result_file.read_text())
    except ValueError as exc:
        raise UsageError(f"{result_file} is not valid JSON: {exc}") from None
    problem = result_problem(result)
    if problem:
        raise UsageError(f"{result_file} is not a boxbox race result: {problem}")
    return result


def result_problem(r) -> str | None:
    """What makes `r` (a parsed result.json) something other than a race result, or None: the
    fields the report reads, where present, must have their types (a missing one is left out)."""
    if not isinstance(r, dict):
        return f"it holds a {type(r).__name__}, not an object"
    problem = json_problem(RaceResult, r)
    if problem:
        return problem
    for i, d in enumerate(r.get("drivers", [])):
        if not isinstance(d, dict):
            return f"drivers[{i}] is a {type(d).__name__}, not an object"
        problem = json_problem(DriverResult, d, f"drivers[{i}].")
        if problem:
            return problem
    return None


def _read_telemetry(run_dir: Path):
    """(the run's telemetry or None, why there is none, its file)."""
    from boxbox.torcs.telemetry import FILE_NAME, load_telemetry

    tel_file = run_dir / FILE_NAME
    if not tel_file.exists():
        return None, "no telemetry recorded for this race (raced with --no-telemetry, or no Python car)", tel_file
    try:
        return load_telemetry(tel_file), "", tel_file
    except Exception as exc:
        return None, f"telemetry file unreadable: {type(exc).__name__}: {exc}", tel_file


def _damage_section(name: str, c: dict, track: dict, race_laps: int, names: dict[int, str]) -> str:
    """Where the car took its damage: a map of the incidents and their table, worst first, with
    the car nearest at each (names: TORCS car index -> driver name)."""
    incidents = damage_incidents(c)
    if not incidents:
        return "<h3>Damage</h3><p class='note'>No damage taken.</p>"
    by_lap = ", ".join(f"lap {lap}: {dmg}" for lap, dmg in damage_by_lap(incidents).items())
    recorded = "near_car" in c  # a run dir from before the nearest car was recorded: say so, not "none"
    rows = [[str(i.lap), f"{i.dist_m:.0f}", fmt_time(i.time_s), str(i.damage), str(i.hits), f"{i.speed_mps * KMH:.0f}",
             html.escape(nearest_text(i, names)) if recorded else "not recorded", moved_text(i)]
            for i in sorted(incidents, key=lambda i: -i.damage)]
    total = sum(i.damage for i in incidents)
    return ("<h3>Damage</h3>"
            f"<p class='note'>{len(incidents)} incidents (hits less than {MERGE_S:g} s apart are one), {total} damage "
            f"points in all; by lap: {html.escape(by_lap)}.</p>"
            + _img(fig_damage_map(incidents, track, race_laps, f"{name}: where the damage was taken"),
                   "Track map: each incident where it began, sized by its damage, coloured by lap")
            + _table(["lap", "from start (m)", "race time", "damage", "hits", "speed km/h", "nearest car",
                      f"moved towards it in {MOVED_S:g} s"], rows))


def build_report(run_dir: Path, limit: tuple[np.ndarray, np.ndarray] | None = None) -> str:
    """The HTML page for the race in run_dir (result.json required; telemetry.parquet when recorded);
    `limit`: the limit lap's speed (m/s) against distance (m), drawn in every lap's speed plot."""
    run_dir = Path(run_dir)
    r = _read_result(run_dir)
    drivers = r.get("drivers", [])
    tel, tel_note, tel_file = _read_telemetry(run_dir)
    parts = [f"<h1>{html.escape(r.get('track', '?'))} ({html.escape(r.get('category', ''))}), "
             f"{html.escape(r.get('car', ''))}, {r.get('laps', '?')} laps, "
             f"skill level {html.escape(str(r.get('skill_level', 'pro (before the level was recorded)')))}</h1>",
             f"<p class='meta'>Wall time {r.get('wall_s', 0):.2f} s · run dir <code>{html.escape(str(run_dir))}</code> "
             f"· report made {time.strftime('%Y-%m-%d %H:%M:%S')}</p>"]
    if r.get("error"):
        parts.append(f"<div class='error'><b>The race stopped early:</b><pre>{html.escape(r['error'])}</pre></div>")
    parts += ["<h2>Results</h2>", _results_table(r), _replay_section(run_dir), "<h2>Lap times</h2>"]
    fig = fig_lap_times(drivers)
    if fig is not None:
        parts.append(_img(fig, "Lap times of every car, lap by lap"))
    parts.append(_lap_table(drivers))
    places = _field_places(drivers)
    if places is not None:
        parts += ["<h2>Places lap by lap</h2>", _img(fig_positions(drivers, places), "Every car's place, lap by lap"),
                  _positions_table(drivers, places)]
    parts += ["<h2>Pit events</h2>", _pit_table(drivers)]

    if tel is not None and tel.rows:
        track = tel.meta.get("track", {})
        length = float(track.get("length_m") or np.nanmax(tel.columns["dist_m"]))
        cars_meta = {m["car"]: m for m in tel.meta.get("cars", [])}
        for d in drivers:
            if not is_python_module(d.get("module", "")) or not isinstance(d.get("idx"), int):
                continue
            c = tel.car(int(d["idx"]))
            if not len(c["time_s"]):
                continue
            parts.append(_car_section(d, c, track, length, cars_meta.get(int(d["idx"]), {}), r, limit))
        parts.append(_telemetry_section(tel, tel_file))
    else:
        parts.append(f"<h2>Telemetry</h2><p class='note'>{html.escape(tel_note or 'telemetry file is empty')}</p>")
    title = html.escape(f"boxbox race report: {r.get('track', '?')}")
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{title}</title>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'><style>{CSS}</style></head>"
            f"<body>{''.join(parts)}</body></html>\n")


def _replay_section(run_dir: Path) -> str:
    """The race to watch (report/replay.py's viewer), or why it cannot be."""
    from boxbox.report.replay import build_replay, viewer_fragment

    try:
        return "<h2>Replay</h2>" + viewer_fragment(build_replay(run_dir))
    except UsageError as exc:
        return f"<h2>Replay</h2><p class='note'>{html.escape(str(exc))}</p>"


def _car_section(d: dict, c: dict, track: dict, length: float, car_meta: dict, r: dict,
                 limit: tuple[np.ndarray, np.ndarray] | None = None) -> str:
    name = driver_label(d)
    parts = [f"<h2>{html.escape(name)}</h2>"]
    if car_meta.get("error"):
        parts.append(f"<p class='note'>Telemetry note: {html.escape(car_meta['error'])}</p>")
    lap_times = d.get("lap_times") or []
    race_laps = int(r.get("laps") or 0)
    laps_present = sorted(int(x) for x in np.unique(c["lap"]) if 1 <= x <= max(race_laps, 1))
    # the map shows the fastest complete lap (else the lap with the most steps)
    if lap_times:
        best = int(np.argmin(lap_times)) + 1
    elif laps_present:
        best = max(laps_present, key=lambda k: int((c["lap"] == k).sum()))
    else:
        best = int(c["lap"].max())
    lap_rows = np.flatnonzero(c["lap"] == best)
    events = [e for e in d.get("pit_events", []) if e.get("entry_time") is not None]
    what = f"lap {best}" + (f" ({fmt_time(lap_times[best - 1])}, fastest)" if 1 <= best <= len(lap_times) else "")
    parts.append(_img(fig_map(c, lap_rows, best, track, events, f"{name}: {what}, coloured by speed"),
                      f"Track map: {what} coloured by speed, braking points and pit events"))
    names = {int(o["car_index"]): driver_label(o) for o in r.get("drivers", []) if o.get("car_index") is not None}
    parts.append(_damage_section(name, c, track, race_laps, names))
    pit = track.get("pit")
    if events and pit:
        parts.append("<h3>Pit stops</h3>")
        for k, e in enumerate(events, start=1):
            stand = (e["leave_time"] - e["stop_time"]) if e.get("leave_time") and e.get("stop_time") else None
            title = (f"Pit stop {k}, lap {e.get('lap')}: " +
                     ("gave up (no stop)" if e.get("gave_up") and e.get("stop_time") is None else
                      f"standing {_num(stand, '{:.2f}')} s, fuel {_num(e.get('fuel'), '{:.1f}')} l") +
                     f" ({e.get('mode', '')})")
            parts.append(_img(fig_pit(c, e, pit, int(d["idx"]), length, title),
                              f"{title}: speed from the pit entry to the exit"))
    parts.append("<h3>Laps</h3>")
    for lap in laps_present:
        rows = c["lap"] == lap
        sub = {k: a[rows] for k, a in c.items()}
        lt = lap_times[lap - 1] if lap <= len(lap_times) else None
        partial = "" if lt is not None else " (not completed)"
        title = f"{name}: lap {lap}" + (f", {fmt_time(lt)}" if lt else "") + partial
        img = _img(fig_lap(sub, lap, length, title, limit), f"Lap {lap}: speed and target speed, throttle/brake, gear")
        parts.append(f"<details{' open' if lap == best or len(laps_present) <= 3 else ''}><summary>Lap {lap}"
                     f"{' · ' + fmt_time(lt) if lt else partial}</summary>{img}</details>")
    return "".join(parts)


def _telemetry_section(tel, tel_file: Path) -> str:
    from boxbox.torcs.telemetry import COLUMNS

    cols = list(tel.columns)
    doc = dict(COLUMNS)
    rows = [[f"<code>{html.escape(k)}</code>", html.escape(doc.get(k, "robot signal" if k.startswith("sig_") else ""))]
            for k in cols]
    cars = ", ".join(f"{m['name']}: {m['steps']} steps"
                     + (f", signals {', '.join(m['signals'])}" if m["signals"] else "")
                     for m in tel.meta.get("cars", []))
    return (f"<h2>Telemetry</h2><p class='note'><code>{html.escape(tel_file.name)}</code>: {tel.rows} rows "
            f"(one per drive step per Python car, every {tel.meta.get('step_s', 0.02)} s); {html.escape(cars)}.</p>"
            + _table(["column", "meaning"], rows))


def write_report(run_dir: Path, out: Path | None = None, limit: tuple[np.ndarray, np.ndarray] | None = None) -> Path:
    """Write the report page (default RUN_DIR/report.html); returns its path. `limit`: as build_report."""
    page = build_report(run_dir, limit)
    out = Path(out) if out is not None else Path(run_dir) / REPORT_FILE
    out.parent.mkdir(parents=True, exist_ok=True)
    from boxbox.files import write_text_atomic

    write_text_atomic(out, page)
    return out
