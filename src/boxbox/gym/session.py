"""TORCS races driven from this process: the env is the robot host.

TORCS runs in console mode as `boxbox race` runs it (torcs/launch.py prepares the same local
folder and race file), with the bridge connecting to a socket this process listens on.  There
is no robot host process: `Race.drive` answers the pending DRIVE message with the controls and
reads the next one, so a step is one socket round trip.  Each episode is a fresh TORCS process
(`Race`), so a reset leaves nothing of the last race behind.  A race is made ready up to its first
drive step at 0 s (`Race.prepare`: spawn, HELLO, NEW_TRACK, NEW_RACE, the start countdown), either
when the reset asks for it or ahead of it, as a spare (gym/spare.py), which the reset then takes
over in microseconds.

TORCS is pinned to one core, the core the thread that drives it is on (`Session.pin`, at each step
and reset, moves TORCS when the thread has moved, and holds the thread where it is for the step):
they strictly alternate, so a round trip on one core costs ~11 us instead of ~50 us across cores.
The thread is never moved (a migration costs ~30 us) and has its own cores back between steps, so
the threads it starts (a learner's) keep its cores.  With `cpu=` both TORCS and the thread run on
that core while it drives.  TORCS dies with the thread that started it
(PR_SET_PDEATHSIG, set by util-linux's setpriv before it execs TORCS; in practice with the
env's process) and is killed by process group when its race is done and on
close.  The session's folder (a folder per race: TORCS's local folder, the race file, the socket,
TORCS's stderr) is a temporary folder removed on close (or by the next session, when the env's
process was killed outright).
"""

from __future__ import annotations

import contextlib
import copy
import ctypes
import math
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import threading
import time
import weakref
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import psutil

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
    state: State  # the first drive step's state, at 0 s (past the start countdown)
    spare: bool = False  # the race was made ready ahead, as a spare


@dataclass(frozen=True)
class RaceOrder:
    """A race to make ready: `key` names it (equal keys are the same race, so a spare is taken
    for it), `cfg` and the start fuel say what it is."""
    key: Hashable
    cfg: RaceConfig = field(compare=False)
    initial_fuel_l: float | None = field(default=None, compare=False)


class Shared:
    """What a session's races share with its clean-up (which may run in any thread, from the
    garbage collector): the processes running, the decoded tracks, whether the session is closed."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.lock = threading.Lock()
        self.running: list[subprocess.Popen] = []
        self.closed = False
        self.tracks: dict[tuple[str, str], tuple[bytes, Track, Car]] = {}  # NEW_TRACK's bytes, decoded


def _clean_up(shared: Shared) -> None:
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


class CorePin:
    """`with pin:` runs the calling thread on TORCS's core for the block (a step, a reset) and gives
    it its own cores back after.  TORCS and the thread that drives it strictly alternate: on one core
    a round trip costs ~11 us instead of ~50 us across cores.  Only for the block: a thread started
    outside it (a learner's, PyTorch's pool) inherits the caller's own cores, not TORCS's one."""

    def __init__(self, cpu: int) -> None:
        self.core = {cpu}
        self.saved: set[int] | None = None  # the thread's cores, while pinned

    def __enter__(self) -> None:
        self._hold(self.core)

    def _hold(self, core: set[int]) -> None:
        own = os.sched_getaffinity(0)
        if own != core:
            try:
                os.sched_setaffinity(0, core)
                self.saved = own
            except OSError:  # the core was taken away (a cgroup changed): drive from where we are
                self.saved = None

    def __exit__(self, *exc: object) -> None:
        if self.saved is not None:
            saved, self.saved = self.saved, None
            with contextlib.suppress(OSError):
                os.sched_setaffinity(0, saved)


class CoreFollow(CorePin):
    """`with follow:` puts the session's TORCS on the core the calling thread is on now, if it is not
    there already.  Without spare races it also holds the thread on that core for the block (a step,
    a reset), so that the scheduler does not wake it on the idle core while it waits for TORCS:
    pinning a thread where it runs moves nothing (~5 us for the pin and its release, against ~30 us
    for each migration of a thread moved to another core); with spares loading beside, the thread
    left free was faster (random policy, idle 2-core machine: 11,700 steps/s against 8,300 held).
    After the block the thread has its own cores back."""

    def __init__(self, session: Session) -> None:
        super().__init__(session.cpu)
        self.session = session

    def __enter__(self) -> None:
        core = current_cpu()
        if core is None:
            return
        if core != self.session.cpu:
            self.session.cpu = core  # the races started from now on start there
            race = self.session.race
            if race is not None:
                race.move_to(core)
        if self.session.pool is None:
            self._hold({core})


def _libc_getcpu() -> Callable[[], int] | None:
    try:
        return ctypes.CDLL(None, use_errno=True).sched_getcpu
    except (OSError, AttributeError):
        return None


_GETCPU = _libc_getcpu()


def current_cpu() -> int | None:
    """The core the calling thread runs on now (glibc's sched_getcpu, ~0.2 us), None if unknown."""
    if _GETCPU is None:
        return None
    core = _GETCPU()
    return core if core >= 0 else None


class IdleShares:
    """Each core's idle share of the time since the last call (psutil's per-core times)."""

    def __init__(self) -> None:
        self.before = self._idle()

    @staticmethod
    def _idle() -> tuple[float, list[float]]:
        return time.monotonic(), [t.idle for t in psutil.cpu_times(percpu=True)]

    def shares(self) -> dict[int, float]:
        (t0, idle0), (t1, idle1) = self.before, self._idle()
        self.before = (t1, idle1)
        span_s = max(t1 - t0, 1e-3)
        return {core: (b - a) / span_s for core, (a, b) in enumerate(zip(idle0, idle1, strict=False))}


def spare_core(race_core: int, cores: set[int], idle_share: dict[int, float]) -> int:
    """The idlest of `cores` other than `race_core` if it was idle at least half the time, else
    `race_core` (`idle_share`: each core's idle share, 0 to 1, of the last episode or so)."""
    others = sorted(cores - {race_core}, key=lambda core: (-idle_share.get(core, 0.0), core))
    return others[0] if others and idle_share.get(others[0], 0.0) >= 0.5 else race_core


def usable_cpus() -> set[int]:
    """The cores the calling thread may run on."""
    return os.sched_getaffinity(0)


def pick_cpu() -> int:
    """A core for a new session, by process id: the sessions of one process share one, and the
    workers of a vector env spread over the cores."""
    cpus = sorted(os.sched_getaffinity(0))
    return cpus[os.getpid() % len(cpus)]


class Race:
    """One TORCS process with one Python car (robot index 0) and TORCS's robots as opponents, in a
    folder of its own under the session's."""

    torcs_env: dict[str, str] = {}  # more of TORCS's environment (gym/multisession.py: the bridge's batch mode)

    def __init__(self, order: RaceOrder, overlay: Overlay, shared: Shared, folder: Path, cpu: int,
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
        self._out = bytearray(HSIZE + wire.CONTROLS_REC.size)
        self._step = 0
        self._track: tuple[Track, Car] | None = None
        self._chunks: list[bytes] = []  # NEW_TRACK's

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
        if kind == wire.DRIVE:
            self._step = step
            state = self._state(count)
            if state.sim_time_s >= 0.0:
                assert self._track is not None
                self.started = Started(self._track[0], self._track[1], state)
                return True
            self._send_controls(0.0, 0.0, 0.0, 0.0, 0, False)  # the countdown: the car cannot move yet
        elif kind == wire.HELLO:
            self._reply(wire.HELLO, robot, step, wire.HELLO_REC, (wire.PROTOCOL_VERSION, 0.0, 0.0))
        elif kind == wire.NEW_TRACK:
            self._chunks.append(bytes(self._buf[HSIZE:n]))
            if step + 1 == count:
                self._new_track(b"".join(self._chunks))
                fuel = self.order.initial_fuel_l
                self._reply(wire.FUEL, robot, step, wire.FUEL_REC,
                            (-1.0 if fuel is None else float(fuel), math.nan, math.nan))
        elif kind == wire.NEW_RACE:
            assert self._track is not None
            complete_car(self._track[1], bytes(self._buf[HSIZE:n]))
            self._reply(wire.ACK, robot, step)
        elif kind in (wire.END_RACE, wire.SHUTDOWN):
            raise TorcsGone("the race ended before it started")
        else:
            raise TorcsGone(f"TORCS sent message kind {kind} before the race started")
        return False

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

    def _new_track(self, blob: bytes) -> None:
        """The track (decoded once per session, track and car) and a copy of the car's file
        constants (NEW_RACE completes the copy for this race: its pit, its grid slot)."""
        track, car = self._decoded(blob)
        self._track = (track, copy.copy(car))

    def _decoded(self, blob: bytes) -> tuple[Track, Car]:
        """NEW_TRACK's track and car, decoded once per session and shared: copy the car to change it."""
        key = (self.cfg.track, self.cfg.car)
        decoded = self.shared.tracks.get(key)
        if decoded is None or decoded[0] != blob:
            track, car = decode_track(blob, self.cfg.track, self.cfg.category)
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
            if not self._recv_in_race():
                return None
            kind, robot, step, count = wire.HEADER.unpack_from(self._buf, 0)
            if kind == wire.DRIVE:
                self._step = step
                return self._state(count)
            if kind == wire.PIT_CMD:
                order = self.on_pit(self._state(0)) if self.on_pit is not None else PitOrder()
                self._reply(wire.PIT_ORDER, robot, step, wire.PIT_ORDER_REC, (order.fuel_l, order.repair))
            elif kind == wire.END_RACE:
                self.ended = True
                self._reply(wire.ACK, robot, step)
                return None

    def _send_controls(self, steer: float, accel: float, brake: float, clutch: float, gear: int, pit: bool) -> None:
        wire.HEADER.pack_into(self._out, 0, wire.CONTROLS, 0, self._step, 0)
        wire.CONTROLS_REC.pack_into(self._out, HSIZE, steer, accel, brake, clutch, gear, 1.0 if pit else 0.0)
        self._send(self._out)

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

    def _recv_in_race(self) -> bool:
        """The next message into the buffer; False (and the race ended) when TORCS has ended the
        race and exited cleanly, TorcsGone when it went otherwise."""
        try:
            self._recv()
        except TorcsGone:
            if self.proc is not None and self.proc.poll() == 0:
                self.ended = True
                return False
            raise
        return True

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


class Session:
    """The env's races, one at a time, with spares made ready ahead (`spares` of them, 0: none)."""

    def __init__(self, overlay: Overlay, cpu: int | None = None, on_pit: PitHandler | None = None,
                 spares: int = 0, step_timeout_s: float = STEP_TIMEOUT_S_DEFAULT) -> None:
        from boxbox.gym.spare import SparePool  # (spare.py builds on this module)

        self.overlay = overlay
        self.step_timeout_s = step_timeout_s
        self.on_pit = on_pit or (lambda state: PitOrder())
        self.cpu = pick_cpu() if cpu is None else cpu
        remove_stale_sockets(FOLDER_PREFIX)  # of env processes killed outright
        self.dir = Path(tempfile.mkdtemp(prefix=f"{FOLDER_PREFIX}{os.getpid()}-"))  # short: a socket path has 108 bytes
        self.shared = Shared(self.dir)
        self._finalizer = weakref.finalize(self, _clean_up, self.shared)
        # `with session.pin:` around a step or a reset: the cpu the user chose, or the caller's own
        self.pin: CorePin | CoreFollow = CorePin(self.cpu) if cpu is not None else CoreFollow(self)
        self.race: Race | None = None
        self._count = 0  # races made: their folders' names
        self.pool = SparePool(spares, self._new_race) if spares else None
        self.cores = usable_cpus()  # at the start: where the spares may load (the thread moves later)
        self.idle = IdleShares()

    def start(self, order: RaceOrder, upcoming: Sequence[RaceOrder] = ()) -> Started:
        """The race `order` asks for, at its first drive step (the last race killed first): a spare
        made ready for it when there is one, else a fresh TORCS.  Then spares for `upcoming`."""
        self.stop()
        taken = self.pool.take(order) if self.pool is not None else None
        if taken is not None:
            race, started = taken
            started.spare = True
            race.move_to(self.cpu)  # loaded on the spares' core, it races on the session's
        else:
            race = self._new_race(order)
            self.race = race  # killed by stop() or close() if it fails half way
            started = race.prepare()
        race.on_pit = self.on_pit
        self.race = race
        if self.pool is not None:
            self.pool.plan(upcoming)
        return started

    def drive(self, steer: float, accel: float, brake: float, clutch: float, gear: int, pit: bool) -> State | None:
        """Answer the pending drive step of the race; the next state, or None when it has ended."""
        if self.race is None:
            return None
        return self.race.drive(steer, accel, brake, clutch, gear, pit)

    def advance_spares(self) -> None:
        """Take the spares' set-up a step further without waiting (the env calls it every step)."""
        if self.pool is not None and self.pool.pending:
            self.pool.advance()

    def stop(self) -> None:
        """Kill the race's TORCS (its process group); nothing of the race is left (a spare pool
        collects it later, off the reset's time)."""
        race, self.race = self.race, None
        if race is None:
            return
        if self.pool is not None:
            self.pool.retire(race)
        else:
            race.reap()

    def close(self) -> None:
        self.stop()
        if self.pool is not None:
            self.pool.close()
        self._finalizer()  # TORCS, the folder

    def settle(self) -> None:
        """Wait for the spares to be ready and the races done with to be collected (tests, bench-gym)."""
        if self.pool is not None:
            self.pool.settle()

    @property
    def pid(self) -> int | None:
        race = self.race
        return race.proc.pid if race is not None and race.proc is not None else None

    @property
    def ended(self) -> bool:
        return self.race is None or self.race.ended

    def _new_race(self, order: RaceOrder, spare: bool = False) -> Race:
        self._count += 1
        return Race(order, self.overlay, self.shared, self.dir / f"r{self._count}",
                    self.pool_cpu() if spare else self.cpu, self.step_timeout_s)

    def pool_cpu(self) -> int:
        """Where a spare loads: the idlest other core if it was idle at least
        half the time since the last spare (TORCS's loading, ~15 ms of CPU an episode, then runs
        beside the episode: 5,700 -> 9,400 steps/s on an idle 2-core machine), else the race's own
        (on a busy machine a spare on another core was late: reset p95 30-80 ms against 2-3 ms)."""
        return spare_core(self.cpu, self.cores, self.idle.shares())
