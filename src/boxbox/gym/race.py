"""One TORCS race driven from this process: the env is the robot host.

TORCS runs in console mode as `boxbox race` runs it (torcs/launch.py prepares the same local
folder and race file), with the bridge connecting to a socket this process listens on.  There
is no robot host process: `GymRace.drive` answers the pending DRIVE message with the controls and
reads the next one, so a step is one socket round trip; the messages are read and written by
torcs/messages.py, as the robot host reads and writes them.  Each episode is a fresh TORCS process
(`GymRace`), so a reset leaves nothing of the last race behind.  A race is made ready up to its first
drive step at 0 s (`GymRace.prepare`: spawn, HELLO, NEW_TRACK, NEW_RACE, the start countdown), either
when the reset asks for it or ahead of it, as a spare (gym/spare.py), which the reset then takes
over in microseconds.  TORCS dies with the thread that started it (PR_SET_PDEATHSIG, set by
util-linux's setpriv before it execs TORCS; in practice with the env's process) and is killed by
process group when its race is done and on close.
"""

from __future__ import annotations

import contextlib
import copy
import os
import shutil
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from pathlib import Path

from boxbox.errors import RaceError
from boxbox.gym.hosted import HostedRobots
from boxbox.gym.start import GRID_START, Start
from boxbox.model import Car, PitOrder, State, Track
from boxbox.torcs import messages, wire
from boxbox.torcs.messages import HSIZE, TrackChunks, decode_state, pack_controls
from boxbox.torcs.processes import child_setup
from boxbox.torcs.raceprep import RaceConfig, prepare_local_dir, torcs_command
from boxbox.torcs.rundir import RunDir
from boxbox.torcs.setup import Overlay

CONNECT_TIMEOUT_S = 30.0  # TORCS connects within ~20 ms; this much means it is stuck
SETUP_ANSWER_TIMEOUT_S = 60.0  # TORCS loads a race in ~15 ms of CPU; a minute means it hangs, even loaded
# TORCS answers a drive step in microseconds (a millisecond with a field of robots): the env's
# `step_timeout_s` defaults to this much before a silent TORCS is a fault (a vector env's every
# sub-env waits on the slowest), well above a scheduler's delays on a loaded machine
STEP_TIMEOUT_S_DEFAULT = 5.0
MAX_STEP_TIMEOUT_S = 3600.0
SETUP_BUDGET_MS = 120_000
FOLDER_PREFIX = "boxbox-gym-"  # TMP/boxbox-gym-<pid>-*: a session's folder
# util-linux's setpriv sets PR_SET_PDEATHSIG before it execs TORCS: a spawn without a preexec_fn
# is a vfork (~0.3 ms), where Python's fork for a preexec_fn takes ~8 ms with numpy loaded, holding
# the GIL (a spare's spawn would stall the learner's steps that long)
SETPRIV = shutil.which("setpriv")

PitHandler = Callable[[State], PitOrder]


class TorcsGone(Exception):
    """TORCS ended or stopped answering in the middle of a race (the message says how)."""


@dataclass
class Started:
    track: Track
    car: Car
    state: State  # the first drive step's state, past the start countdown and the start's launch
    spare: bool = False  # the race was made ready ahead, as a spare


@dataclass(frozen=True)
class RaceOrder:
    """A race to make ready: `key` names it (equal keys are the same race, so a spare is taken
    for it), `cfg`, the start fuel and the start's launch say what it is."""
    key: Hashable
    cfg: RaceConfig = field(compare=False)
    initial_fuel_l: float | None = field(default=None, compare=False)
    start: Start = field(default=GRID_START, compare=False)


class SessionResources:
    """What a session's races share with its clean-up (which may run in any thread, from the
    garbage collector): the processes running, the decoded tracks, whether the session is closed."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.lock = threading.Lock()
        self.running: list[subprocess.Popen] = []
        self.closed = False
        self.tracks: dict[tuple[str, str], tuple[bytes, Track, Car]] = {}  # NEW_TRACK's bytes, decoded


def clean_up(shared: SessionResources) -> None:
    """What a session leaves: TORCS processes and the folder (at close, or when the env is dropped
    without it, or at exit)."""
    with shared.lock:
        shared.closed = True  # no race spawns or makes a folder after this
        running = list(shared.running)
        shared.running.clear()
    for proc in running:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=5)
    shutil.rmtree(shared.folder, ignore_errors=True)


class GymRace:
    """One TORCS process with one Python car (robot index 0) and TORCS's robots as opponents, in a
    folder of its own under the session's."""

    torcs_env: dict[str, str] = {}  # more of TORCS's environment (gym/multisession.py: the bridge's batch mode)

    def __init__(self, order: RaceOrder, overlay: Overlay, shared: SessionResources, folder: Path, cpu: int,
                 step_timeout_s: float = STEP_TIMEOUT_S_DEFAULT) -> None:
        self.order, self.cfg, self.overlay, self.shared, self.cpu = order, order.cfg, overlay, shared, cpu
        self.step_timeout_s = step_timeout_s  # a drive step's answer, once the race is set up
        self.run = RunDir(folder)  # the names of TORCS's files in it
        self.on_pit: PitHandler | None = None  # the env's, once the race is handed over
        self.proc: subprocess.Popen | None = None
        self.listener: socket.socket | None = None
        self.conn: socket.socket | None = None
        self.started: Started | None = None  # the first drive step at 0 s, once set up
        self.killed = False
        self.ended = False  # TORCS ended the race (END_RACE)
        self._buf = bytearray(wire.MAX_MESSAGE_BYTES + 64)
        self._out = bytearray(messages.REPLY_BYTES)  # the replies, packed
        self._controls = memoryview(self._out)[:HSIZE + wire.CONTROLS_REC.size]  # a DRIVE's reply
        self._step = 0
        self._launched = 0  # drive steps of the start's launch driven
        self._track: tuple[Track, Car] | None = None
        self._chunks: dict[int, TrackChunks] = {}  # NEW_TRACK's, by robot
        self.hosted: HostedRobots | None = None  # the Python opponents' robot host (gym/hosted.py)

    # --- making it ready ---------------------------------------------------------------------
    def prepare(self) -> Started:
        """TORCS started and served up to its first drive step at 0 s (the car cannot move before)."""
        while not self.advance(block=True):
            pass
        assert self.started is not None
        return self.started

    def advance(self, block: bool = False) -> bool:
        """Take the race's set-up as far as it goes without waiting (with `block`: to its end):
        spawn TORCS, accept it, answer HELLO, NEW_TRACK, NEW_RACE and the start countdown's drive
        steps.  True once it is ready (`started`)."""
        if self.started is not None:
            return True
        if self.proc is None:
            self.listener = self._listen()
            if self.cfg.robot_names[0] == "gym" and len(self.cfg.robots) > 1:  # (the parallel env's cars: car_i)
                self.hosted = HostedRobots(self.cfg, self.run, self.cpu, SETPRIV)
                with self.shared.lock:  # killed by the session's clean-up too
                    self.shared.running.append(self.hosted.proc)
            self._spawn()
        if self.conn is None:
            self.conn = self._accept(block)
            if self.conn is None:
                return False
        self.conn.settimeout(SETUP_ANSWER_TIMEOUT_S if block else 0.0)
        while True:
            try:
                n = self._recv()
            except BlockingIOError:
                return False
            if self._setup_message(n):
                self.conn.settimeout(self.step_timeout_s)
                return True

    def _setup_message(self, n: int) -> bool:
        """Answer one set-up message; True at the first drive step at 0 s."""
        kind, robot, step, count = wire.HEADER.unpack_from(self._buf, 0)
        if robot > 0 and self.hosted is not None:
            self._relay(n)
        elif kind == wire.DRIVE:
            self._step = step
            state = decode_state(self._buf, count)
            start = self.order.start
            if state.sim_time_s >= 0.0 and self._launched < start.launch_steps:  # part of the set-up: a spare's too
                self._launched += 1
                self._send_controls(start.launch_steer, start.launch_throttle, 0.0, 0.0, 1, False)
            elif state.sim_time_s >= 0.0:
                assert self._track is not None
                self.started = Started(self._track[0], self._track[1], state)
                return True
            else:
                self._send_controls(0.0, 0.0, 0.0, 0.0, 0, False)  # the countdown: the car cannot move yet
        elif kind in (wire.END_RACE, wire.SHUTDOWN):
            raise TorcsGone("the race ended before it started")
        elif not self._answer_setup(kind, robot, step, count, n):
            raise TorcsGone(f"TORCS sent message kind {kind} before the race started")
        return False

    def _answer_setup(self, kind: int, robot: int, step: int, count: int, n: int) -> bool:
        """HELLO, NEW_TRACK (its chunks joined, then the start fuel) and NEW_RACE answered, for one
        car or several; False for another kind of message."""
        if kind == wire.HELLO:
            self._reply(wire.HELLO, robot, step, wire.HELLO_REC, (wire.PROTOCOL_VERSION, 0.0, 0.0))
        elif kind == wire.NEW_TRACK:
            blob = self._chunks.setdefault(robot, TrackChunks()).add(self._buf, n, step, count)
            if blob is not None:
                self._car_known(robot, blob)
                self._reply(wire.FUEL, robot, step, wire.FUEL_REC, messages.fuel_reply(self.order.initial_fuel_l))
        elif kind == wire.NEW_RACE:
            messages.complete_car(self._car(robot), bytes(self._buf[HSIZE:n]))
            self._reply(wire.ACK, robot, step)
        else:
            return False
        return True

    def _car_known(self, robot: int, blob: bytes) -> None:
        """NEW_TRACK's whole bytes: the track, and a copy of the car's file constants (NEW_RACE
        completes the copy for this race: its pit, its grid slot)."""
        track, car = self._decoded(blob)
        self._track = (track, copy.copy(car))

    def _car(self, robot: int) -> Car:
        assert self._track is not None, "NEW_RACE before NEW_TRACK"
        return self._track[1]

    def _listen(self) -> socket.socket:
        with self.shared.lock:  # not in a folder that close() is removing
            if self.shared.closed or self.killed:
                raise TorcsGone("the session was closed")
            prepare_local_dir(self.run, self.overlay, self.cfg)
        listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET | socket.SOCK_CLOEXEC)
        try:
            listener.bind(str(self.socket_path))
            listener.listen(1)
        except BaseException:
            listener.close()
            raise
        return listener

    def _decoded(self, blob: bytes) -> tuple[Track, Car]:
        """NEW_TRACK's track and car, decoded once per session and shared: copy the car to change it."""
        key = (self.cfg.track, self.cfg.car)
        decoded = self.shared.tracks.get(key)
        if decoded is None or decoded[0] != blob:
            track, car = messages.decode_track(blob, self.cfg.track, self.cfg.category)
            car.name = self.cfg.car
            decoded = self.shared.tracks[key] = (blob, track, car)
        return decoded[1], decoded[2]

    # --- the race ----------------------------------------------------------------------------
    def drive(self, steer: float, accel: float, brake: float, clutch: float, gear: int, pit: bool) -> State | None:
        """Answer the pending drive step; the next step's state, or None when the race has ended."""
        if self.conn is None or self.ended:
            return None
        self._send_controls(steer, accel, brake, clutch, gear, pit)
        while True:
            n = self._recv_in_race()
            if not n:
                return None
            kind, robot, step, count = wire.HEADER.unpack_from(self._buf, 0)
            if robot > 0 and self.hosted is not None:
                self._relay(n)
            elif kind == wire.DRIVE:
                self._step = step
                return decode_state(self._buf, count)
            if kind == wire.PIT_CMD:
                order = self.on_pit(decode_state(self._buf, 0)) if self.on_pit is not None else PitOrder()
                self._reply(wire.PIT_ORDER, robot, step, wire.PIT_ORDER_REC, (order.fuel_l, order.repair))
            elif kind == wire.END_RACE:
                self.ended = True
                self._reply(wire.ACK, robot, step)
                return None

    def _relay(self, n: int) -> None:
        """A Python opponent's message, answered by its robot host (gym/hosted.py)."""
        assert self.hosted is not None
        try:
            answer = self.hosted.relay(self._buf, n)
        except RaceError:
            self.kill()  # the bridge waits for an answer that will not come: the race is over
            self.ended = True
            raise
        if answer is not None:
            self._send(answer)

    def _send_controls(self, steer: float, accel: float, brake: float, clutch: float, gear: int, pit: bool) -> None:
        pack_controls(self._out, 0, 0, self._step, steer, accel, brake, clutch, gear, pit)
        self._send(self._controls)

    def move_to(self, cpu: int) -> None:
        """Run TORCS on `cpu` from now on (a spare handed over: the reset's thread drives it there)."""
        if cpu != self.cpu and self.proc is not None:
            with contextlib.suppress(OSError):
                os.sched_setaffinity(self.proc.pid, {cpu})
            self.cpu = cpu

    def kill(self) -> None:
        """Kill TORCS (its process group) now; `reap` collects it."""
        with self.shared.lock:
            self.killed = True
            proc = self.proc
        if proc is not None:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(proc.pid, signal.SIGKILL)
        if self.hosted is not None:
            self.hosted.kill()

    def reap(self, block: bool = True) -> bool:
        """After `kill`: collect TORCS, close the sockets, remove the race's folder.  Without
        `block`, only when TORCS is gone already (False: not yet)."""
        self.kill()
        if self.proc is not None:
            if not block and self.proc.poll() is None:
                return False
            self.proc.wait()
            with self.shared.lock, contextlib.suppress(ValueError):
                self.shared.running.remove(self.proc)
        if self.hosted is not None:
            with self.shared.lock, contextlib.suppress(ValueError):
                self.shared.running.remove(self.hosted.proc)
            self.hosted.close()
        for sock in (self.conn, self.listener):
            if sock is not None:
                sock.close()
        self.conn = self.listener = None
        self.on_pit = None
        shutil.rmtree(self.run.path, ignore_errors=True)
        return True

    @property
    def socket_path(self) -> Path:
        return self.run.path / "bridge.sock"

    # --- plumbing ----------------------------------------------------------------------------
    def _spawn(self) -> None:
        o = self.overlay
        env = dict(os.environ, LD_LIBRARY_PATH=str(o.torcs.shared_lib_dir), BOXBOX_SOCKET=str(self.socket_path),
                   BOXBOX_STEP_BUDGET_MS="0",  # no limit: a learner may think for as long as it likes
                   BOXBOX_SETUP_BUDGET_MS=str(SETUP_BUDGET_MS), **self.torcs_env)
        cmd = torcs_command(o, self.run)
        with self.shared.lock, open(self.run.torcs_err, "wb") as err:  # (a spawn without a preexec_fn: a vfork)
            if self.shared.closed or self.killed:
                raise TorcsGone("the session was closed")
            try:
                if SETPRIV is not None:
                    self.proc = subprocess.Popen([SETPRIV, "--pdeathsig", "KILL", "--", *cmd], cwd=o.data_dir,
                                                 env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                                 stderr=err, start_new_session=True)
                    with contextlib.suppress(OSError):
                        os.sched_setaffinity(self.proc.pid, {self.cpu})
                else:
                    self.proc = subprocess.Popen(cmd, cwd=o.data_dir, env=env, stdin=subprocess.DEVNULL,
                                                 stdout=subprocess.DEVNULL, stderr=err,
                                                 preexec_fn=child_setup(self.cpu), start_new_session=True)
            except OSError as exc:
                raise RaceError(f"TORCS could not be started ({cmd[0]}): {exc.strerror or exc}; "
                                "run `boxbox setup`") from None
            self.shared.running.append(self.proc)

    def _accept(self, block: bool) -> socket.socket | None:
        """TORCS's connection (None when it has not connected yet and `block` is off)."""
        listener = self.listener
        assert listener is not None and self.proc is not None
        listener.settimeout(0.05 if block else 0.0)
        deadline = time.monotonic() + CONNECT_TIMEOUT_S
        while True:
            try:
                conn, _ = listener.accept()
                listener.close()
                self.listener = None
                return conn
            except (TimeoutError, BlockingIOError):
                if self.proc.poll() is not None:
                    raise TorcsGone(f"TORCS {self.exit_text()} before it connected: {self.torcs_words()}") from None
                if not block:
                    return None
                if time.monotonic() > deadline:
                    raise TorcsGone(f"TORCS did not connect within {CONNECT_TIMEOUT_S:.0f} s") from None

    def _recv_in_race(self) -> int:
        """The next message into the buffer, its size; 0 (and the race ended) when TORCS has ended
        the race and exited cleanly, TorcsGone when it went otherwise."""
        try:
            return self._recv()
        except TorcsGone:
            if self.proc is not None and self.proc.poll() == 0:
                self.ended = True
                return 0
            raise

    def _recv(self) -> int:
        assert self.conn is not None
        try:
            n = self.conn.recv_into(self._buf)
        except BlockingIOError:
            raise
        except TimeoutError:
            raise TorcsGone(f"TORCS did not answer within {self.conn.gettimeout():g} s (hung; the env's "
                            "step_timeout_s)") from None
        except OSError:
            n = 0
        if n == 0:
            raise TorcsGone(self._gone_text())
        return n

    def _send(self, data: bytes | bytearray | memoryview) -> None:
        assert self.conn is not None
        try:
            self.conn.send(data)
        except OSError:
            raise TorcsGone(self._gone_text()) from None

    def _reply(self, kind: int, robot: int, step: int, rec=None, values=()) -> None:
        self._send(messages.pack_reply(self._out, kind, robot, step, rec, values))

    def _gone_text(self) -> str:
        if self.proc is not None:
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(timeout=1.0)
        words = self.torcs_words()
        return f"TORCS {self.exit_text()} in the middle of the race" + (f": {words}" if words else "")

    def exit_text(self) -> str:
        code = self.proc.poll() if self.proc is not None else None
        if code is None:
            return "closed its connection"
        if code < 0:
            with contextlib.suppress(ValueError):
                return f"was killed by {signal.Signals(-code).name}"
        return f"exited with status {code}"

    def torcs_words(self) -> str:
        """TORCS's last lines on stderr."""
        try:
            lines = self.run.torcs_err.read_text(errors="replace").split("\n")
        except OSError:
            return ""
        return " | ".join(ln.strip() for ln in lines if ln.strip())[-300:]
