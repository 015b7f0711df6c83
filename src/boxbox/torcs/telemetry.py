"""Telemetry: every drive step of every Python car, buffered, spilled to disk, written as Parquet.

The robot host records a step with one byte copy (the state record as the bridge sent it, followed
in the host's buffer by the CONTROLS reply as it was sent: header and controls record), the nearest
other car's index and place (three doubles) and, when the robot names telemetry fields, one list
append of the tuple `Robot.telemetry(state)` returns.  Every SPILL_STEPS steps the buffer goes to a
spool file in the run dir (`spill`), so the host's memory stays flat over a race of any length (a
200-lap race grew it by 200 MB before).  Besides the nearest other car (`nearest_car`: a loop over
the opponents the robot is given anyway, about 4 microseconds for nine), nothing is decoded while
the race runs; `write_telemetry` turns spool and buffer into columns at the end (also after a robot
fault: the host's `finally` calls it), so partial telemetry survives a failed race.

File: RUN_DIR/telemetry.parquet, one row per drive step per Python car, columns in `COLUMNS`
order, then `sig_<name>` for each robot signal.  The schema metadata key `boxbox` holds JSON with
the track (length, edges for a map, pit lane) and per car its name, robot, signal names, box
position and any telemetry error.  `load_telemetry` reads it back as numpy columns.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from boxbox.files import atomic_path
from boxbox.model import Car, Track
from boxbox.torcs import wire
from boxbox.torcs.rundir import TELEMETRY_FILE, RunDir
from boxbox.torcs.timing import STEP_S

FILE_NAME = TELEMETRY_FILE  # RUN_DIR/telemetry.parquet
METADATA_KEY = b"boxbox"
TARGET_FIELD = "target_speed_mps"  # a robot signal of this name fills the target speed column
SIGNAL_PREFIX = "sig_"
N_STATE = len(wire.STATE_FIELDS)
N_CONTROLS = len(wire.CONTROLS_FIELDS)
N_HEADER = wire.HEADER.size // 8
# the nearest other car at the step (`nearest_car` below): its TORCS car index (-1: none)
# and where its centre is from ours in our car's frame
NEAR_FIELDS = ("near_car", "near_ahead_m", "near_left_m")
NEAR_REC = struct.Struct("<3d")
# one recorded step: the state record, the reply's header (ignored), the controls record, the nearest car
ROW_DOUBLES = N_STATE + N_HEADER + N_CONTROLS + len(NEAR_FIELDS)
_S = {f: i for i, f in enumerate(wire.STATE_FIELDS)}
_C = {f: N_STATE + N_HEADER + i for i, f in enumerate(wire.CONTROLS_FIELDS)}
_N = {f: N_STATE + N_HEADER + N_CONTROLS + i for i, f in enumerate(NEAR_FIELDS)}
RAD_S_TO_RPM = 60.0 / (2.0 * math.pi)
ROW_BYTES = 8 * ROW_DOUBLES
SPILL_STEPS = 5000  # steps kept in memory before they go to the spool file (100 s of racing, ~2.5 MB)
SPILL_BYTES = SPILL_STEPS * ROW_BYTES
NO_CONTROLS = wire.CONTROLS_REC.pack(*[math.nan] * N_CONTROLS)  # a pit stop row: the race engine holds the car
_NO_HEADER = bytes(wire.HEADER.size)
NO_NEAR = NEAR_REC.pack(-1.0, math.nan, math.nan)

# (column, unit / meaning) in file order; documented in docs/report.md
COLUMNS = [
    ("car", "robot index of the Python car (its `idx` in result.json)"),
    ("driver", "driver name"),
    ("time_s", "simulated time"),
    ("lap", "lap being driven (TORCS count: 1 during the first lap, 0 before the start line)"),
    ("dist_m", "distance from the start line along the track"),
    ("dist_raced_m", "distance raced since the start"),
    ("x_m", "position"),
    ("y_m", "position"),
    ("speed_mps", "speed along the car's axis"),
    (TARGET_FIELD, "the robot's target speed (its speed profile), null when the robot gives none"),
    ("accel", "throttle command [0, 1]"),
    ("brake", "brake command [0, 1]"),
    ("clutch", "clutch command [0, 1], 1 = disengaged"),
    ("gear", "gear engaged (-1 reverse, 0 neutral)"),
    ("rpm", "engine speed in revolutions per minute"),
    ("steer", "steer command [-1, 1], + left"),
    ("to_middle_m", "track position: distance from the middle line, + left"),
    ("fuel_l", "fuel in the tank"),
    ("damage", "damage points"),
    ("in_pit", "captured by the race engine in the pit box (the row TORCS sends at the stop; no controls)"),
    ("pit_request", "the robot asks for a pit stop"),
    ("near_car", "the nearest other car, centre to centre: its TORCS car index (`car_index` in result.json), "
                 "-1 when there is none (racing alone, and the pit stop's row)"),
    ("near_ahead_m", "... its centre ahead of ours along our car's axis (- behind), null when none"),
    ("near_left_m", "... its centre to the left of ours across our car's axis (- right), null when none"),
]


def nearest_car(x_m: float, y_m: float, yaw_rad: float, opponents) -> bytes:
    """The nearest of the opponents (centre to centre) packed as NEAR_REC: its car index, and its
    centre ahead of ours and to our left in our car's frame; NO_NEAR when there are none.  Called on
    the drive step while recording, so a plain loop (nine cars: a few microseconds)."""
    best, best_d2 = None, math.inf
    for o in opponents:
        d2 = (o.x_m - x_m) ** 2 + (o.y_m - y_m) ** 2
        if d2 < best_d2:
            best, best_d2 = o, d2
    if best is None:  # none, or only cars TORCS lost (NaN places never compare nearer)
        return NO_NEAR
    dx, dy = best.x_m - x_m, best.y_m - y_m
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return NEAR_REC.pack(float(best.car_index), dx * c + dy * s, dy * c - dx * s)


class Recorder:
    """One Python car's telemetry while the race runs (the host appends to `rows` and `signals`, and
    calls `spill` when `rows` holds SPILL_BYTES).

    spool_dir: where the steps go when the buffer is full (None: all kept in memory, for tests)."""

    __slots__ = ("index", "name", "spec", "rows", "signals", "sig_append", "tel", "names", "error", "spool_dir",
                 "spilled_steps", "storage_error")

    def __init__(self, index: int, name: str, spec: str, spool_dir: Path | None = None) -> None:
        self.index, self.name, self.spec = index, name, spec
        self.rows = bytearray()  # ROW_DOUBLES little-endian float64 per step (see ROW_DOUBLES)
        self.signals: list[tuple] = []  # one tuple per step, in `names` order
        self.sig_append = self.signals.append
        self.spool_dir = spool_dir
        self.spilled_steps = 0
        self.tel: Callable[[Any], tuple] | None = None  # the robot's bound telemetry method; None: no signals
        self.names: tuple[str, ...] = ()
        self.error: str | None = None
        self.storage_error: str | None = None  # why the steps could not be kept on disk (then: not recorded)

    @property
    def steps(self) -> int:
        return self.spilled_steps + len(self.rows) // ROW_BYTES

    def _spool(self, kind: str) -> Path:
        assert self.spool_dir is not None
        return RunDir(self.spool_dir).spool(self.index, kind)

    def spill(self) -> bool:
        """Move the buffered steps to the spool files (rows as recorded, signals as float64).
        False when they cannot be written (a full disk): then the car's telemetry is given up, its
        spool removed (the space goes back to the race's results) and `storage_error` says why."""
        if self.spool_dir is None or not self.rows:
            return True
        try:
            if self.names:
                sig = self._signal_array()
                if sig is not None:
                    with open(self._spool("sig"), "ab") as f:
                        f.write(sig.tobytes())
            with open(self._spool("rows"), "ab") as f:
                f.write(self.rows)
        except OSError as exc:
            self.storage_error = f"{exc.strerror or exc} at step {self.steps} in {self.spool_dir}"
            self.remove_spool()
            self.rows, self.spilled_steps = bytearray(), 0
            self.signals.clear()
            return False
        self.spilled_steps += len(self.rows) // ROW_BYTES
        self.rows = bytearray()
        self.signals.clear()
        return True

    def _signal_array(self, spilled: bool = False) -> np.ndarray | None:
        """The buffered signal tuples (after the spooled ones, when spilled) as a (steps, names)
        float64 array, or None when they do not fit the names: then the signals are dropped."""
        k = len(self.names)
        try:
            sig = np.array(self.signals, dtype="<f8") if self.signals else np.empty((0, k))
            if spilled and self.spilled_steps:
                sig = np.concatenate([np.fromfile(self._spool("sig"), dtype="<f8").reshape(self.spilled_steps, k), sig])
            n = (self.spilled_steps if spilled else 0) + len(self.rows) // ROW_BYTES
            if sig.shape != (n, k):
                raise ValueError(f"expected {n} steps x {k} values, got shape {sig.shape}")
        except (ValueError, TypeError, OSError) as exc:
            self.drop_signals(exc, f"telemetry() values do not match telemetry_fields() {self.names}: {exc}; "
                                   "robot signals dropped")
            return None
        return sig

    def remove_spool(self) -> None:
        if self.spool_dir is not None:
            for kind in ("rows", "sig"):
                self._spool(kind).unlink(missing_ok=True)

    def start(self, robot) -> None:
        """Ask the robot for its signal names once (after on_track).  A robot error here costs only
        its signals, never the race."""
        try:
            names = tuple(robot.telemetry_fields())
            bad = [n for n in names if not isinstance(n, str) or not n]
            if bad or len(set(names)) != len(names):
                raise ValueError(f"names must be distinct non-empty strings, got {names!r}")
        except Exception as exc:
            self.error = f"telemetry_fields() failed: {type(exc).__name__}: {exc}; robot signals not recorded"
            return
        self.names = names
        self.tel = robot.telemetry if names else None

    def add(self, state_record: bytes, state, controls: bytes = NO_CONTROLS) -> None:
        """Record one step off the hot path (the state TORCS sends when it captures the car in its pit;
        no opponents come with it, so no nearest car)."""
        self.rows += state_record
        self.rows += _NO_HEADER
        self.rows += controls
        self.rows += NO_NEAR
        if self.tel is not None:
            self.add_signals(state)

    def add_signals(self, state) -> None:
        """The robot's telemetry() tuple for this step (the host calls it only when tel is set)."""
        tel = self.tel
        if tel is None:
            return
        try:
            self.sig_append(tel(state))
        except Exception as exc:
            self.drop_signals(exc)

    def drop_signals(self, exc: BaseException, why: str | None = None) -> None:
        """telemetry() raised (or its values did not fit): keep recording the car, without the
        robot's signals."""
        self.error = why or f"telemetry() raised {type(exc).__name__}: {exc}; robot signals dropped"
        self.tel = None
        self.names = ()
        self.signals.clear()
        if self.spool_dir is not None:
            self._spool("sig").unlink(missing_ok=True)

    # --- at the end ----------------------------------------------------------------------------
    def recorded_rows(self) -> np.ndarray:
        """Every recorded step as a (steps, ROW_DOUBLES) array: the spool's, then the buffer's."""
        n = self.steps
        rows = bytes(self.rows)
        if self.spilled_steps:
            rows = self._spool("rows").read_bytes()[: self.spilled_steps * ROW_BYTES] + rows
        return np.frombuffer(rows, dtype="<f8", count=n * ROW_DOUBLES).reshape(n, ROW_DOUBLES)

    def columns(self, a: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The recorded steps (`recorded_rows`, read when not given) as named numpy columns (the
        signals as sig_<name>, the target apart)."""
        if a is None:
            a = self.recorded_rows()
        n = len(a)
        cols: dict[str, np.ndarray] = {
            "car": np.full(n, self.index, dtype=np.int16),
            "time_s": a[:, _S["sim_time_s"]].copy(),
            "lap": a[:, _S["laps"]].astype(np.int16),
            "dist_m": a[:, _S["dist_from_start_m"]].copy(),
            "dist_raced_m": a[:, _S["dist_raced_m"]].copy(),
            "x_m": a[:, _S["x_m"]].copy(),
            "y_m": a[:, _S["y_m"]].copy(),
            "speed_mps": a[:, _S["speed_x_mps"]].copy(),
            "accel": a[:, _C["accel"]].copy(),
            "brake": a[:, _C["brake"]].copy(),
            "clutch": a[:, _C["clutch"]].copy(),
            "gear": a[:, _S["gear"]].astype(np.int8),
            "rpm": a[:, _S["rpm"]] * RAD_S_TO_RPM,
            "steer": a[:, _C["steer"]].copy(),
            "to_middle_m": a[:, _S["to_middle_m"]].copy(),
            "fuel_l": a[:, _S["fuel_l"]].copy(),
            "damage": a[:, _S["damage"]].copy(),
            "in_pit": (a[:, _S["car_state"]].astype(np.int64) & 1) != 0,
            "pit_request": a[:, _C["pit_request"]] > 0.5,
            "near_car": a[:, _N["near_car"]].astype(np.int16),
            "near_ahead_m": a[:, _N["near_ahead_m"]].copy(),
            "near_left_m": a[:, _N["near_left_m"]].copy(),
        }
        names = self.names
        sig = self._signal_array(spilled=True) if names else None
        if sig is not None:
            for j, name in enumerate(names):
                cols[name if name == TARGET_FIELD else SIGNAL_PREFIX + name] = sig[:, j]
        return cols


def track_edges(track: Track) -> dict[str, list[float]]:
    """The track's edges for a map: the corners of every segment (TORCS splits turns into segments
    of a few metres, so the polygon follows them closely), closed at the start line."""
    seg = track.seg
    edges = {}
    for side in ("left", "right"):
        for axis in ("x", "y"):
            points = np.append(seg[f"start_{side}_{axis}"], seg[f"end_{side}_{axis}"][-1])
            edges[f"{side}_{axis}"] = np.round(points.astype(float), 2).tolist()
    return edges


def track_info(track: Track, cars: dict[int, Car | None]) -> dict:
    """What a report needs of the track: length, edges (for the map), pit lane, each car's box."""
    info: dict = {"name": track.name, "category": track.category, "length_m": float(track.length_m),
                  "width_m": float(track.width_m)}
    try:
        info["edges"] = track_edges(track)
    except Exception as exc:  # a map without edges is still a map
        info["edges_error"] = f"{type(exc).__name__}: {exc}"
    pit = track.pit
    if pit is not None:
        starts, lengths = track.seg["start_dist_m"], track.seg["length_m"]
        info["pit"] = {"entry_m": float(starts[pit.entry_seg]), "limit_start_m": float(starts[pit.start_seg]),
                       "limit_end_m": float(starts[pit.end_seg] + lengths[pit.end_seg]),
                       "exit_m": float(starts[pit.exit_seg] + lengths[pit.exit_seg]),
                       "speed_limit_mps": float(pit.speed_limit_mps), "side": int(pit.side),
                       "box_length_m": float(pit.box_length_m),
                       "box_m": {str(i): float(track.dist_of(c.pit_seg, c.pit_to_start))
                                 for i, c in cars.items() if c is not None and c.pit_seg >= 0}}
    return info


def write_telemetry(path: Path, recorders: list[Recorder], track=None, cars: dict | None = None) -> int:
    """Write every recorder's steps to one Parquet file (atomically); returns the number of rows.
    Writes nothing when no step was recorded."""
    if not any(r.steps for r in recorders):
        return 0
    import pyarrow as pa
    import pyarrow.parquet as pq

    tables, states = [], []
    for rec in recorders:
        if not rec.steps:
            continue
        rows = rec.recorded_rows()
        states.append(state_table(rec.index, rows))
        cols = rec.columns(rows)
        n = rec.steps
        arrays = {}
        for name, _ in COLUMNS:
            if name == "driver":
                codes = pa.array(np.zeros(n, dtype=np.int32))
                arrays[name] = pa.DictionaryArray.from_arrays(codes, pa.array([rec.name]))
            elif name == TARGET_FIELD and name not in cols:
                arrays[name] = pa.nulls(n, pa.float64())
            elif name in NEAR_FIELDS[1:]:
                arrays[name] = pa.array(cols[name], from_pandas=True)  # NaN (no other car) as null
            else:
                arrays[name] = pa.array(cols[name])
        for name, values in cols.items():
            if name.startswith(SIGNAL_PREFIX):
                arrays[name] = pa.array(values)
        tables.append(pa.table(arrays))
    table = pa.concat_tables(tables, promote_options="default") if len(tables) > 1 else tables[0]
    meta = {"version": 1, "step_s": STEP_S,
            "cars": [{"car": r.index, "name": r.name, "robot": r.spec, "steps": r.steps, "signals": list(r.names),
                      "error": r.error} for r in recorders]}
    if track is not None:
        meta["track"] = track_info(track, cars or {})
    table = table.replace_schema_metadata({METADATA_KEY: json.dumps(meta).encode()})
    with atomic_path(path) as tmp:
        # dictionary pages only for the driver's name: on float columns they cost two thirds of the
        # write (66 -> 25 ms for a 20-lap race's 38,700 rows) and make the file larger
        pq.write_table(table, tmp, compression="zstd", use_dictionary=["driver"])
    with atomic_path(RunDir(path.parent).states) as tmp:
        # split float bytes, then lz4: 47,000 steps (20 laps of g-track-1) in 56 ms and 2.1 MB, against
        # 70 ms and 1.9 MB with zstd, 116 ms and 7.9 MB with snappy alone, 17.5 MB uncompressed
        pq.write_table(pa.concat_tables(states), tmp, compression="lz4", use_dictionary=False,
                       use_byte_stream_split=True, write_statistics=False)
    for rec in recorders:
        rec.remove_spool()
    return table.num_rows


def state_table(car: int, rows: np.ndarray):
    """The State record of each drive step in a recorder's rows (`Recorder.recorded_rows`; a pit
    stop's row, which has no controls, is not a drive step) as a pyarrow table: `car`, then
    wire.STATE_FIELDS, float64 as the robot got them (RUN_DIR/states.parquet, `boxbox.testing.recorded_states`)."""
    import pyarrow as pa

    by_field = np.ascontiguousarray(rows[:, :N_STATE].T)  # a field per row: pyarrow takes each without a copy
    drive = ~np.isnan(rows[:, _C["steer"]])
    if not drive.all():
        by_field = by_field[:, drive]
    arrays = {"car": pa.array(np.full(by_field.shape[1], car, dtype=np.int16))}
    arrays.update({name: pa.array(by_field[i]) for i, name in enumerate(wire.STATE_FIELDS)})
    return pa.table(arrays)


def load_states(path: Path, car: int) -> np.ndarray:
    """The State records of one Python car (its robot index) in a states file: (steps, STATE_FIELDS)."""
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    mine = table.column("car").to_numpy() == car
    return np.column_stack([table.column(name).to_numpy()[mine] for name in wire.STATE_FIELDS])


@dataclass
class Telemetry:
    """A telemetry file read back: numpy columns (nulls as NaN) and the metadata."""

    columns: dict[str, np.ndarray]
    meta: dict

    @property
    def rows(self) -> int:
        return len(self.columns["time_s"]) if self.columns else 0

    def car(self, index: int) -> dict[str, np.ndarray]:
        """The rows of one Python car, in time order."""
        mask = self.columns["car"] == index
        return {k: v[mask] for k, v in self.columns.items()}


def load_telemetry(path: Path) -> Telemetry:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    raw = (table.schema.metadata or {}).get(METADATA_KEY)
    meta = json.loads(raw) if raw else {}
    cols = {}
    for name in table.column_names:
        col = table.column(name)
        if name == "driver":
            cols[name] = np.array(col.to_pylist(), dtype=object)
        elif pa.types.is_floating(col.type):
            cols[name] = np.asarray(col.to_numpy(), dtype=np.float64)  # nulls become NaN
        else:
            cols[name] = col.to_numpy()
    return Telemetry(columns=cols, meta=meta)
