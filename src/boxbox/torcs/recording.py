"""The race recording: every car, 10 times a simulated second, for `boxbox replay`.

In a race with a Python car the robot host sees every car at each drive step (the DRIVE message's
opponents).  At the first drive step in each SAMPLE_S of simulated time (and at that same instant
for every other Python car) `RaceRecorder.step` appends to one buffer a small head (which robot, how many
opponents, its controls) and the DRIVE message's bytes as the bridge sent them (the state record
and every opponent record): one struct pack and one byte copy, before the reply is packed over the
opponents.  Every SPILL_BYTES the buffer goes to a spool file in the run dir, so memory stays flat.
Nothing is decoded while the race runs.

At the end (`write_recording`, called by the host's `finish`, so also after a robot fault or a
Ctrl-C) the records become one row per car and sample: a Python car's own row (its state and
controls) wins over the same car seen by another Python car; the cars TORCS drives come from the
opponent records.  Columns (`COLUMNS`, float32 where it is enough) go to RUN_DIR/recording.parquet
(zstd), with JSON metadata under the key `boxbox`: the track (edges, pit lane), the grid (TORCS car
index -> module, idx, from race.xml) and each car's size.  A 10-car, 10-lap race is a few MB.
`load_recording` reads it back as numpy columns (report/ reads only that).
"""

from __future__ import annotations

import json
import math
import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from boxbox.files import atomic_path
from boxbox.model.state import CAR_STATE_DNF, CAR_STATE_FINISH, CAR_STATE_PIT
from boxbox.model.track import LEFT, RIGHT, STRAIGHT, Track
from boxbox.torcs import wire
from boxbox.torcs.rundir import RunDir
from boxbox.torcs.telemetry import Telemetry, track_info

METADATA_KEY = b"boxbox"
SAMPLE_S = 0.1  # 10 samples a simulated second, one in about 5 drive steps (the viewer interpolates)
_PER_S = 1.0 / SAMPLE_S
SPILL_BYTES = 4 << 20  # buffered bytes before they go to the spool file (about 40 s of a 10-car race)
# a record's head: the Python car's robot index, its opponent count, then its controls
HEAD_FIELDS = ("robot", "count", "steer", "accel", "brake", "clutch", "pit_request")
HEAD = struct.Struct(f"<{len(HEAD_FIELDS)}d")
N_HEAD, N_STATE, N_OPP = len(HEAD_FIELDS), len(wire.STATE_FIELDS), len(wire.OPPONENT_FIELDS)
_HSIZE = wire.HEADER.size
_S = {f: i for i, f in enumerate(wire.STATE_FIELDS)}
_O = {f: i for i, f in enumerate(wire.OPPONENT_FIELDS)}
_H = {f: i for i, f in enumerate(HEAD_FIELDS)}

# (column, unit / meaning), in file order; documented in docs/report.md
COLUMNS = [
    ("car", "TORCS car index (`car_index` in result.json)"),
    ("time_s", "simulated time of the sample (every 0.1 s)"),
    ("python", "the row is a Python car's own (its controls filled), not a car it saw"),
    ("lap", "lap being driven (TORCS count: 1 during the first lap, 0 before the start line)"),
    ("place", "place in the race (1 = leading)"),
    ("dist_m", "distance from the start line along the track"),
    ("dist_raced_m", "distance raced since the start"),
    ("x_m", "position"),
    ("y_m", "position"),
    ("yaw_rad", "heading, counter-clockwise from the x axis"),
    ("speed_mps", "speed along the car's axis"),
    ("to_middle_m", "distance from the middle line, + left"),
    ("heading_to_track_rad", "heading less the track's direction there, + left, in [-pi, pi]"),
    ("damage", "damage points (TORCS's count; 10,000 puts a car out)"),
    ("in_pit", "captured by the race engine in its pit box"),
    ("in_pit_lane", "in the pit lane (the centre beyond the edge on the pit side, between pit entry and exit)"),
    ("off_track", "the car's centre beyond an edge of the track, the pit lane excepted"),
    ("out", "finished or out of the race"),
    ("steer", "steer command [-1, 1], + left (Python cars; null for the others)"),
    ("accel", "throttle command [0, 1] (Python cars)"),
    ("brake", "brake command [0, 1] (Python cars)"),
    ("clutch", "clutch command [0, 1] (Python cars)"),
    ("gear", "gear engaged (Python cars)"),
    ("pit_request", "the robot asks for a pit stop (Python cars)"),
]
_F32 = {"dist_m", "dist_raced_m", "x_m", "y_m", "yaw_rad", "speed_mps", "to_middle_m", "heading_to_track_rad",
        "steer", "accel", "brake", "clutch"}


class RaceRecorder:
    """Every car of the race, sampled at the Python cars' drive steps (the host calls `step` with
    the controls before it packs its reply over the opponents in `buf`, its receive buffer)."""

    __slots__ = ("view", "rows", "spool", "storage_error", "next_s", "last_s")

    def __init__(self, buf: bytearray, spool: Path | None = None) -> None:
        self.view = memoryview(buf)
        self.rows = bytearray()
        self.spool = spool  # None: all kept in memory (tests)
        self.storage_error: str | None = None  # why the recording stopped (a full disk)
        # TORCS calls the robots 0.02 or 0.022 s apart: a sample at the first step from next_s on,
        # and at last_s, the instant sampled, for the other Python cars (all are driven then)
        self.next_s = -math.inf
        self.last_s = math.nan

    def step(self, robot: int, sim_time_s: float, count: int, c: Any) -> None:
        """Record this drive step if it is a sampled one (one pack, one byte copy)."""
        if sim_time_s < self.next_s and sim_time_s != self.last_s or self.storage_error:
            return
        if sim_time_s >= self.next_s:
            # (less a microsecond: 0.2 s x 10 + 1 is 0.30000000000000004 s, after the step at 0.3 s)
            self.last_s, self.next_s = sim_time_s, (math.floor(sim_time_s * _PER_S + 1e-6) + 1) * SAMPLE_S - 1e-6
        rows = self.rows
        rows += HEAD.pack(robot, count, c.steer, c.accel, c.brake, c.clutch, 1.0 if c.pit_request else 0.0)
        rows += self.view[_HSIZE: _HSIZE + (N_STATE + count * N_OPP) * 8]
        if len(rows) >= SPILL_BYTES:
            self.spill()

    def spill(self) -> bool:
        """The buffer to the spool file; False (and the recording given up) when it cannot be written."""
        if self.spool is None or not self.rows:
            return True
        try:
            with open(self.spool, "ab") as f:
                f.write(self.rows)
        except OSError as exc:
            self.storage_error = f"{exc.strerror or exc} in {self.spool.parent}"
            self.spool.unlink(missing_ok=True)  # nothing more is kept (step checks storage_error)
        self.rows = bytearray()
        return self.storage_error is None

    def data(self) -> bytes:
        """Everything recorded: the spool file's records, then the buffer's."""
        spooled = b""
        if self.spool is not None and self.storage_error is None and self.spool.exists():
            spooled = self.spool.read_bytes()
        return spooled + bytes(self.rows)

    def remove_spool(self) -> None:
        if self.spool is not None:
            self.spool.unlink(missing_ok=True)


# --- at the end: records -> rows ---------------------------------------------------------------
@dataclass
class Records:
    """The decoded records, grouped by opponent count (it is the same all race long: TORCS lists
    every car, out or not): per group the heads (n x N_HEAD), states (n x N_STATE) and opponents
    (n x count x N_OPP), float64."""

    groups: list[tuple[np.ndarray, np.ndarray, np.ndarray]]

    def __len__(self) -> int:
        return sum(len(head) for head, _, _ in self.groups)


def decode(data: bytes) -> Records:
    """The records of a recorder's bytes; a record cut short (a host killed while writing) ends them."""
    a = np.frombuffer(data, dtype="<f8", count=len(data) // 8)
    starts: dict[int, list[int]] = {}
    i = 0
    while i + N_HEAD + N_STATE <= len(a):
        count = int(a[i + _H["count"]])
        end = i + N_HEAD + N_STATE + count * N_OPP
        if count < 0 or end > len(a):
            break
        starts.setdefault(count, []).append(i)
        i = end
    groups = []
    for count, at in starts.items():
        width = N_HEAD + N_STATE + count * N_OPP
        rec = a[np.asarray(at)[:, None] + np.arange(width)[None, :]]
        groups.append((rec[:, :N_HEAD], rec[:, N_HEAD: N_HEAD + N_STATE],
                       rec[:, N_HEAD + N_STATE:].reshape(len(at), count, N_OPP)))
    return Records(groups)


def _own_rows(records: Records, car_of_robot: dict[int, int]) -> dict[str, np.ndarray]:
    """One row per record: the Python car's own state and controls."""
    head = np.concatenate([g[0] for g in records.groups]) if records.groups else np.zeros((0, N_HEAD))
    st = np.concatenate([g[1] for g in records.groups]) if records.groups else np.zeros((0, N_STATE))
    robots = head[:, _H["robot"]].astype(np.int64)
    cars = np.full(len(robots), -1, dtype=np.int64)  # -1: a robot whose car is not known (dropped)
    for robot, car in car_of_robot.items():
        cars[robots == robot] = car
    cols = {"car": cars, "time_s": st[:, _S["sim_time_s"]], "python": np.ones(len(st), bool),
            "place": st[:, _S["position"]], "speed_mps": st[:, _S["speed_x_mps"]], "gear": st[:, _S["gear"]]}
    for name in ("lap", "dist_m", "dist_raced_m", "x_m", "y_m", "yaw_rad", "to_middle_m", "damage", "seg_id",
                 "to_start", "car_state"):
        cols[name] = st[:, _S[{"lap": "laps", "dist_m": "dist_from_start_m"}.get(name, name)]]
    for name in ("steer", "accel", "brake", "clutch", "pit_request"):
        cols[name] = head[:, _H[name]]
    return cols


def _seen_rows(records: Records) -> dict[str, np.ndarray]:
    """One row per opponent record: a car as a Python car saw it (its place from the order TORCS
    lists the cars in, which is the race order, the observer's own place left out)."""
    times, places, opps = [], [], []
    for _, state, opp in records.groups:
        n, count = opp.shape[:2]
        if not count:
            continue
        k = np.arange(1, count + 1, dtype=float)[None, :]
        own = state[:, _S["position"]][:, None]
        places.append(np.where(k < own, k, k + 1).ravel())
        times.append(np.repeat(state[:, _S["sim_time_s"]], count))
        opps.append(opp.reshape(n * count, N_OPP))
    if not opps:
        return {}
    o = np.concatenate(opps)
    cols = {"car": o[:, _O["car_index"]].astype(np.int64), "time_s": np.concatenate(times),
            "python": np.zeros(len(o), bool), "place": np.concatenate(places), "lap": o[:, _O["laps"]],
            "dist_m": o[:, _O["dist_from_start_m"]], "speed_mps": o[:, _O["speed_x_mps"]]}
    for name in ("dist_raced_m", "x_m", "y_m", "yaw_rad", "to_middle_m", "damage", "seg_id", "to_start",
                 "car_state"):
        cols[name] = o[:, _O[name]]
    nan = np.full(len(o), np.nan)
    for name in ("steer", "accel", "brake", "clutch", "pit_request", "gear"):
        cols[name] = nan
    return cols


def merge_rows(records, car_of_robot: dict[int, int]) -> dict[str, np.ndarray]:
    """One row per car and sample, sorted by time then car: a Python car's own row first, else the
    first sighting of the car at that sample (a car TORCS drives, seen by every Python car; a
    Python car standing in its pit, seen by another)."""
    own = _own_rows(records, car_of_robot)
    seen = _seen_rows(records)
    cols = {k: np.concatenate([own[k], seen[k]]) for k in own} if seen else own
    cols = {k: v[cols["car"] >= 0] for k, v in cols.items()}
    _, sample = np.unique(cols["time_s"], return_inverse=True)  # the Python cars sample the same instants
    key = sample.astype(np.int64) * 4096 + cols["car"]
    order = np.argsort(key, kind="stable")  # own rows come first among equal keys
    first = np.ones(len(order), bool)
    first[1:] = key[order][1:] != key[order][:-1]
    return {k: v[order][first] for k, v in cols.items()}


def _wrap_pi(a: np.ndarray) -> np.ndarray:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def pit_zone_mask(track: Track) -> np.ndarray:
    """Per segment, whether it lies between the pit entry and the pit exit (where the pit lane runs)."""
    n = track.n_segments
    zone = np.zeros(n, bool)
    if track.pit is None:
        return zone
    entry, exit_ = track.pit.entry_seg % n, track.pit.exit_seg % n
    span = (exit_ - entry) % n + 1
    zone[(entry + np.arange(span)) % n] = True
    return zone


def add_track_columns(cols: dict[str, np.ndarray], track: Track | None) -> None:
    """heading_to_track_rad, off_track and in_pit_lane of each row, from its segment and the place
    on it (NaN and False where the track or the segment is not known)."""
    n = len(cols["car"])
    sid = cols["seg_id"]
    valid = np.isfinite(sid) & np.isfinite(cols["to_middle_m"]) & (sid >= 0)
    if track is None or not n:
        cols["heading_to_track_rad"] = np.full(n, np.nan)
        cols["off_track"] = cols["in_pit_lane"] = np.zeros(n, bool)
        return
    seg = track.seg
    valid &= sid < track.n_segments
    i = np.where(valid, sid, 0).astype(np.int64)
    kind, to_start = seg["type"][i], np.nan_to_num(cols["to_start"])
    track_dir = seg["start_angle_rad"][i] + np.where(kind == LEFT, to_start, np.where(kind == RIGHT, -to_start, 0.0))
    cols["heading_to_track_rad"] = np.where(valid, _wrap_pi(cols["yaw_rad"] - track_dir), np.nan)
    size = np.where(kind == STRAIGHT, seg["length_m"][i], seg["arc_rad"][i])
    along = np.clip(to_start / np.where(size > 0, size, 1.0), 0.0, 1.0)
    width = seg["start_width_m"][i] + (seg["end_width_m"][i] - seg["start_width_m"][i]) * along
    mid = np.nan_to_num(cols["to_middle_m"])
    beyond = valid & (np.abs(mid) > width / 2)
    pit_side = (mid > 0) if track.pit is not None and track.pit.side == LEFT else (mid < 0)
    cols["in_pit_lane"] = beyond & pit_zone_mask(track)[i] & pit_side & (track.pit is not None)
    cols["off_track"] = beyond & ~cols["in_pit_lane"]


def pit_lane_outline(track: Track) -> dict[str, list[float]] | None:
    """The pit lane for a map: its outer line beside the track's edge on the pit side, from the
    pit entry to the exit, the full pit width along the speed limit and tapering to it outside."""
    pit = track.pit
    if pit is None:
        return None
    n, seg = track.n_segments, track.seg
    side, other = ("left", "right") if pit.side == LEFT else ("right", "left")
    zone = np.flatnonzero(pit_zone_mask(track))
    order = (pit.entry_seg % n + np.arange(len(zone))) % n
    k = np.arange(len(order) + 1, dtype=float)
    ramp_in = (pit.start_seg - pit.entry_seg) % n or 1
    ramp_out = (pit.exit_seg - pit.end_seg) % n or 1
    share = np.clip(np.minimum(k / ramp_in, (len(order) - k) / ramp_out), 0.0, 1.0)
    px = np.append(seg[f"start_{side}_x"][order], seg[f"end_{side}_x"][order[-1]])
    py = np.append(seg[f"start_{side}_y"][order], seg[f"end_{side}_y"][order[-1]])
    qx = np.append(seg[f"start_{other}_x"][order], seg[f"end_{other}_x"][order[-1]])
    qy = np.append(seg[f"start_{other}_y"][order], seg[f"end_{other}_y"][order[-1]])
    across = np.maximum(np.hypot(px - qx, py - qy), 1e-6)
    reach = float(pit.width_m) * share / across
    return {"edge_x": _r(px), "edge_y": _r(py), "outer_x": _r(px + (px - qx) * reach),
            "outer_y": _r(py + (py - qy) * reach)}


def _r(a: np.ndarray) -> list[float]:
    return np.round(a.astype(float), 2).tolist()


def read_grid(race_file: Path) -> list[dict]:
    """The cars of race.xml in its order (TORCS's car index is the place in it): module and idx."""
    try:
        root = ET.parse(race_file).getroot()
    except (OSError, ET.ParseError):
        return []
    drivers = next((s for s in root.iter("section") if s.get("name") == "Drivers"), None)
    grid: list[dict] = []
    for entry in drivers.findall("section") if drivers is not None else []:
        attrs = {a.get("name"): a.get("val") for a in entry}
        grid.append({"car": len(grid), "module": attrs.get("module", ""), "idx": int(float(attrs.get("idx") or 0))})
    return grid


def _car_sizes(records: Records, slots) -> dict[str, dict[str, float]]:
    """Each car's length and width (m): the Python cars' from their Car, the others' as seen."""
    sizes: dict[str, dict[str, float]] = {}
    for _, _, opp in records.groups:
        for o in opp[0]:
            sizes.setdefault(str(int(o[_O["car_index"]])), {"length_m": round(float(o[_O["length_m"]]), 3),
                                                           "width_m": round(float(o[_O["width_m"]]), 3)})
    for s in slots:
        if s.car is not None:
            sizes[str(int(s.car.car_index))] = {"length_m": round(float(s.car.length_m), 3),
                                                "width_m": round(float(s.car.width_m), 3)}
    return sizes


def _meta(records, slots, track: Track | None, run_dir: RunDir) -> dict:
    meta: dict = {"version": 1, "sample_s": SAMPLE_S, "grid": read_grid(run_dir.race_file),
                  "python": [{"car": int(s.car.car_index), "robot_index": i, "name": s.name, "robot": s.spec}
                             for i, s in enumerate(slots) if s.car is not None],
                  "cars": _car_sizes(records, slots)}
    if track is not None:
        meta["track"] = track_info(track, {i: s.car for i, s in enumerate(slots)})
        try:
            meta["track"]["pit_lane"] = pit_lane_outline(track)
        except Exception as exc:  # a map without its pit lane is still a map
            meta["track"]["pit_lane_error"] = f"{type(exc).__name__}: {exc}"
    return meta


def recording_table(records, slots, track: Track | None, run_dir: RunDir):
    """The rows as a pyarrow table with its metadata (None when no Python car has its index)."""
    import pyarrow as pa

    car_of_robot = {i: int(s.car.car_index) for i, s in enumerate(slots) if s.car is not None}
    if not records or not car_of_robot:
        return None
    cols = merge_rows(records, car_of_robot)
    add_track_columns(cols, track)
    state = cols["car_state"].astype(np.int64)
    cols["in_pit"] = (state & CAR_STATE_PIT) != 0
    cols["out"] = (state & (CAR_STATE_DNF | CAR_STATE_FINISH)) != 0
    ints = {"car": pa.int8(), "lap": pa.int16(), "place": pa.int8(), "damage": pa.int32(), "gear": pa.int8()}
    arrays = {}
    for name, _ in COLUMNS:
        v = cols[name]
        if name in ints:
            arrays[name] = pa.array(np.nan_to_num(v).astype(np.int64), ints[name],
                                    mask=np.isnan(v) if v.dtype.kind == "f" and name == "gear" else None)
        elif name == "pit_request":
            arrays[name] = pa.array(v > 0.5, mask=np.isnan(v))
        elif name in _F32:
            arrays[name] = pa.array(v.astype(np.float32), from_pandas=name in ("steer", "accel", "brake", "clutch"))
        else:
            arrays[name] = pa.array(v)
    table = pa.table(arrays)
    meta = _meta(records, slots, track, run_dir)
    return table.replace_schema_metadata({METADATA_KEY: json.dumps(meta).encode()})


def write_recording(rec: RaceRecorder | None, run_dir: RunDir, slots) -> list[str]:
    """RUN_DIR/recording.parquet from what `rec` holds (slots: the host's, with each Python car's
    Car, Track, name and spec); never raises.  Returns why the recording was lost, if it was."""
    if rec is None:
        return []
    lost = [f"recording: {rec.storage_error}"] if rec.storage_error else []
    try:
        track = next((s.track for s in slots if s.track is not None), None)
        table = recording_table(decode(rec.data()), slots, track, run_dir)
        if table is not None:
            import pyarrow.parquet as pq

            with atomic_path(run_dir.recording) as tmp:
                pq.write_table(table, tmp, compression="zstd", use_dictionary=False)
    except OSError as exc:
        lost.append(f"{run_dir.recording.name} not written: {exc.strerror or exc}")
    except Exception:  # the race's results matter more than its recording
        import sys
        import traceback

        print("boxbox host: writing the race recording failed", file=sys.stderr)
        traceback.print_exc()
    finally:
        rec.remove_spool()
    return lost


class Recording(Telemetry):
    """A recording read back: numpy columns (nulls as NaN) and the metadata, as a telemetry file's."""

    @property
    def cars(self) -> list[int]:
        return sorted(int(c) for c in np.unique(self.columns["car"]))


def load_recording(path: Path) -> Recording:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    raw = (table.schema.metadata or {}).get(METADATA_KEY)
    cols = {}
    for name in table.column_names:
        col = table.column(name)
        if pa.types.is_floating(col.type) or col.null_count:
            cols[name] = np.asarray(col.cast(pa.float64()).to_numpy(zero_copy_only=False), dtype=np.float64)
        else:
            cols[name] = col.to_numpy()
    return Recording(columns=cols, meta=json.loads(raw) if raw else {})
