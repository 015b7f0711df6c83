"""`boxbox replay RUN_DIR`: the race as a page that plays it, every car on the track, the incidents marked.

The page is one self-contained HTML file (no network: it opens from a file:// URL or an e-mail
attachment): the viewer's template, style and script (report/replay_viewer/, plain JS on a canvas)
and the race's data embedded as JSON, its per-sample arrays as base64 of little-endian typed arrays
(float32 positions, int16 headings and speeds, bytes for the rest: about 18 bytes per car and
sample).  The race report embeds the same viewer (`viewer_fragment`).  What it shows is in
docs/report.md.
"""

from __future__ import annotations

import base64
import html
import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from boxbox.errors import UsageError
from boxbox.report.incidents import Frames, describe, find_incidents
from boxbox.torcs.recording import COLUMNS, load_recording, read_grid
from boxbox.torcs.results import is_python_module

REPLAY_FILE = "replay.html"
RECORDING_FILE = "recording.parquet"
VIEWER_DIR = Path(__file__).resolve().parent / "replay_viewer"
# the report's palette (report/figures.py), by TORCS car index
COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
          "#17becf"]
# per-sample flags, one bit each (the viewer's FLAG_*)
FLAGS = {"seen": 1, "in_pit": 2, "in_pit_lane": 4, "off_track": 8, "out": 16, "python": 32}
UNKNOWN_I8 = -128  # a TORCS robot's controls are not known


@dataclass
class Replay:
    """What the viewer gets: the data as JSON-ready values, and the race's title."""

    data: dict
    title: str


def no_recording_error(run_dir: Path) -> UsageError:
    """Why run_dir has no recording, in one line that says what to do: not a run dir, a race of
    TORCS robots alone, one run with --no-telemetry, one stopped before its first drive step (the
    recording is made at the drive steps), or one from before boxbox recorded races."""
    result = _read_json(run_dir / "result.json")
    spec = _read_json(run_dir / "host-spec.json")
    grid = read_grid(run_dir / "race.xml")
    if result is None and spec is None and not grid:
        return UsageError(f"{run_dir} is not a race's run dir (no result.json, race.xml nor {RECORDING_FILE}): "
                          "give the folder `boxbox race` prints after its table (run_dir in its --json)")
    drivers = [d for d in (result or {}).get("drivers", []) if isinstance(d, dict)]
    python = [d for d in drivers if is_python_module(str(d.get("module", "")))]
    if not python and not (spec or {}).get("robots") and not any(is_python_module(g["module"]) for g in grid):
        return UsageError(f"{run_dir} has no recording ({RECORDING_FILE}): a race of TORCS robots alone is not "
                          "recorded (the Python cars' drive steps record it); race one with a Python car")
    if spec is not None and spec.get("telemetry") is False:
        return UsageError(f"{run_dir} has no recording ({RECORDING_FILE}): it was raced with --no-telemetry; "
                          "race it again without it")
    if not any(d.get("lap_times") or d.get("time") for d in python):
        error = str((result or {}).get("error") or "no result").splitlines()[0]
        return UsageError(f"{run_dir} has no recording ({RECORDING_FILE}): the race stopped before its first drive "
                          f"step ({error}); fix that and race it again")
    return UsageError(f"{run_dir} has no recording ({RECORDING_FILE}): it was raced before boxbox recorded races, "
                      "or the file was removed; race it again with `boxbox race`")


def _read_json(path: Path) -> dict | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _b64(a: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _held(a: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """Each column's last seen value carried forward over the samples it was not seen (and its first
    carried back), so a car standing in its box, or not seen for a while, stays where it was."""
    rows = np.where(seen, np.arange(len(a))[:, None], -1)
    last = np.maximum.accumulate(rows, axis=0)
    first = np.argmax(seen, axis=0)
    idx = np.where(last < 0, first[None, :], last)
    return np.take_along_axis(np.nan_to_num(a), idx, axis=0)


def _flags(f: Frames, seen: np.ndarray) -> np.ndarray:
    bits = seen.astype(np.uint8) * FLAGS["seen"]
    for name, bit in FLAGS.items():
        if name != "seen":
            bits |= (_held(f.flag(name).astype(float), seen) > 0.5).astype(np.uint8) * np.uint8(bit)
    return bits


def _control(a: np.ndarray, seen: np.ndarray, scale: float) -> np.ndarray:
    """A control as int8 (value x scale), UNKNOWN_I8 where not recorded (a TORCS robot's)."""
    held = _held(np.where(np.isnan(a), 1e9, a), seen)
    return np.where(held > 1e8, UNKNOWN_I8, np.clip(np.rint(held * scale), -127, 127)).astype(np.int8)


def encode_frames(f: Frames) -> dict[str, str]:
    """The per-sample arrays, car after car (column k at k*S .. (k+1)*S), base64."""
    seen = f.seen() & np.isfinite(f.cols["x_m"])
    col = {name: _held(a, seen).T for name, a in f.cols.items()}
    return {"t": _b64(f.times, "<f4"), "x": _b64(col["x_m"], "<f4"), "y": _b64(col["y_m"], "<f4"),
            "yaw": _b64(np.rint(col["yaw_rad"] * 10000), "<i2"),
            "speed": _b64(np.clip(np.rint(col["speed_mps"] * 100), -32767, 32767), "<i2"),
            "damage": _b64(col["damage"], "<i4"), "place": _b64(np.clip(col["place"], 0, 255), "u1"),
            "lap": _b64(col["lap"], "<i2"), "flags": _b64(_flags(f, seen).T, "u1"),
            "gear": _b64(_control(f.cols["gear"], seen, 1.0).T, "i1"),
            "accel": _b64(_control(f.cols["accel"], seen, 100.0).T, "i1"),
            "brake": _b64(_control(f.cols["brake"], seen, 100.0).T, "i1"),
            "steer": _b64(_control(f.cols["steer"], seen, 100.0).T, "i1")}


def car_names(meta: dict, result: dict) -> dict[int, dict]:
    """Per TORCS car index: its name, label and whether a Python robot drives it (from result.json,
    else race.xml's grid and the recording's Python cars)."""
    cars: dict[int, dict] = {}
    for g in meta.get("grid", []):
        cars[int(g["car"])] = {"name": f"{g['module']} {g['idx']}", "label": f"{g['module']}:{g['idx']}",
                               "python": is_python_module(g["module"])}
    for p in meta.get("python", []):
        cars[int(p["car"])] = {"name": p["name"], "label": f"{p['name']} ({p['robot']})", "python": True}
    by_entry = {(g["module"], int(g["idx"])): int(g["car"]) for g in meta.get("grid", [])}
    for d in result.get("drivers", []):
        car = d.get("car_index", -1)
        car = car if car is not None and car >= 0 else by_entry.get((d.get("module"), int(d.get("idx", -1))))
        if car is not None:
            cars[int(car)] = {"name": d["name"], "label": f"{d['name']} ({d['module']}:{d['idx']})",
                              "python": is_python_module(d.get("module", ""))}
    return cars


def build_replay(run_dir: Path) -> Replay:
    """The viewer's data for the race in run_dir; a UsageError when it has no recording."""
    run_dir = Path(run_dir)
    path = run_dir / RECORDING_FILE
    if not path.exists():
        raise no_recording_error(run_dir)
    try:
        rec = load_recording(path)
    except Exception as exc:
        raise UsageError(f"{path} cannot be read ({type(exc).__name__}: {exc}); race again") from None
    missing = [name for name, _ in COLUMNS if name not in rec.columns]
    if missing:
        raise UsageError(f"{path} is not a boxbox race recording (no column {', '.join(missing[:3])}"
                         f"{', ...' if len(missing) > 3 else ''}): give the run dir of a race `boxbox race` ran")
    if not rec.rows:
        raise UsageError(f"{path} is empty (no sample: the race stopped as it started, or the file was cut); "
                         "race it again")
    result = _read_json(run_dir / "result.json") or {}
    fault = _read_json(run_dir / "fault.json")
    frames = Frames.from_columns(rec.columns)
    known = car_names(rec.meta, result)
    sizes = rec.meta.get("cars", {})
    cars = [{"car": c, "color": COLORS[c % len(COLORS)], **known.get(c, {"name": f"car {c}", "label": f"car {c}",
                                                                          "python": False}),
             "length_m": float(sizes.get(str(c), {}).get("length_m", 4.5)),
             "width_m": float(sizes.get(str(c), {}).get("width_m", 1.9))} for c in frames.cars]
    names = {c["car"]: c["name"] for c in cars}
    incidents = [{**i.to_json(), "text": describe(i, names)}
                 for i in find_incidents(rec.columns, rec.meta, result, fault)]
    track = rec.meta.get("track", {})
    data = {"track": track, "cars": cars, "incidents": incidents, "frames": encode_frames(frames),
            "samples": len(frames.times), "laps": result.get("laps"), "error": result.get("error")}
    title = f"{track.get('name', result.get('track', '?'))}, {result.get('laps', '?')} laps, {len(cars)} cars"
    return Replay(data=data, title=title)


def _template(name: str) -> str:
    return (VIEWER_DIR / name).read_text()


def viewer_fragment(replay: Replay) -> str:
    """The viewer as a block of HTML (its markup, style, data and script) to put in any page."""
    data = json.dumps(replay.data, separators=(",", ":")).replace("</", "<\\/")
    markup = _template("viewer.html").replace("{{title}}", html.escape(replay.title))
    return (f"<style>{_template('viewer.css')}</style>{markup}"
            f'<script type="application/json" id="bbr-data">{data}</script>'
            f"<script>{_template('viewer.js')}</script>")


def replay_page(replay: Replay) -> str:
    """The viewer as a page of its own."""
    title = html.escape(f"boxbox replay: {replay.title}")
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{title}</title>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            "<style>body{font-family:system-ui,sans-serif;margin:12px;color:#222}</style></head>"
            f"<body>{viewer_fragment(replay)}</body></html>\n")


def write_replay(run_dir: Path, out: Path | None = None) -> Path:
    """Write the replay page (default RUN_DIR/replay.html); returns its path."""
    page = replay_page(build_replay(run_dir))
    out = Path(out) if out is not None else Path(run_dir) / REPLAY_FILE
    out.parent.mkdir(parents=True, exist_ok=True)
    from boxbox.files import write_text_atomic

    write_text_atomic(out, page)
    return out


def replay_line(run_dirs: Iterable[str], where: str = "each race's run_dir is in --json") -> str:
    """A bench table's footer: how to watch one of its races (`boxbox replay` on its run dir), or why
    none can be (no Python car in them, or cached races whose run dir was pruned or is from before
    races were recorded: --no-cache races them again)."""
    recorded = [d for d in dict.fromkeys(run_dirs) if d and (Path(d) / RECORDING_FILE).exists()]
    if not recorded:
        return ("replay: none of these races has a recording (races with a Python car have one; a cached "
                "race's run dir may be gone: race again with --no-cache)")
    return f"replay: boxbox replay {recorded[0]}" + (f"  ({len(recorded)} recorded; {where})" if len(recorded) > 1
                                                     else "")
