"""One TORCS race driven from this process: the env is the robot host.

TORCS runs in console mode as `boxbox race` runs it (torcs/launch.py prepares the same local
folder and race file), with the bridge connecting to a socket this process listens on.  There
is no robot host process: `Session.drive` answers the pending DRIVE message with the controls
and reads the next one, so a step is one socket round trip.  Each race is a fresh TORCS process
(it starts in about 20 ms), so a reset leaves nothing of the last race behind.

TORCS is pinned to one core, and the thread that drives it runs there while it drives (a step, a
reset: `Session.pin`), as they strictly alternate: the round trip costs ~3 us instead of ~50 us
across cores (docs/architecture.md); between steps the thread has its own cores back, so threads it
starts (a learner's) are not pinned.  TORCS dies with the thread that started it
(PR_SET_PDEATHSIG; in practice with the env's process) and is killed by process group on every
reset and on close.  The run folder (TORCS's local folder, the race file, the
socket, TORCS's stderr) is a temporary folder removed on close (or by the next session, when the
env's process was killed outright).
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from boxbox.errors import RaceError
from boxbox.model import Car, Opponent, PitOrder, State, Track
from boxbox.torcs import wire
from boxbox.torcs.host import complete_car, decode_track
from boxbox.torcs.launch import RaceConfig, prepare_local_dir, remove_stale_sockets, torcs_command
from boxbox.torcs.processes import child_setup
from boxbox.torcs.rundir import RunDir
from boxbox.torcs.setup import Overlay

HSIZE = wire.HEADER.size
STATE_SIZE = wire.STATE_REC.size
OPP_SIZE = wire.OPPONENT_REC.size
CONNECT_TIMEOUT_S = 30.0  # TORCS connects within ~20 ms; this much means it is stuck
ANSWER_TIMEOUT_S = 60.0  # TORCS answers a step in microseconds; this much means it hangs
SETUP_BUDGET_MS = 120_000
FOLDER_PREFIX = "boxbox-gym-"  # TMP/boxbox-gym-<pid>-*: a session's folder

PitHandler = Callable[[State], PitOrder]


class TorcsGone(Exception):
    """TORCS ended or stopped answering in the middle of a race (the message says how)."""


@dataclass
class Started:
    track: Track
    car: Car
    state: State  # the first drive step's state


def _clean_up(folder: Path, running: list[subprocess.Popen]) -> None:
    """What a session leaves: TORCS and the folder (at close, or when the env is dropped without
    it, or at exit)."""
    for proc in running:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=5)
    shutil.rmtree(folder, ignore_errors=True)


class CorePin:
    """`with pin:` runs the calling thread on TORCS's core for the block (a step, a reset) and gives
    it its own cores back after.  TORCS and the thread that drives it strictly alternate: on one core
    a round trip costs ~3 us instead of ~50 us across cores.  Only for the block: a thread started
    outside it (a learner's, PyTorch's pool) inherits the caller's own cores, not TORCS's one."""

    def __init__(self, cpu: int) -> None:
        self.core = {cpu}
        self.saved: set[int] | None = None  # the thread's cores, while pinned

    def __enter__(self) -> None:
        own = os.sched_getaffinity(0)
        if own != self.core:
            try:
                os.sched_setaffinity(0, self.core)
                self.saved = own
            except OSError:  # the core was taken away (a cgroup changed): drive from where we are
                self.saved = None

    def __exit__(self, *exc: object) -> None:
        if self.saved is not None:
            saved, self.saved = self.saved, None
            with contextlib.suppress(OSError):
                os.sched_setaffinity(0, saved)


def usable_cpus() -> set[int]:
    """The cores the calling thread may run on."""
    return os.sched_getaffinity(0)


def pick_cpu() -> int:
    """A core for a new session, by process id: the sessions of one process share one, and the
    workers of a vector env spread over the cores."""
    cpus = sorted(os.sched_getaffinity(0))
    return cpus[os.getpid() % len(cpus)]


class Session:
    """TORCS with one Python car (robot index 0) and TORCS's robots as opponents."""

    torcs_env: dict[str, str] = {}  # more of TORCS's environment (gym/multisession.py: the bridge's batch mode)

    def __init__(self, cfg: RaceConfig, overlay: Overlay, cpu: int | None = None,
                 initial_fuel_l: float | None = None, on_pit: PitHandler | None = None) -> None:
        self.cfg, self.overlay = cfg, overlay
        self.initial_fuel_l = initial_fuel_l
        self.on_pit = on_pit or (lambda state: PitOrder())
        self.cpu = pick_cpu() if cpu is None else cpu
        remove_stale_sockets(FOLDER_PREFIX)  # of env processes killed outright
        self.dir = Path(tempfile.mkdtemp(prefix=f"{FOLDER_PREFIX}{os.getpid()}-"))  # short: a socket path has 108 bytes
        self.run = RunDir(self.dir)  # the names of TORCS's files in it
        self.proc: subprocess.Popen | None = None
        self._running: list[subprocess.Popen] = []  # what an env dropped without close() leaves to clean up
        self._finalizer = weakref.finalize(self, _clean_up, self.dir, self._running)
        self.pin = CorePin(self.cpu)  # `with session.pin:` around a step or a reset
        self.conn: socket.socket | None = None
        self.listener: socket.socket | None = None
        self.ended = False  # TORCS ended the race (END_RACE)
        self._track_blob = b""
        self._track: tuple[Track, Car] | None = None
        self._buf = bytearray(wire.MAX_MESSAGE_BYTES + 64)
        self._out = bytearray(HSIZE + wire.CONTROLS_REC.size)
        self._step = 0
        try:
            self.local = prepare_local_dir(self.run, overlay, cfg)
            self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET | socket.SOCK_CLOEXEC)
            self.listener.bind(str(self.dir / "bridge.sock"))
            self.listener.listen(1)
        except BaseException:
            self.close()
            raise

    # --- a race ------------------------------------------------------------------------------
    def start(self) -> Started:
        """A fresh TORCS (the last one killed first), served up to its first drive step."""
        self.stop()
        shutil.rmtree(self.local / "results", ignore_errors=True)  # a finished race's results file
        self.ended = False
        self.proc = self._spawn()
        self._running.append(self.proc)
        self.conn = self._accept()
        self.conn.settimeout(ANSWER_TIMEOUT_S)
        chunks: list[bytes] = []
        while True:
            n = self._recv()
            kind, robot, step, count = wire.HEADER.unpack_from(self._buf, 0)
            if kind == wire.DRIVE:
                self._step = step
                state = self._state(count)
                track, car = self._track  # type: ignore[misc]
                return Started(track, car, state)
            if kind == wire.HELLO:
                self._reply(wire.HELLO, robot, step, wire.HELLO_REC, (wire.PROTOCOL_VERSION, 0.0, 0.0))
            elif kind == wire.NEW_TRACK:
                chunks.append(bytes(self._buf[HSIZE:n]))
                if step + 1 == count:
                    self._new_track(b"".join(chunks))
                    fuel = -1.0 if self.initial_fuel_l is None else float(self.initial_fuel_l)
                    self._reply(wire.FUEL, robot, step, wire.FUEL_REC, (fuel, math.nan, math.nan))
            elif kind == wire.NEW_RACE:
                assert self._track is not None
                complete_car(self._track[1], bytes(self._buf[HSIZE:n]))
                self._reply(wire.ACK, robot, step)
            else:
                raise TorcsGone(f"TORCS sent message kind {kind} before the race started")

    def drive(self, steer: float, accel: float, brake: float, clutch: float, gear: int, pit: bool) -> State | None:
        """Answer the pending drive step; the next step's state, or None when the race has ended."""
        if self.conn is None or self.ended:
            return None
        wire.HEADER.pack_into(self._out, 0, wire.CONTROLS, 0, self._step, 0)
        wire.CONTROLS_REC.pack_into(self._out, HSIZE, steer, accel, brake, clutch, gear, 1.0 if pit else 0.0)
        self._send(self._out)
        while True:
            try:
                self._recv()
            except TorcsGone:
                if self.proc is not None and self.proc.poll() == 0:  # TORCS ended the race and exited
                    self.ended = True
                    return None
                raise
            kind, robot, step, count = wire.HEADER.unpack_from(self._buf, 0)
            if kind == wire.DRIVE:
                self._step = step
                return self._state(count)
            if kind == wire.PIT_CMD:
                order = self.on_pit(self._state(0))
                self._reply(wire.PIT_ORDER, robot, step, wire.PIT_ORDER_REC, (order.fuel_l, order.repair))
            elif kind == wire.END_RACE:
                self.ended = True
                self._reply(wire.ACK, robot, step)
                return None

    def stop(self) -> None:
        """Kill TORCS (its process group) and drop the connection; nothing of the race is left."""
        if self.conn is not None:
            self.conn.close()
            self.conn = None
        if self.proc is not None:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
            self.proc = None
            self._running.clear()

    def close(self) -> None:
        self.stop()
        if self.listener is not None:
            self.listener.close()
            self.listener = None
        self._finalizer()  # TORCS, the folder

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc is not None else None

    # --- plumbing ----------------------------------------------------------------------------
    def _spawn(self) -> subprocess.Popen:
        o = self.overlay
        env = dict(os.environ, LD_LIBRARY_PATH=str(o.torcs.shared_lib_dir), BOXBOX_SOCKET=str(self.dir / "bridge.sock"),
                   BOXBOX_STEP_BUDGET_MS="0",  # no limit: a learner may think for as long as it likes
                   BOXBOX_SETUP_BUDGET_MS=str(SETUP_BUDGET_MS), **self.torcs_env)
        cmd = torcs_command(o, self.run)
        with open(self.run.torcs_err, "wb") as err:
            try:
                return subprocess.Popen(cmd, cwd=o.data_dir, env=env, stdin=subprocess.DEVNULL,
                                        stdout=subprocess.DEVNULL, stderr=err, preexec_fn=child_setup(self.cpu),
                                        start_new_session=True)
            except OSError as exc:
                raise RaceError(f"TORCS could not be started ({cmd[0]}): {exc.strerror or exc}; "
                                "run `boxbox setup`") from None

    def _accept(self) -> socket.socket:
        assert self.listener is not None and self.proc is not None
        self.listener.settimeout(0.05)
        deadline = time.monotonic() + CONNECT_TIMEOUT_S
        while True:
            try:
                conn, _ = self.listener.accept()
                return conn
            except TimeoutError:
                if self.proc.poll() is not None:
                    raise TorcsGone(f"TORCS {self.exit_text()} before it connected: {self.torcs_words()}") from None
                if time.monotonic() > deadline:
                    raise TorcsGone(f"TORCS did not connect within {CONNECT_TIMEOUT_S:.0f} s") from None

    def _recv(self) -> int:
        assert self.conn is not None
        try:
            n = self.conn.recv_into(self._buf)
        except TimeoutError:
            raise TorcsGone(f"TORCS did not answer within {ANSWER_TIMEOUT_S:.0f} s") from None
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
        out = bytearray(HSIZE + (rec.size if rec is not None else 0))
        wire.HEADER.pack_into(out, 0, kind, robot, step, 0)
        if rec is not None:
            rec.pack_into(out, HSIZE, *values)
        self._send(out)

    def _state(self, count: int) -> State:
        buf = self._buf
        vals = wire.STATE_REC.unpack_from(buf, HSIZE)
        if count:
            base = HSIZE + STATE_SIZE
            unpack = wire.OPPONENT_REC.unpack_from
            opps = tuple([Opponent._make(unpack(buf, base + i * OPP_SIZE)) for i in range(count)])
        else:
            opps = ()
        return State._make(vals + (opps,))

    def _new_track(self, blob: bytes) -> None:
        """The track and the car's file constants, decoded once while the race stays the same."""
        if blob != self._track_blob or self._track is None:
            self._track = decode_track(blob, self.cfg.track, self.cfg.category)
            self._track[1].name = self.cfg.car
            self._track_blob = blob

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
