"""The robot host: the Python process that answers the bridge's messages with robot calls.

Started by the race launcher as `python -m boxbox.torcs.host SPEC.json` with the listening
socket inherited.  One host serves every Python car of a race.  A robot that raises or returns
bad values is a fault: the host writes `fault.json` (with the traceback) and tells the bridge,
which brakes the car and ends the race.  SIGUSR1 dumps the current traceback (for hangs).
"""

from __future__ import annotations

import faulthandler
import json
import math
import os
import signal
import socket
import sys
import traceback
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from time import perf_counter_ns

import numpy as np

from boxbox.files import write_json_atomic
from boxbox.model import Car, Controls, Opponent, PitLane, PitOrder, State, Track
from boxbox.model.state import CAR_STATE_OUT, CAR_STATE_PIT
from boxbox.model.track import LEFT
from boxbox.robot.base import RaceOptions, Robot
from boxbox.robot.loader import load_robot_class
from boxbox.torcs import wire
from boxbox.torcs.telemetry import FILE_NAME as TELEMETRY_FILE
from boxbox.torcs.telemetry import SPILL_BYTES, Recorder, write_telemetry

STATE_SIZE = wire.STATE_REC.size
OPP_SIZE = wire.OPPONENT_REC.size
STEP_S = 0.02  # TORCS calls a robot's drive every 0.02 s of simulated time
STUCK_SPEED_MPS = 1.0  # slower than this outside the pit counts as stuck
MAX_STEP_SAMPLES = 1 << 16  # step times kept per car: every step up to this, then every 2nd, 4th...


@dataclass
class Slot:
    """One Python car: its robot and what the host tracks for it."""

    robot: Robot
    spec: str
    name: str
    car: Car | None = None
    track: Track | None = None
    max_gear: int = 6
    laps_seen: int = 0
    lap_times: list[float] = field(default_factory=list)
    step_ns: array = field(default_factory=lambda: array("q"))  # a sample of the step times (see record_step_time)
    steps_timed: int = 0
    step_stride: int = 1
    chunks: list[bytes] = field(default_factory=list)
    last_state: State | None = None
    # incidents, in drive steps (see watch_step)
    stuck_steps: int = 0
    stuck_run: int = 0
    longest_stuck_steps: int = 0
    off_track_steps: int = 0
    pit_zone: bytes = b""  # 1 per segment between pit entry and exit
    recorder: Recorder | None = None  # telemetry (None: not recorded)
    rec: Recorder | None = None  # the recorder while recording (the drive step's check), else None
    start_fuel_l: float | None = None


class RobotFault(Exception):
    def __init__(self, kind: str, message: str, tb: str = "") -> None:
        super().__init__(message)
        self.kind, self.message, self.tb = kind, message, tb


def decode_track(blob: bytes, name: str, category: str) -> tuple[Track, Car]:
    t = dict(zip(wire.TRACK_FIELDS, wire.TRACK_REC.unpack_from(blob, 0)))
    n = int(t["n_segments"])
    off = wire.TRACK_REC.size
    seg_rows = np.frombuffer(blob, dtype="<f8", count=n * len(wire.SEGMENT_FIELDS), offset=off)
    seg_rows = seg_rows.reshape(n, len(wire.SEGMENT_FIELDS))
    seg = {f: seg_rows[:, i].copy() for i, f in enumerate(wire.SEGMENT_FIELDS)}
    seg["type"] = seg["type"].astype(int)
    seg["race_info"] = seg["race_info"].astype(int)
    off += wire.SEGMENT_REC.size * n
    handle = dict(zip(wire.HANDLE_FIELDS, wire.HANDLE_REC.unpack_from(blob, off)))
    pit = None
    if int(t["pit_type"]) != 0 and t["pit_entry_seg"] >= 0:
        pit = PitLane(side=int(t["pit_side"]), entry_seg=int(t["pit_entry_seg"]), start_seg=int(t["pit_start_seg"]),
                      end_seg=int(t["pit_end_seg"]), exit_seg=int(t["pit_exit_seg"]), width_m=t["pit_width_m"],
                      box_length_m=t["pit_box_length_m"], speed_limit_mps=t["pit_speed_limit_mps"],
                      count=int(t["pit_count"]))
    track = Track(name=name, category=category, length_m=t["length_m"], width_m=t["width_m"], seg=seg, pit=pit)
    handle["drivetrain"] = int(handle["drivetrain"])
    points = int(handle.pop("torque_points"))
    rpm = [handle.pop(f"torque_rpm_{i}") for i in range(wire.MAX_TORQUE_POINTS)]
    torque = [handle.pop(f"torque_nm_{i}") for i in range(wire.MAX_TORQUE_POINTS)]
    handle["torque_curve_radps"], handle["torque_curve_nm"] = tuple(rpm[:points]), tuple(torque[:points])
    return track, Car(**handle)


def complete_car(car: Car, payload: bytes) -> None:
    r = dict(zip(wire.CAR_FIELDS, wire.CAR_REC.unpack_from(payload, 0)))
    ints = {"car_index", "gear_count", "gear_offset", "pit_seg", "start_rank", "race_laps", "skill_level"}
    for key, value in r.items():
        if key.startswith("gear_ratio_"):
            continue
        setattr(car, key, int(value) if key in ints else value)
    car.gear_ratios = tuple(r[f"gear_ratio_{i}"] for i in range(wire.MAX_GEARS))


def pit_zone(track: Track | None) -> bytes:
    """1 for each segment from the pit entry to the pit exit (where the pit lane runs beside the track)."""
    if track is None or track.pit is None:
        return b""
    n = track.n_segments
    zone = bytearray(n)
    entry, exit_ = track.pit.entry_seg % n, track.pit.exit_seg % n
    i = entry
    for _ in range(n):
        zone[i] = 1
        if i == exit_:
            break
        i = (i + 1) % n
    return bytes(zone)


def watch_step(slot: Slot, state: State) -> None:
    """Count a drive step stuck (slower than 1 m/s) or off the track (the car's centre beyond an
    edge), outside the pit: captured in the box, or in the pit lane beside the pit zone, is neither."""
    if int(state.car_state) & (CAR_STATE_PIT | CAR_STATE_OUT):
        slot.stuck_run = 0
        return
    left, right = state.to_left_m, state.to_right_m
    if left < 0.0 or right < 0.0:
        seg = int(state.seg_id)
        if slot.pit_zone and 0 <= seg < len(slot.pit_zone) and slot.pit_zone[seg] and \
                (left < 0.0 if slot.track.pit.side == LEFT else right < 0.0):
            slot.stuck_run = 0
            return  # in the pit lane
        slot.off_track_steps += 1
    if math.hypot(state.speed_x_mps, state.speed_y_mps) < STUCK_SPEED_MPS and state.sim_time_s > 0.0:
        slot.stuck_steps += 1
        slot.stuck_run += 1
        if slot.stuck_run > slot.longest_stuck_steps:
            slot.longest_stuck_steps = slot.stuck_run
    else:
        slot.stuck_run = 0


def record_step_time(slot: Slot, ns: int) -> None:
    """Keep the step times in bounded memory: all of them up to MAX_STEP_SAMPLES, then an evenly
    spaced sample over the whole race (thinned by half, stride doubled, whenever it fills up)."""
    slot.steps_timed += 1
    if slot.steps_timed % slot.step_stride == 0:
        slot.step_ns.append(ns)
        if len(slot.step_ns) >= MAX_STEP_SAMPLES:
            del slot.step_ns[1::2]
            slot.step_stride *= 2


def incidents(slot: Slot) -> dict:
    return {"stuck_s": round(slot.stuck_steps * STEP_S, 2),
            "longest_stuck_s": round(slot.longest_stuck_steps * STEP_S, 2),
            "off_track_s": round(slot.off_track_steps * STEP_S, 2)}


class Host:
    def __init__(self, spec: dict) -> None:
        self.spec = spec
        self.run_dir = Path(spec["run_dir"])
        opts = spec.get("options", {})
        opts["pit_laps"] = tuple(opts.get("pit_laps", ()))
        options = RaceOptions(**opts)
        self.slots: list[Slot] = []
        for entry in spec["robots"]:
            cls = load_robot_class(entry["spec"])
            self.slots.append(Slot(robot=cls(options), spec=entry["spec"], name=entry["name"]))
        if spec.get("telemetry", True):
            for i, slot in enumerate(self.slots):
                slot.rec = slot.recorder = Recorder(i, slot.name, slot.spec, spool_dir=self.run_dir)
        self.alternate = bool(spec.get("telemetry_alternate"))  # bench-telemetry: record odd laps only
        self.other_laps: dict[int, list[float]] = {}
        self._other_seen: dict[int, int] = {}
        self.fault: RobotFault | None = None
        self.out = bytearray(wire.HEADER.size + 64)

    # --- replies -------------------------------------------------------------------------
    def _reply(self, conn: socket.socket, kind: int, robot: int, step: int, rec=None, values=(), flags=0) -> None:
        wire.HEADER.pack_into(self.out, 0, kind, robot, step, flags)
        n = wire.HEADER.size
        if rec is not None:
            rec.pack_into(self.out, n, *values)
            n += rec.size
        conn.send(memoryview(self.out)[:n])

    def _record_fault(self, slot: Slot | None, robot: int, step: int, where: str, fault: RobotFault) -> None:
        if self.fault is None:
            self.fault = fault
            info = {"kind": fault.kind, "message": fault.message, "traceback": fault.tb, "robot_index": robot,
                    "robot": slot.spec if slot else "", "name": slot.name if slot else "", "where": where,
                    "step": step, "sim_time_s": slot.last_state.sim_time_s if slot and slot.last_state else 0.0}
            (self.run_dir / "fault.json").write_text(json.dumps(info, indent=1))

    @staticmethod
    def _call(where: str, fn, *args):
        """A robot call: any exception becomes a RobotFault naming the call, with its traceback."""
        try:
            return fn(*args)
        except Exception as exc:
            tb = traceback.format_exc()
            raise RobotFault("exception", f"{type(exc).__name__}: {exc} (in {where})", tb) from exc

    # --- the loop ------------------------------------------------------------------------
    def serve(self, conn: socket.socket) -> None:
        buf = bytearray(wire.MAX_MESSAGE_BYTES + 64)
        header = wire.HEADER.unpack_from
        state_rec = wire.STATE_REC.unpack_from
        opp_rec = wire.OPPONENT_REC.unpack_from
        controls_rec = wire.CONTROLS_REC.pack_into
        make_state = State._make
        make_opp = Opponent._make
        # the CONTROLS reply is packed into buf right after the state record (over the opponents,
        # decoded by then), so that telemetry records a step with one copy: state, header, controls
        reply_at = wire.HEADER.size + STATE_SIZE
        reply_view = memoryview(buf)[reply_at: reply_at + wire.HEADER.size + wire.CONTROLS_REC.size]
        row_view = memoryview(buf)[wire.HEADER.size: reply_at + wire.HEADER.size + wire.CONTROLS_REC.size]
        state_view = row_view[:STATE_SIZE]
        pack_header = wire.HEADER.pack_into
        hsize = wire.HEADER.size
        slots = self.slots
        while True:
            try:
                n = conn.recv_into(buf)
            except ConnectionResetError:
                n = 0
            if n == 0:
                return
            kind, robot, step, count = header(buf, 0)
            if kind == wire.DRIVE:
                t0 = perf_counter_ns()
                slot = slots[robot]
                vals = state_rec(buf, hsize)
                if count:
                    base = hsize + STATE_SIZE
                    opps = tuple([make_opp(opp_rec(buf, base + i * OPP_SIZE)) for i in range(count)])
                    self._track_other_laps(opps)
                else:
                    opps = ()
                state = make_state(vals + (opps,))
                slot.last_state = state
                watch_step(slot, state)
                if step == 1:
                    slot.start_fuel_l = state.fuel_l
                if vals[29] != slot.laps_seen:  # laps
                    self._lap(slot, state)
                try:
                    c = slot.robot.drive(state)
                    problem = c.problem(slot.max_gear) if type(c) is Controls else f"drive() returned {type(c).__name__}, not Controls"
                    if problem:
                        raise RobotFault("invalid-controls", f"drive() returned invalid controls: {problem} "
                                                             f"(step {step}, t={state.sim_time_s:.2f} s)")
                except RobotFault as fault:
                    self._fail(conn, slot, robot, step, "drive", fault, wire.CONTROLS)
                    continue
                except Exception as exc:
                    fault = RobotFault("exception", f"{type(exc).__name__}: {exc} (in drive, step {step}, "
                                                    f"t={state.sim_time_s:.2f} s)", traceback.format_exc())
                    self._fail(conn, slot, robot, step, "drive", fault, wire.CONTROLS)
                    continue
                pack_header(buf, reply_at, wire.CONTROLS, robot, step, 0)
                controls_rec(buf, reply_at + hsize, c.steer, c.accel, c.brake, c.clutch, c.gear,
                             1.0 if c.pit_request else 0.0)
                conn.send(reply_view)
                rec = slot.rec
                if rec is not None:
                    rec.rows += row_view
                    if rec.tel is not None:
                        try:
                            rec.sig_append(rec.tel(state))
                        except Exception as exc:
                            rec.drop_signals(exc)
                    if len(rec.rows) >= SPILL_BYTES:
                        rec.spill()
                record_step_time(slot, perf_counter_ns() - t0)
            elif kind == wire.NEW_TRACK:
                slot = slots[robot]
                slot.chunks.append(bytes(buf[hsize:n]))
                if step + 1 < count:
                    continue  # more chunks follow
                blob = b"".join(slot.chunks)
                slot.chunks = []
                try:
                    slot.track, slot.car = decode_track(blob, self.spec["track"], self.spec["category"])
                    slot.car.name = self.spec["car"]
                    fuel = self._call("initial_fuel_l", slot.robot.initial_fuel_l, slot.track, slot.car)
                    if fuel is not None and not (isinstance(fuel, (int, float)) and 0 <= fuel < math.inf):
                        raise RobotFault("invalid-value", f"initial_fuel_l() returned {fuel!r}; expected litres >= 0 or None")
                except RobotFault as fault:
                    self._fail(conn, slot, robot, step, "initial_fuel_l", fault, wire.FUEL)
                    continue
                self._reply(conn, wire.FUEL, robot, step, wire.FUEL_REC, (-1.0 if fuel is None else float(fuel),))
            elif kind == wire.NEW_RACE:
                slot = slots[robot]
                complete_car(slot.car, bytes(buf[hsize:n]))
                slot.max_gear = slot.car.max_gear
                slot.pit_zone = pit_zone(slot.track)
                try:
                    self._call("on_track", slot.robot.on_track, slot.track, slot.car)
                except RobotFault as fault:
                    self._fail(conn, slot, robot, step, "on_track", fault, wire.ACK)
                    continue
                if slot.recorder is not None:
                    slot.recorder.start(slot.robot)
                self._reply(conn, wire.ACK, robot, step)
            elif kind == wire.PIT_CMD:
                slot = slots[robot]
                state = make_state(state_rec(buf, hsize) + ((),))
                if slot.rec is not None:  # the stop itself: TORCS drives no car it holds in the pit
                    slot.rec.add(bytes(state_view), state)
                try:
                    order = self._call("pit_stop", slot.robot.pit_stop, state)
                    problem = order.problem() if type(order) is PitOrder else f"pit_stop() returned {type(order).__name__}, not PitOrder"
                    if problem:
                        raise RobotFault("invalid-value", f"pit_stop() returned an invalid order: {problem}")
                except RobotFault as fault:
                    self._fail(conn, slot, robot, step, "pit_stop", fault, wire.PIT_ORDER)
                    continue
                self._reply(conn, wire.PIT_ORDER, robot, step, wire.PIT_ORDER_REC, (float(order.fuel_l), float(order.repair)))
            elif kind == wire.END_RACE:
                slot = slots[robot]
                state = make_state(state_rec(buf, hsize) + ((),))
                self._lap(slot, state)
                try:
                    self._call("on_race_end", slot.robot.on_race_end, state)
                except RobotFault as fault:
                    self._fail(conn, slot, robot, step, "on_race_end", fault, wire.ACK)
                    continue
                self._reply(conn, wire.ACK, robot, step)
            elif kind == wire.HELLO:
                self._reply(conn, wire.HELLO, robot, step, wire.HELLO_REC, (wire.PROTOCOL_VERSION, 0.0, 0.0))
            elif kind == wire.SHUTDOWN:
                continue

    def _fail(self, conn, slot, robot, step, where, fault: RobotFault, reply_kind: int) -> None:
        self._record_fault(slot, robot, step, where, fault)
        self._reply(conn, reply_kind, robot, step, flags=wire.FLAG_FAULT)

    def _lap(self, slot: Slot, state: State) -> None:
        laps = int(state.laps)
        if self.alternate:
            self._alternate(slot, laps)
        if laps > slot.laps_seen and slot.laps_seen >= 1 and state.last_lap_time_s > 0:
            slot.lap_times.append(state.last_lap_time_s)
            self._save_progress()
        slot.laps_seen = max(slot.laps_seen, laps)

    def _save_progress(self) -> None:
        """Lap times so far, once per lap, so a host that is killed or hangs loses none of them."""
        cars = [{"robot_index": i, "robot": s.spec, "name": s.name,
                 "car_index": s.car.car_index if s.car else None, "lap_times": s.lap_times,
                 "steps": s.steps_timed, "start_fuel_l": s.start_fuel_l, "step_us_median": None,
                 "step_us_p99": None, "report": {}, **incidents(s)} for i, s in enumerate(self.slots)]
        try:
            write_json_atomic(self.run_dir / "host-progress.json",
                              {"cars": cars, "other_lap_times": {str(k): v for k, v in self.other_laps.items()}})
        except OSError:
            pass  # only a safety copy: host.json at the end has it all

    def _track_other_laps(self, opps: tuple[Opponent, ...]) -> None:
        seen = self._other_seen
        for o in opps:
            idx = int(o.car_index)
            laps = int(o.laps)
            before = seen.get(idx, 0)
            if laps > before:
                if before >= 1 and o.last_lap_time_s > 0:
                    self.other_laps.setdefault(idx, []).append(o.last_lap_time_s)
                seen[idx] = laps

    def _alternate(self, slot: Slot, lap: int) -> None:
        """bench-telemetry: record odd laps only, and keep each whole lap's step median (from lap 2:
        lap 1 holds the start) with whether it was recorded, so one race compares both."""
        rec = slot.recorder
        if rec is None or lap == rec.alt_lap:
            return
        if rec.alt_lap >= 2 and slot.step_stride == 1:  # step_ns still holds every step
            part = sorted(slot.step_ns[rec.alt_mark:])
            if part:
                rec.lap_step_us.append((rec.alt_lap, slot.rec is not None, part[len(part) // 2] / 1000))
        rec.alt_lap, rec.alt_mark = lap, len(slot.step_ns)
        slot.rec = rec if lap % 2 == 1 else None

    def write_telemetry(self) -> None:
        """RUN_DIR/telemetry.parquet from what was recorded, also after a fault; never raises."""
        recorders = [s.recorder for s in self.slots if s.recorder is not None]
        if not recorders:
            return
        try:
            track = next((s.track for s in self.slots if s.track is not None), None)
            write_telemetry(self.run_dir / TELEMETRY_FILE, recorders, track,
                            {i: s.car for i, s in enumerate(self.slots)})
        except Exception:
            print("boxbox host: writing the telemetry failed", file=sys.stderr)
            traceback.print_exc()

    def summary(self) -> dict:
        cars = []
        for i, slot in enumerate(self.slots):
            ns = sorted(slot.step_ns)
            try:
                report = slot.robot.race_report() if slot.car is not None else {}
                json.dumps(report)
            except Exception as exc:  # a report must never lose the race's results
                report = {"report_error": f"{type(exc).__name__}: {exc}"}
            cars.append({
                "robot_index": i, "robot": slot.spec, "name": slot.name,
                "car_index": slot.car.car_index if slot.car else None,
                "lap_times": slot.lap_times, "steps": slot.steps_timed, "start_fuel_l": slot.start_fuel_l,
                "step_us_median": ns[len(ns) // 2] / 1000 if ns else None,
                "step_us_p99": ns[min(len(ns) - 1, int(len(ns) * 0.99))] / 1000 if ns else None,
                "report": report,
                **incidents(slot),
            })
        return {"cars": cars, "other_lap_times": {str(k): v for k, v in self.other_laps.items()}}


def main(argv: list[str]) -> int:
    spec = json.loads(Path(argv[0]).read_text())
    run_dir = Path(spec["run_dir"])
    os.environ["BOXBOX_RUN_DIR"] = str(run_dir)  # robots may keep files of their race here
    hang_file = open(run_dir / "hang-traceback.txt", "w")
    faulthandler.register(signal.SIGUSR1, file=hang_file, all_threads=False)
    listener = socket.socket(fileno=int(spec["listen_fd"]))
    try:
        host = Host(spec)
    except Exception as exc:  # robot import or constructor failed
        (run_dir / "fault.json").write_text(json.dumps({
            "kind": "exception", "message": f"{type(exc).__name__}: {exc} (creating the robot)",
            "traceback": traceback.format_exc(), "robot_index": -1, "robot": "", "name": "", "where": "__init__",
            "step": 0, "sim_time_s": 0.0}))
        return 1
    listener.settimeout(float(spec.get("connect_timeout_s", 60)))
    try:
        conn, _ = listener.accept()
    except TimeoutError:
        return 2
    conn.settimeout(None)
    (run_dir / "host-connected").touch()  # tells the launcher that TORCS's bridge got through
    try:
        host.serve(conn)
    except (BrokenPipeError, ConnectionResetError):
        pass  # TORCS went away while we answered (killed): what we have is written below
    finally:
        try:
            write_json_atomic(run_dir / "host.json", host.summary())
        finally:
            host.write_telemetry()  # what was recorded, also after a robot fault
    return 1 if host.fault else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
