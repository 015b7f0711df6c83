"""The robot host: the Python process that answers the bridge's messages with robot calls.

Started by the race launcher (forked, or as `python -m boxbox.torcs.host_process SPEC.json`: the
process entry, torcs/host_process.py) with the
listening socket and the write end of its pipe to the launcher (torcs/hostlink.py) inherited.  One
host serves every Python car of a race.  A robot that raises, exits, or returns bad values is a
fault: the host makes a `Fault` record (torcs/faults.py), tells the launcher and the bridge, which
brakes the car and ends the race.  SIGUSR1 dumps the current traceback (for hangs).
"""

from __future__ import annotations

import contextlib
import gc
import math
import os
import socket
import traceback
from time import perf_counter_ns

from boxbox.model import Car, Controls, Opponent, PitOrder, State, Track
from boxbox.robot.base import RaceOptions, Robot
from boxbox.robot.loader import load_robot_class
from boxbox.torcs import messages, wire
from boxbox.torcs.car_setup import apply_setup, car_settings, checked_setup
from boxbox.torcs.carwatch import (
    HostedCar,
    car_json,
    every_car_lost,
    pit_zone,
    record_step_time,
    watch_step,
)
from boxbox.torcs.faults import Fault, FaultKind, RobotCall
from boxbox.torcs.hostlink import HostLink
from boxbox.torcs.messages import HSIZE, OPPONENTS_AT, decode_state, decode_track, pack_controls
from boxbox.torcs.pitwatch import PitWatch
from boxbox.torcs.recording import RaceRecorder, write_recording
from boxbox.torcs.robot_output import CALLER, host_message
from boxbox.torcs.rundir import RunDir
from boxbox.torcs.telemetry import NO_NEAR, SPILL_BYTES, Recorder, nearest_car, write_telemetry
from boxbox.torcs.timing import HEARTBEAT_S, MIN_SPEED_MPS, TimeModel

BREAKDOWN_S = 1.0  # simulated time TORCS may have lost every car before the race is stopped
# set in a child a robot forks (os.fork): back in the host's code it must end at once, never answer
# the bridge or send the launcher a summary (see forked_child)
FORKED = [False]


HEARTBEAT_NS = int(HEARTBEAT_S * 1e9)


class CallAbandoned(BaseException):
    """The launcher gave up on the robot call the host is in (SIGUSR2, after the bridge stopped the
    race for a call past its budget): the host leaves it, and ends the race as in any ending, with
    each robot's on_race_end (docs/robots.md promises it once in every ending)."""


MEMORY_LIMIT_GIB: list[float | None] = [None]  # the robots' allowance (RaceConfig.memory_limit_gib)
_ABANDON_ARMED = [False]  # SIGUSR2 raises CallAbandoned only while the host serves the bridge


def abandon_call(signum: int, frame) -> None:
    if _ABANDON_ARMED[0]:
        _ABANDON_ARMED[0] = False  # once: on_race_end that follows runs to its end
        raise CallAbandoned


class RobotFault(Exception):
    """A robot call went wrong; the host turns it into a `Fault` record naming the car."""

    def __init__(self, kind: FaultKind, message: str, tb: str = "") -> None:
        super().__init__(message)
        self.kind, self.message, self.tb = kind, message, tb

    @classmethod
    def from_exception(cls, exc: BaseException, context: str) -> RobotFault:
        """An exception out of a robot call (`context`: "in drive, step 3", "creating the robot"), or
        its sys.exit(): the robot exiting is reported as such at once, never as a hang (SystemExit
        would otherwise end the host)."""
        tb = traceback.format_exc()
        if isinstance(exc, MemoryError) and MEMORY_LIMIT_GIB[0] is not None:
            return cls("exception", f"the robot used more than {MEMORY_LIMIT_GIB[0]:g} GiB of memory ({context}); "
                                    "give it more with --memory-limit", tb)
        if isinstance(exc, SystemExit):
            code = "" if exc.code is None else repr(exc.code)
            return cls("exit", f"the robot called sys.exit({code}) ({context})", tb)
        return cls("exception", f"{type(exc).__name__}: {exc} ({context})", tb)


def check_start_fuel(fuel, car: Car) -> None:
    """initial_fuel_l's answer: None or litres that fit in the tank (TORCS would cut more to the
    tank's size without a word: a robot that asks for more has its sums wrong, and is told)."""
    if fuel is None:
        return
    if not (isinstance(fuel, (int, float)) and 0 <= fuel < math.inf):
        raise RobotFault("invalid-value", f"initial_fuel_l() returned {fuel!r}; expected litres >= 0 or None")
    if fuel > car.tank_l + 1e-6:
        raise RobotFault("invalid-value", f"initial_fuel_l() returned {fuel:g} l, more than the tank holds "
                                          f"({car.tank_l:g} l): return at most car.tank_l, or None for the car's own")


def robot_call(where: str, fn, *args):
    """A robot call: any exception, or its sys.exit(), becomes a RobotFault naming the call."""
    try:
        return fn(*args)
    except CallAbandoned:
        raise
    except BaseException as exc:  # noqa: BLE001  (a robot's SystemExit is its fault too)
        raise RobotFault.from_exception(exc, f"in {where}") from exc


def robot_drive(robot: Robot, state: State, step: int, max_gear: int) -> Controls:
    """The robot's controls for the drive step, checked: a RobotFault naming the step for a raise,
    an exit or invalid controls (the robot host's, and the env's teacher's, gym/teacher.py)."""
    try:
        c = robot.drive(state)
    except CallAbandoned:
        raise
    except BaseException as exc:  # noqa: BLE001  (a robot's SystemExit is its fault too)
        raise RobotFault.from_exception(exc, f"in drive, step {step}, t={state.sim_time_s:.2f} s") from exc
    problem = c.problem(max_gear) if type(c) is Controls else f"drive() returned {type(c).__name__}, not Controls"
    if problem:
        raise RobotFault("invalid-controls", f"drive() returned invalid controls: {problem} "
                                             f"(step {step}, t={state.sim_time_s:.2f} s)")
    return c


class Host:
    """Answers the bridge's messages with robot calls; tells the launcher what it sees (HostLink)."""

    def __init__(self, spec: dict, link: HostLink | None = None) -> None:
        self.spec = spec
        self.run_dir = RunDir(spec["run_dir"])
        self.link = link or HostLink(None)
        opts = dict(spec.get("options", {}))
        opts["pit_laps"] = tuple(opts.get("pit_laps", ()))
        options = RaceOptions(**opts)
        self.pit_laps = options.pit_laps
        self.slots: list[HostedCar] = []
        for i, entry in enumerate(spec["robots"]):
            cls = load_robot_class(entry["spec"], isolated=False)  # the host is the robot's own process
            CALLER[0] = i  # what the robot's constructor prints is marked with its car
            self.slots.append(HostedCar(robot=cls(options), spec=entry["spec"], name=entry["name"]))
        if spec.get("telemetry", True):
            for i, slot in enumerate(self.slots):
                slot.rec = slot.recorder = Recorder(i, slot.name, slot.spec, spool_dir=self.run_dir.path)
        limits = spec.get("limits", {})
        self.laps = int(limits.get("laps", 0))
        self.min_speed_mps = float(limits.get("min_speed_mps", MIN_SPEED_MPS))
        self.sim_limit_s = math.inf  # set when the track is known
        self.other_laps: dict[int, list[float]] = {}
        self._other_seen: dict[int, int] = {}
        self.fault: Fault | None = None
        self._beat_due_ns = 0  # perf_counter_ns after which the next heartbeat is sent
        self.buf = bytearray(wire.MAX_MESSAGE_BYTES + 64)
        self.out = bytearray(messages.REPLY_BYTES)
        # every car, 10 times a second, for `boxbox replay` (torcs/recording.py)
        self.race_rec = RaceRecorder(self.buf, self.run_dir.recording_spool) if spec.get("telemetry", True) else None

    # --- replies and faults ----------------------------------------------------------------
    def _reply(self, conn: socket.socket, kind: int, robot: int, step: int, rec=None, values=(), flags=0) -> None:
        conn.send(messages.pack_reply(self.out, kind, robot, step, rec, values, flags))

    def _fail(self, conn, robot: int, step: int, where: RobotCall, fault: RobotFault, reply_kind: int) -> None:
        """Record the fault (the first one of the race) and tell the bridge: it brakes the car and
        ends the race."""
        self._record_fault(robot, step, where, fault)
        self._reply(conn, reply_kind, robot, step, flags=wire.FLAG_FAULT)

    def _record_fault(self, robot: int, step: int, where: RobotCall, fault: RobotFault) -> None:
        """Keep the race's first fault (fault.json, and the launcher told); a later one is only printed."""
        slot = self.slots[robot] if 0 <= robot < len(self.slots) else None
        if self.fault is not None:
            host_message(f"boxbox host: after the race's first fault, {slot.name if slot else robot}: "
                         f"{fault.message}\n{fault.tb}")
            return
        last = slot.last_state if slot else None
        self.fault = Fault(kind=fault.kind, message=fault.message, where=where, robot_index=robot,
                           robot=slot.spec if slot else "", name=slot.name if slot else "", step=step,
                           sim_time_s=last.sim_time_s if last else 0.0, traceback=fault.tb)
        report_fault(self.run_dir, self.link, self.fault)

    _call = staticmethod(robot_call)

    # --- the loop ------------------------------------------------------------------------
    def serve(self, conn: socket.socket) -> None:
        """Answer the bridge until it closes the connection, or the launcher abandons the call the
        host is in (CallAbandoned)."""
        _ABANDON_ARMED[0] = True
        try:
            self._serve(conn)
        except CallAbandoned:
            pass
        finally:
            _ABANDON_ARMED[0] = False

    def _serve(self, conn: socket.socket) -> None:
        buf = self.buf
        header = wire.HEADER.unpack_from
        forked = FORKED
        drive = self._drive_step(conn)
        handlers = {wire.NEW_TRACK: self._new_track, wire.NEW_RACE: self._new_race, wire.PIT_CMD: self._pit_cmd,
                    wire.END_RACE: self._end_race, wire.SHUTDOWN: self._shutdown, wire.HELLO: self._hello}
        caller = CALLER
        while True:
            try:
                n = conn.recv_into(buf)
            except ConnectionResetError:
                n = 0
            if n == 0:
                return
            kind, robot, step, count = header(buf, 0)
            caller[0] = robot  # a robot's prints are marked with its car (torcs/robot_output.py)
            if kind == wire.DRIVE:
                drive(robot, step, count)
            elif (handler := handlers.get(kind)) is not None:
                handler(conn, robot, step, count, n)
            if forked[0]:
                os._exit(0)  # a robot's os.fork() child came back here from the robot call

    def _drive_step(self, conn: socket.socket):
        """The drive step, a closure over everything it uses (it runs 50 times a simulated second
        per car: locals are the cheapest lookups). The CONTROLS reply is packed into the receive
        buffer right after the state record (over the opponents, decoded by then), so telemetry
        records a step with one copy (state, reply header, controls) and the nearest other car."""
        buf, slots = self.buf, self.slots
        decode, pack = decode_state, pack_controls
        reply_at = OPPONENTS_AT
        reply_view = memoryview(buf)[reply_at: reply_at + HSIZE + wire.CONTROLS_REC.size]
        row_view = memoryview(buf)[HSIZE: reply_at + HSIZE + wire.CONTROLS_REC.size]
        robot_controls = self._robot_controls
        near, no_near = nearest_car, NO_NEAR
        race_rec = self.race_rec

        def drive(robot: int, step: int, count: int) -> None:
            t0 = perf_counter_ns()
            slot = slots[robot]
            state = decode(buf, count)
            if t0 > self._beat_due_ns:  # the launcher's stall watch (torcs/timing.py)
                self._beat_due_ns = t0 + HEARTBEAT_NS
                self.link.send("alive", sim_time_s=state.sim_time_s)
            opps = state.opponents
            if count:
                self._track_other_laps(opps)
            slot.last_state = state
            watch_step(slot, state)
            if state.laps != slot.laps_seen:
                self._lap(slot, state)
            try:
                c = robot_controls(slot, state, step)
            except RobotFault as fault:
                self._fail(conn, robot, step, "drive", fault, wire.CONTROLS)
                return
            if race_rec is not None:  # before the reply is packed over the opponents
                race_rec.step(robot, state.sim_time_s, count, c)
            pack(buf, reply_at, robot, step, c.steer, c.accel, c.brake, c.clutch, c.gear, c.pit_request)
            conn.send(reply_view)
            if c.pit_request or slot.pit_watch.active:
                slot.pit_watch.step(state, c.pit_request)
            rec = slot.rec
            if rec is not None:
                rec.rows += row_view
                rec.rows += near(state.x_m, state.y_m, state.yaw_rad, opps) if opps else no_near
                if rec.tel is not None:
                    rec.add_signals(state)
                if len(rec.rows) >= SPILL_BYTES and not rec.spill():
                    slot.rec = None  # the disk is full: this car's telemetry stops (rec.storage_error says so)
            record_step_time(slot, perf_counter_ns() - t0)

        return drive

    def _robot_controls(self, slot: HostedCar, state: State, step: int) -> Controls:
        """The robot's controls for this step, checked; a RobotFault for anything else."""
        if state.sim_time_s > self.sim_limit_s:
            raise RobotFault("sim-time-limit", self._sim_limit_text())
        if state.x_m != state.x_m:  # NaN: TORCS lost our car (cheap to ask every step)
            self._check_breakdown(slot, state)
        if step == 1:
            slot.start_fuel_l = state.fuel_l
        return robot_drive(slot.robot, state, step, slot.max_gear)

    @staticmethod
    def _check_breakdown(slot: HostedCar, state: State) -> None:
        """A RobotFault once TORCS has lost every car for BREAKDOWN_S: the race cannot finish."""
        if not every_car_lost(state):
            slot.lost_since_s = None
            return
        if slot.lost_since_s is None:
            slot.lost_since_s = state.sim_time_s
        elif state.sim_time_s - slot.lost_since_s >= BREAKDOWN_S:
            raise RobotFault("sim-breakdown", f"TORCS's simulation broke down at {slot.lost_since_s:.1f} s of "
                                              "simulated time: every car's position is NaN, so no car can finish; "
                                              "the race was stopped (race it again, or with other fuel)")

    def _sim_limit_text(self) -> str:
        length = self.slots[0].track.length_m if self.slots and self.slots[0].track else 0.0
        return (f"the race did not finish within {self.sim_limit_s:.0f} s of simulated time ({self.laps} laps "
                f"of {length:.0f} m at {self.min_speed_mps:g} m/s on average); it was stopped")

    # --- the other messages ----------------------------------------------------------------
    def _new_track(self, conn, robot: int, step: int, count: int, n: int) -> None:
        slot = self.slots[robot]
        blob = slot.chunks.add(self.buf, n, step, count)
        if blob is None:
            return  # more chunks follow
        try:
            slot.track, slot.car = decode_track(blob, self.spec["track"], self.spec["category"])
            slot.car.name = self.spec["car"]
            # TORCS tells the car's skill level at NEW_RACE; car_setup and on_track need it before
            slot.car.skill_level = int(self.spec.get("skill_level", slot.car.skill_level))
            self._track_known(slot.track)
            fuel = self._call("initial_fuel_l", slot.robot.initial_fuel_l, slot.track, slot.car)
            check_start_fuel(fuel, slot.car)
            fuel = self._offset_fuel(fuel, slot.car)
            answer = self._call("car_setup", slot.robot.car_setup, slot.track, slot.car)
            setup, problem = checked_setup(answer, slot.robot.options.car_setup, self.spec["car"])
            if problem:
                raise RobotFault("invalid-value", f"car_setup(): {problem}")
        except RobotFault as fault:
            self._fail(conn, robot, step, "initial_fuel_l", fault, wire.FUEL)
            return
        apply_setup(slot.car, setup)
        self._reply(conn, wire.FUEL, robot, step, wire.FUEL_REC,
                    messages.fuel_reply(fuel, setup, car_settings(self.spec["car"]).drivetrain))


    def _offset_fuel(self, fuel: float | None, car: Car) -> float | None:
        """The robot's start fuel (None: the car's own) plus the race's fuel_offset_l; as much less
        where more would not fit in the tank (a full tank is still dithered)."""
        offset = float(self.spec.get("fuel_offset_l", 0.0))
        if not offset:
            return fuel
        base = car.initial_fuel_l if fuel is None else fuel
        return max(0.0, base + offset if base + offset <= car.tank_l else base - offset)

    def _track_known(self, track: Track) -> None:
        if math.isinf(self.sim_limit_s):
            self.sim_limit_s = TimeModel(0, 0, self.min_speed_mps).sim_limit_s(self.laps, track.length_m) \
                if self.laps else math.inf
            self.link.send("track", length_m=float(track.length_m))

    def _new_race(self, conn, robot: int, step: int, count: int, n: int) -> None:
        slot = self.slots[robot]
        assert slot.car is not None, "NEW_RACE before NEW_TRACK"
        messages.complete_car(slot.car, bytes(self.buf[HSIZE:n]))
        slot.max_gear = slot.car.max_gear
        slot.pit_zone = pit_zone(slot.track)
        slot.pit_watch = PitWatch(slot.track, slot.car, slot.pit_zone)
        try:
            self._call("on_track", slot.robot.on_track, slot.track, slot.car)
        except RobotFault as fault:
            self._fail(conn, robot, step, "on_track", fault, wire.ACK)
            return
        slot.started = True
        if slot.recorder is not None:
            slot.recorder.start(slot.robot)
        # what exists now (imports, the robot's per-track tables) lives for the race: out of the
        # collector's sight, a full collection no longer walks it (tens of ms, at a lap's end when
        # the speed profile is rebuilt; on a loaded machine past the 200 ms step budget)
        gc.freeze()
        self._reply(conn, wire.ACK, robot, step)

    def _pit_cmd(self, conn, robot: int, step: int, count: int, n: int) -> None:
        slot = self.slots[robot]
        state = decode_state(self.buf, 0)  # PIT_CMD: a STATE, no opponents
        if slot.rec is not None:  # the stop itself: TORCS drives no car it holds in the pit
            slot.rec.add(bytes(self.buf[HSIZE: OPPONENTS_AT]), state)
        slot.pit_watch.step(state, True)
        try:
            order = self._call("pit_stop", slot.robot.pit_stop, state)
            problem = order.problem() if type(order) is PitOrder else \
                f"pit_stop() returned {type(order).__name__}, not PitOrder"
            if problem:
                raise RobotFault("invalid-value", f"pit_stop() returned an invalid order: {problem}")
        except RobotFault as fault:
            self._fail(conn, robot, step, "pit_stop", fault, wire.PIT_ORDER)
            return
        self._reply(conn, wire.PIT_ORDER, robot, step, wire.PIT_ORDER_REC, (float(order.fuel_l), float(order.repair)))

    def _end_race(self, conn, robot: int, step: int, count: int, n: int) -> None:
        """END_RACE (a TORCS that calls rbEndRace: 1.3 does not), answered."""
        fault = self._race_end(self.slots[robot], self._message_state(n))
        if fault is not None:
            self._fail(conn, robot, step, "on_race_end", fault, wire.ACK)
            return
        self._reply(conn, wire.ACK, robot, step)

    def _shutdown(self, conn, robot: int, step: int, count: int, n: int) -> None:
        """SHUTDOWN: TORCS cleans the race up (its finish, or its end after a stop); not answered."""
        fault = self._race_end(self.slots[robot], self._message_state(n))
        if fault is not None:
            self._record_fault(robot, step, "on_race_end", fault)

    def _message_state(self, n: int) -> State | None:
        """The STATE record a message of n bytes carries, if it carries one."""
        return messages.message_state(self.buf, n)

    def _race_end(self, slot: HostedCar, state: State | None) -> RobotFault | None:
        """The robot's on_race_end, once per race, for a robot that took part (its on_track
        returned), with the car's state at the end (else the last one it drove with); the fault
        if it failed."""
        state = state or slot.last_state
        if slot.ended or not slot.started or state is None:
            return None
        slot.ended = True
        self._lap(slot, state)  # the finish: TORCS often ends the race before the next drive step
        try:
            self._call("on_race_end", slot.robot.on_race_end, state)
        except RobotFault as fault:
            return fault
        return None

    def end_races(self) -> None:
        """on_race_end for every robot TORCS did not tell (a fault, Ctrl-C, TORCS gone)."""
        for i, slot in enumerate(self.slots):
            CALLER[0] = i
            fault = self._race_end(slot, None)
            if fault is not None:
                self._record_fault(i, slot.steps_timed, "on_race_end", fault)

    def _hello(self, conn, robot: int, step: int, count: int, n: int) -> None:
        self._reply(conn, wire.HELLO, robot, step, wire.HELLO_REC, (wire.PROTOCOL_VERSION, 0.0, 0.0))

    # --- what the host keeps -----------------------------------------------------------------
    def _lap(self, slot: HostedCar, state: State) -> None:
        laps = int(state.laps)
        if laps > slot.laps_seen and slot.laps_seen >= 1 and state.last_lap_time_s > 0:
            slot.lap_times.append(state.last_lap_time_s)
            self.link.send("progress", **self.cars_json(final=False))  # a host killed later loses no lap
        slot.laps_seen = max(slot.laps_seen, laps)

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

    def cars_json(self, final: bool = True) -> dict:
        """What the host knows of each Python car (sent at every lap, and whole at the end)."""
        return {"cars": [car_json(i, slot, final, self.pit_laps) for i, slot in enumerate(self.slots)],
                "other_lap_times": {str(k): v for k, v in self.other_laps.items()}}

    def finish(self) -> None:
        """At the end, whatever happened: the summary to the launcher first (it is the result), then
        RUN_DIR/telemetry.parquet from what was recorded (also after a fault), and what became of it.
        Each robot's on_race_end has run by then (end_races), and its race_report comes after it."""
        self.end_races()
        self.link.send("summary", **self.cars_json())
        telemetry_errors = self.write_telemetry() + write_recording(self.race_rec, self.run_dir, self.slots)
        if telemetry_errors:
            self.link.send("telemetry", errors=telemetry_errors)

    def write_telemetry(self) -> list[str]:
        """Write the telemetry file; never raises. Returns why telemetry was lost, if it was."""
        recorders = [s.recorder for s in self.slots if s.recorder is not None]
        lost = [f"{r.name}: {r.storage_error}" for r in recorders if r.storage_error]
        if not recorders:
            return lost
        try:
            track = next((s.track for s in self.slots if s.track is not None), None)
            write_telemetry(self.run_dir.telemetry, recorders, track, {i: s.car for i, s in enumerate(self.slots)})
        except OSError as exc:
            lost.append(f"{self.run_dir.telemetry.name} not written: {exc.strerror or exc}")
        except Exception:
            host_message(f"boxbox host: writing the telemetry failed\n{traceback.format_exc()}")
        finally:
            for rec in recorders:
                rec.remove_spool()
        return lost


def report_fault(run_dir: RunDir, link: HostLink, fault: Fault) -> None:
    """Tell the launcher (in memory) and keep RUN_DIR/fault.json (written whole, when the disk allows)."""
    link.send("fault", fault=fault.to_json())
    try:
        fault.write(run_dir.fault)
    except OSError:
        pass  # the launcher has it


def forked_child(link: HostLink) -> None:
    """In a child a robot forks: its copy of the launcher's pipe closed at once (the launcher waits
    for the host's end of it to close: a child holding it kept a finished race waiting 30 s), and
    marked, so that it ends as soon as it comes back into the host's code (FORKED)."""
    FORKED[0] = True
    if link.fd is not None:
        with contextlib.suppress(OSError):
            os.close(link.fd)
        link.fd = None
