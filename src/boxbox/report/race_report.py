"""`boxbox report RUN_DIR`: one self-contained HTML page for a race, from result.json and telemetry.parquet.

Figures are drawn with matplotlib (no pyplot, no display) and embedded as base64 PNG, so the page
is a single file that opens anywhere.  What the page shows is described in docs/report.md.
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
import time
import warnings
from pathlib import Path

import numpy as np

from boxbox.errors import UsageError
from boxbox.report.damage import MERGE_S, MOVED_S, Incident, damage_by_lap, damage_incidents, moved_text, nearest_text
from boxbox.report.tables import HTML_RESULTS, driver_label, fmt_time, html_table
from boxbox.report.tables import KMH_PER_MPS as KMH
from boxbox.report.tables import fmt_num as _num
from boxbox.torcs.positions import positions_by_lap
from boxbox.torcs.results import DriverResult, RaceResult, is_python_module, json_problem

REPORT_FILE = "report.html"
COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
          "#17becf"]
BRAKE_ON = 0.1  # a braking point: the brake command rises through this ...
BRAKE_GAP_STEPS = 50  # ... after at least this many steps (1 s) without braking


# --- helpers ---------------------------------------------------------------------------------------
def _figure(width_in: float, height_in: float, **kw):
    from matplotlib.figure import Figure

    return Figure(figsize=(width_in, height_in), layout="constrained", **kw)


def _png(fig, dpi: int = 90) -> str:
    buf = io.BytesIO()
    with warnings.catch_warnings():  # a name with an emoji: drawn as a box, not a warning on the console
        warnings.filterwarnings("ignore", message=r"Glyph \d+ .*missing from")
        fig.savefig(buf, format="png", dpi=dpi)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _img(fig, alt: str, dpi: int = 90) -> str:
    caption = html.escape(alt)
    return f'<figure><img src="{_png(fig, dpi)}" alt="{caption}"><figcaption>{caption}</figcaption></figure>'


def _table(headers: list[str], rows: list[list[str]], cls: str = "") -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f'<table class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _break_wraps(x: np.ndarray, *ys: np.ndarray, jump: float) -> tuple[np.ndarray, ...]:
    """NaN between samples whose x jumps by more than `jump` (the start line), so lines do not cross the plot."""
    if len(x) < 2:
        return (x, *ys)
    cut = np.flatnonzero(np.abs(np.diff(x)) > jump) + 1
    if not len(cut):
        return (x, *ys)
    out = []
    for a in (x, *ys):
        a = a.astype(float)
        out.append(np.insert(a, cut, np.nan))
    return tuple(out)


# --- figures ---------------------------------------------------------------------------------------
def fig_lap_times(drivers: list[dict]):
    """Lap-time bars, one group per lap, one bar per driver; pit laps marked."""
    timed = [d for d in drivers if d.get("lap_times")]
    if not timed:
        return None
    laps = max(len(d["lap_times"]) for d in timed)
    fig = _figure(max(6.0, min(16.0, 1.2 + 0.45 * laps * len(timed))), 3.8)
    ax = fig.add_subplot()
    width = 0.8 / len(timed)
    lo = min(min(d["lap_times"]) for d in timed)
    hi = max(max(d["lap_times"]) for d in timed)
    for k, d in enumerate(timed):
        x = np.arange(1, len(d["lap_times"]) + 1) + (k - (len(timed) - 1) / 2) * width
        t = np.array(d["lap_times"], dtype=float)
        bars = ax.bar(x, t, width=width * 0.95, color=COLORS[k % len(COLORS)], label=driver_label(d),
                      edgecolor="black" if is_python_module(d["module"]) else "none", linewidth=0.6)
        pit_laps = {int(e["lap"]) for e in d.get("pit_events", []) if e.get("stop_time") is not None}
        for lap, bar in enumerate(bars, start=1):
            if lap in pit_laps:
                ax.annotate("pit", (bar.get_x() + bar.get_width() / 2, bar.get_height()), ha="center",
                            va="bottom", fontsize=7, xytext=(0, 1), textcoords="offset points")
    ax.set_xticks(range(1, laps + 1))
    ax.set_xlabel("lap")
    ax.set_ylabel("lap time (s)")
    bottom = max(0.0, math.floor(lo * 0.92))
    ax.set_ylim(bottom, hi + 0.08 * (hi - bottom) + 0.5)
    ax.set_title(f"Lap times (axis from {bottom:.0f} s; Python cars outlined)")
    ax.legend(fontsize=8, ncols=min(4, len(timed)), loc="upper right")
    ax.grid(axis="y", alpha=0.3)
    return fig


def _pedal_gear_panels(fig, gs_rows, x, c, jump: float, sharex):
    """Throttle (up, green) and brake (down, red) band; gear band.  Returns the two axes."""
    axp = fig.add_subplot(gs_rows[0], sharex=sharex)
    xs, acc, brk = _break_wraps(x, c["accel"], c["brake"], jump=jump)
    axp.fill_between(xs, 0, acc, color="#2ca02c", alpha=0.6, linewidth=0, label="throttle")
    axp.fill_between(xs, 0, -brk, color="#d62728", alpha=0.7, linewidth=0, label="brake")
    axp.set_ylim(-1.05, 1.05)
    axp.set_yticks([-1, 0, 1], ["brake", "0", "throttle"], fontsize=7)
    axp.grid(alpha=0.3)
    axg = fig.add_subplot(gs_rows[1], sharex=sharex)
    xs, gear = _break_wraps(x, c["gear"].astype(float), jump=jump)
    axg.fill_between(xs, 0, gear, step="post", color="#9467bd", alpha=0.5, linewidth=0)
    axg.step(xs, gear, where="post", color="#9467bd", linewidth=0.8)
    top = int(np.nanmax(c["gear"])) if len(c["gear"]) else 1
    axg.set_ylim(min(-1, int(np.nanmin(c["gear"])) if len(c["gear"]) else 0) - 0.2, max(1, top) + 0.5)
    axg.set_yticks(range(0, max(1, top) + 1))
    axg.tick_params(axis="y", labelsize=7)
    axg.set_ylabel("gear", fontsize=8)
    axg.grid(alpha=0.3)
    return axp, axg


def fig_lap(c: dict, lap: int, length_m: float, title: str, limit: tuple[np.ndarray, np.ndarray] | None = None):
    """Speed and target speed against distance for one lap, with throttle/brake and gear bands, and
    `limit` (distance m, speed m/s: the car's limit lap, `boxbox limit`) when given."""
    fig = _figure(11.0, 5.4)
    gs = fig.add_gridspec(3, 1, height_ratios=[3.2, 1.0, 1.0])
    ax = fig.add_subplot(gs[0])
    x = c["dist_m"]
    jump = 0.5 * length_m
    xs, v, target = _break_wraps(x, c["speed_mps"] * KMH, c["target_speed_mps"] * KMH, jump=jump)
    if "sig_pit_phase" in c and np.nanmax(c["sig_pit_phase"], initial=0) > 0:
        pit = np.nan_to_num(c["sig_pit_phase"]) > 0
        ax.fill_between(x, 0, 1, where=pit, transform=ax.get_xaxis_transform(), color="#7f7f7f", alpha=0.15,
                        linewidth=0, label="pit phase")
    if np.isfinite(target).any():
        ax.plot(xs, target, color="#ff7f0e", linewidth=1.0, linestyle="--", label="target speed")
    if limit is not None:
        ax.plot(limit[0], limit[1] * KMH, color="#d62728", linewidth=0.9, alpha=0.8, label="limit lap")
    ax.plot(xs, v, color="#1f77b4", linewidth=1.3, label="speed")
    ax.set_ylabel("km/h")
    # the target can be the robot's top speed on straights: the axis follows the car's own speed
    ax.set_ylim(0, max(50.0, float(np.nanmax(v, initial=0.0))) * 1.25)
    ax.set_xlim(0, length_m)
    return _finish_speed_figure(fig, ax, gs, x, c, jump, title, "distance from the start line (m)",
                                dict(loc="lower right", ncols=3))


def _finish_speed_figure(fig, ax, gs, x, data: dict, jump, title: str, xlabel: str, legend: dict):
    """Grid, legend and title of a speed panel, and the throttle/brake and gear panels below it."""
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, **legend)
    ax.set_title(title)
    ax.tick_params(labelbottom=False)
    _, axg = _pedal_gear_panels(fig, [gs[1], gs[2]], x, data, jump, ax)
    fig.axes[1].tick_params(labelbottom=False)
    axg.set_xlabel(xlabel)
    return fig


def braking_points(c: dict) -> np.ndarray:
    """Indices where the brake command rises through BRAKE_ON after a second without braking (the
    brake filters pulse, so each braking zone counts once), outside pit business."""
    braking = np.nan_to_num(c["brake"]) >= BRAKE_ON
    if not braking.any():
        return np.zeros(0, dtype=int)
    steps = np.arange(len(braking))
    last = np.maximum.accumulate(np.where(braking, steps, -1))  # last braking step at or before each step
    idx = np.flatnonzero(braking[1:] & ~braking[:-1]) + 1
    idx = idx[(last[idx - 1] < 0) | (idx - last[idx - 1] > BRAKE_GAP_STEPS)]
    if "sig_pit_phase" in c:
        idx = idx[np.nan_to_num(c["sig_pit_phase"][idx]) == 0]
    return idx


def _track_axes(meta_track: dict):
    """A figure and axes for a map, with the track's edges drawn when the telemetry has them."""
    fig = _figure(8.5, 7.0)
    ax = fig.add_subplot()
    edges = meta_track.get("edges")
    if edges:
        for side in ("left", "right"):
            ax.plot(edges[f"{side}_x"], edges[f"{side}_y"], color="#9a9a9a", linewidth=0.8)
    return fig, ax


def _finish_map(ax, title: str) -> None:
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.grid(alpha=0.2)


def fig_map(c: dict, lap_rows: np.ndarray, lap: int, meta_track: dict, events: list[dict], title: str):
    """The track map, the chosen lap coloured by speed, its braking points, and the pit events."""
    from matplotlib.collections import LineCollection

    fig, ax = _track_axes(meta_track)
    x, y, v = c["x_m"][lap_rows], c["y_m"][lap_rows], c["speed_mps"][lap_rows] * KMH
    if len(x) >= 2:
        pts = np.column_stack([x, y]).reshape(-1, 1, 2)
        segs = np.concatenate([pts[:-1], pts[1:]], axis=1)
        lc = LineCollection(segs, cmap="turbo", linewidth=2.6)
        lc.set_array(0.5 * (v[:-1] + v[1:]))
        ax.add_collection(lc)
        fig.colorbar(lc, ax=ax, label=f"speed on lap {lap} (km/h)", shrink=0.8)
        ax.plot(x[0], y[0], marker="*", color="black", markersize=12, linestyle="none", label="lap start")
    sub = {k: a[lap_rows] for k, a in c.items()}
    bp = braking_points(sub)
    if len(bp):
        ax.plot(sub["x_m"][bp], sub["y_m"][bp], marker="v", color="#d62728", markeredgecolor="black",
                markersize=7, linestyle="none", label=f"braking points ({len(bp)})")
    t = c["time_s"]
    shown = set()
    for e in events:
        start = e.get("entry_time")
        end = e.get("exit_time") or e.get("leave_time")
        if start is None:
            continue
        rows = (t >= start) & (t <= (end if end is not None else t[-1]))
        ax.plot(c["x_m"][rows], c["y_m"][rows], color="black", linewidth=1.0, linestyle="--",
                label=None if "path" in shown else "pit lane driven")
        shown.add("path")
        for key, marker, color, label in (("entry_time", "^", "#ffffff", "pit entry"),
                                          ("stop_time", "s", "#ffd700", "pit stop"),
                                          ("exit_time", "o", "#ffffff", "pit exit")):
            when = e.get(key)
            if when is None:
                continue
            i = int(np.argmin(np.abs(t - when)))
            ax.plot(c["x_m"][i], c["y_m"][i], marker=marker, color=color, markeredgecolor="black", markersize=9,
                    linestyle="none", label=None if label in shown else label)
            shown.add(label)
    ax.legend(fontsize=8, loc="best")
    _finish_map(ax, title)
    return fig


def fig_pit(c: dict, event: dict, pit: dict, car_index: int, length_m: float, title: str):
    """Speed against distance from the pit entry to the exit, with the speed limit and the stop point."""
    t = c["time_s"]
    start = event["entry_time"] - 1.5
    end = event.get("exit_time") or event.get("leave_time")
    end = (end + 1.5) if end is not None else t[-1]
    rows = (t >= start) & (t <= end)
    sub = {k: a[rows] for k, a in c.items()}
    entry = pit["entry_m"]

    def rel(d):
        return (np.asarray(d, dtype=float) - entry + 0.25 * length_m) % length_m - 0.25 * length_m

    x = rel(sub["dist_m"])
    fig = _figure(11.0, 5.0)
    gs = fig.add_gridspec(3, 1, height_ratios=[3.2, 1.0, 1.0])
    ax = fig.add_subplot(gs[0])
    jump = 0.5 * length_m
    xs, v, target = _break_wraps(x, sub["speed_mps"] * KMH, sub["target_speed_mps"] * KMH, jump=jump)
    ax.plot(xs, v, color="#1f77b4", linewidth=1.3, label="speed")
    lim_a, lim_b = rel(pit["limit_start_m"]), rel(pit["limit_end_m"])
    limit = pit["speed_limit_mps"] * KMH
    ax.hlines(limit, lim_a, lim_b, color="#d62728", linewidth=1.4, label=f"speed limit {limit:.0f} km/h")
    ax.axvspan(lim_a, lim_b, color="#d62728", alpha=0.06, linewidth=0)
    box = pit.get("box_m", {}).get(str(car_index))
    if box is not None:
        ax.axvline(rel(box), color="#444444", linestyle=":", linewidth=1.2, label="box")
    stop_t = event.get("stop_time")
    if stop_t is not None and len(sub["time_s"]):
        i = int(np.argmin(np.abs(sub["time_s"] - stop_t)))
        err = event.get("stop_error_m")
        ax.plot(x[i], sub["speed_mps"][i] * KMH, marker="s", color="#ffd700", markeredgecolor="black",
                markersize=9, linestyle="none",
                label="stop point" + (f" ({err:+.2f} m from the box)" if err is not None else ""))
    ax.axvline(0.0, color="black", linewidth=0.8)
    ax.axvline(rel(pit["exit_m"]), color="black", linewidth=0.8)
    ax.text(0.0, 1.0, " entry", transform=ax.get_xaxis_transform(), va="top", fontsize=8)
    ax.text(rel(pit["exit_m"]), 1.0, " exit", transform=ax.get_xaxis_transform(), va="top", fontsize=8)
    ax.set_ylabel("km/h")
    ax.set_ylim(0, max(limit * 1.5, float(np.nanmax(v, initial=0.0))) * 1.3)
    ax.set_xlim(min(-20.0, float(np.nanmin(x, initial=0.0))), max(rel(pit["exit_m"]) + 20.0,
                                                                   float(np.nanmax(x, initial=0.0))))
    return _finish_speed_figure(fig, ax, gs, x, sub, jump, title, "distance from the pit entry (m)",
                                dict(loc="upper center", ncols=2))


# --- the page ----------------------------------------------------------------------------------------
def _field_places(drivers: list[dict]) -> list[list[int]] | None:
    """Every car's place lap by lap, when the race had several cars and all their lap times are
    known (a race with a Python car: the robot host sees every car's laps); else None."""
    if len(drivers) < 2 or not all(d.get("lap_times") for d in drivers):
        return None
    return positions_by_lap([list(d["lap_times"]) for d in drivers])


def fig_positions(drivers: list[dict], places: list[list[int]]):
    """Place against lap, one line per car (Python cars drawn thicker)."""
    laps = max(len(p) for p in places)
    fig = _figure(max(6.0, min(12.0, 3.0 + 0.5 * laps)), 0.8 + 0.32 * len(drivers))
    ax = fig.add_subplot()
    for k, (d, row) in enumerate(zip(drivers, places, strict=True)):
        python = is_python_module(d["module"])
        ax.plot(range(1, len(row) + 1), row, marker="o", markersize=3, color=COLORS[k % len(COLORS)],
                linewidth=2.6 if python else 1.0, label=driver_label(d), zorder=3 if python else 2)
    ax.set_ylim(len(drivers) + 0.5, 0.5)
    ax.set_yticks(range(1, len(drivers) + 1))
    ax.set_xticks(range(1, laps + 1))
    ax.set_xlabel("end of lap")
    ax.set_ylabel("place")
    ax.set_title("Places lap by lap (Python cars drawn thicker)")
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.grid(alpha=0.3)
    return fig


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


def fig_damage_map(incidents: list[Incident], meta_track: dict, race_laps: int, title: str):
    """The track's edges with each incident where it began: the marker's area grows with the damage
    taken, its colour is the lap."""
    fig, ax = _track_axes(meta_track)
    laps = np.array([i.lap for i in incidents], dtype=float)
    dots = ax.scatter([i.x_m for i in incidents], [i.y_m for i in incidents], c=laps, cmap="viridis",
                      vmin=min(1.0, laps.min()), vmax=max(float(race_laps), laps.max(), 2.0),
                      s=[20.0 + i.damage / 5.0 for i in incidents], edgecolors="black", linewidths=0.6, alpha=0.8)
    fig.colorbar(dots, ax=ax, label="lap", shrink=0.8)
    labelled: list[Incident] = []
    for i in sorted(incidents, key=lambda i: -i.damage):  # the worst five, one label per place
        if len(labelled) < 5 and all(math.hypot(i.x_m - j.x_m, i.y_m - j.y_m) > 30.0 for j in labelled):
            ax.annotate(f"{i.damage}", (i.x_m, i.y_m), textcoords="offset points", xytext=(6, 6), fontsize=8)
            labelled.append(i)
    _finish_map(ax, title)
    return fig


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
