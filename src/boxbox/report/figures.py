"""The race report's figures: matplotlib figures drawn off-screen, as PNG data in the page
(report/race_report.py puts them in its sections; tune/report.py uses the same helpers)."""

from __future__ import annotations

import base64
import html
import io
import math
import warnings

import numpy as np

from boxbox.report.damage import DamageIncident
from boxbox.report.tables import KMH_PER_MPS as KMH
from boxbox.report.tables import driver_label
from boxbox.torcs.positions import positions_by_lap
from boxbox.torcs.results import is_python_module

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


def fig_damage_map(incidents: list[DamageIncident], meta_track: dict, race_laps: int, title: str):
    """The track's edges with each incident where it began: the marker's area grows with the damage
    taken, its colour is the lap."""
    fig, ax = _track_axes(meta_track)
    laps = np.array([i.lap for i in incidents], dtype=float)
    dots = ax.scatter([i.x_m for i in incidents], [i.y_m for i in incidents], c=laps, cmap="viridis",
                      vmin=min(1.0, laps.min()), vmax=max(float(race_laps), laps.max(), 2.0),
                      s=[20.0 + i.damage / 5.0 for i in incidents], edgecolors="black", linewidths=0.6, alpha=0.8)
    fig.colorbar(dots, ax=ax, label="lap", shrink=0.8)
    labelled: list[DamageIncident] = []
    for i in sorted(incidents, key=lambda i: -i.damage):  # the worst five, one label per place
        if len(labelled) < 5 and all(math.hypot(i.x_m - j.x_m, i.y_m - j.y_m) > 30.0 for j in labelled):
            ax.annotate(f"{i.damage}", (i.x_m, i.y_m), textcoords="offset points", xytext=(6, 6), fontsize=8)
            labelled.append(i)
    _finish_map(ax, title)
    return fig
