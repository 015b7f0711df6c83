"""The race's processes: how they start, and that every one of them ends with the race.

TORCS and the robot host are pinned to one core (they strictly alternate, so this costs nothing
and makes the socket round trip ~15x cheaper), die with the launcher (PR_SET_PDEATHSIG), run in
sessions of their own and are killed by process group at the end.  Processes a robot starts may
leave both (a new session, a double fork).  The forked robot host is their child subreaper, so they
stay its descendants however they fork, and it ends them as it ends (`end_descendants`); the
launcher ends them too when it has to kill the host (`kill_group(tree=True)`).  Behind that, the
launcher is the child subreaper of the whole race, and `ChildSweep` kills every process of the race
still alive at the end (psutil: the launcher's new descendants that carry the race's
BOXBOX_RUN_DIR; a daemon forked from the host without an exec has the launcher's environment, not
the race's, so this alone let it live on).
"""

from __future__ import annotations

import contextlib
import ctypes
import fcntl
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import psutil

from boxbox.cache import cache_dir
from boxbox.torcs.signals import STOP_SIGNALS

PR_SET_PDEATHSIG = 1
PR_SET_CHILD_SUBREAPER = 36
PR_GET_CHILD_SUBREAPER = 37
_libc = ctypes.CDLL(None, use_errno=True)


def child_setup(cpu: int | None, address_space_bytes: int | None = None) -> Callable[[], None]:
    """What a race's child does first: die with the launcher, run on the race's core, and (the robot
    host) keep within its address space (RLIMIT_AS: past it an allocation fails, a MemoryError in
    Python, instead of the machine running out of memory and the OOM killer choosing a victim)."""
    def setup() -> None:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)  # blocked in the launcher (torcs/signals.py)
        _libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
        if cpu is not None:
            os.sched_setaffinity(0, {cpu})
        if address_space_bytes is not None:
            import resource

            hard = resource.getrlimit(resource.RLIMIT_AS)[1]
            soft = address_space_bytes if hard == resource.RLIM_INFINITY else min(address_space_bytes, hard)
            resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
    return setup


def host_address_space(memory_limit_gib: float | None) -> int | None:
    """The robot host's address-space limit: what the launcher maps now (the forked host starts with
    it; an exec'd one maps about as much once it has imported boxbox) plus the robots' allowance."""
    if memory_limit_gib is None:
        return None
    return psutil.Process().memory_info().vms + int(memory_limit_gib * 2**30)


def pick_cpu() -> int:
    """A core for a race by the launcher's process id: the workers of one pool (of a vector env)
    spread over the cores, and the sessions of one process share one."""
    cpus = sorted(os.sched_getaffinity(0))  # never empty: the process runs somewhere
    return cpus[os.getpid() % len(cpus)]


@contextlib.contextmanager
def claimed_core(lock_dir: Path | None = None) -> Iterator[int | None]:
    """A core that no other race claiming one on this machine holds, held until the block ends (a
    lock file per core in lock_dir, by default the cache's `cores` folder); None when every core is
    held (the race then takes pick_cpu's).

    For races started by processes that know nothing of each other (a Ray node's workers): by
    process id alone two of them met on one core while the other stood idle half the time."""
    cores = sorted(os.sched_getaffinity(0))
    lock_dir = lock_dir or cache_dir() / "cores"
    lock_dir.mkdir(parents=True, exist_ok=True)
    first = os.getpid() % len(cores)
    for core in cores[first:] + cores[:first]:
        fd = os.open(lock_dir / f"cpu{core}.lock", os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            continue
        try:
            yield core
        finally:
            os.close(fd)  # the lock goes with its descriptor
        return
    yield None


class ForkedHost:
    """The robot host as a forked child of the launcher (a Popen look-alike).

    A fresh `python -m boxbox.torcs.host_process` spends about 0.4 s importing numpy and the robot before
    TORCS can start its race; a fork starts with what the launcher has imported already (it has
    loaded the robot class to check it). BOXBOX_HOST_EXEC=1 goes back to a fresh interpreter.
    """

    def __init__(self, spec_path: Path, log_fd: int, cpu: int | None, address_space_bytes: int | None = None) -> None:
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:  # the child: never returns into the launcher's code
            _host_child(spec_path, log_fd, child_setup(cpu, address_space_bytes))
        self.pid = pid
        self.returncode: int | None = None
        self.args = ["fork", "boxbox.torcs.host_process", str(spec_path)]

    def poll(self) -> int | None:
        if self.returncode is None:
            try:
                pid, status = os.waitpid(self.pid, os.WNOHANG)
            except ChildProcessError:  # reaped elsewhere: it is gone, how is unknown
                self.returncode = -signal.SIGKILL
                return self.returncode
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while (code := self.poll()) is None:
            if deadline is not None and time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(self.args, timeout or 0.0)
            time.sleep(0.002)
        return code

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:
            os.kill(self.pid, sig)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


def _host_child(spec_path: Path, log_fd: int, setup: Callable[[], None]) -> None:
    """The forked host: its own session, default signals, output to the log (log_fd: the write end
    of the launcher's LogPump); then the host's main."""
    code = 1
    try:
        os.setsid()
        _libc.prctl(PR_SET_CHILD_SUBREAPER, 1)  # what the robot starts stays below the host (end_descendants)
        signal.set_wakeup_fd(-1)  # the launcher's stop signals are not the host's
        for sig in STOP_SIGNALS:
            signal.signal(sig, signal.SIG_DFL)
        setup()
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.dup2(log_fd, 1)
        os.dup2(log_fd, 2)
        os.close(log_fd)
        # what the robot prints goes to the log, whatever the launcher's sys.stdout was (a notebook's
        # stream, a test's capture); line by line, so the terminal shows it as it comes
        sys.stdout = open(1, "w", buffering=1, closefd=False)  # noqa: SIM115
        sys.stderr = open(2, "w", buffering=1, closefd=False)  # noqa: SIM115
        import atexit

        from boxbox.torcs import host_process

        atexit._clear()  # the launcher's exit handlers are not the host's to run
        try:
            code = host_process.main([str(spec_path)])
        finally:
            try:
                atexit._run_exitfuncs()  # a robot's own exit handlers run, as in a fresh interpreter
            finally:
                end_descendants()
    except BaseException:  # noqa: BLE001  (anything here must end the child, reported)
        import traceback

        os.write(2, traceback.format_exc().encode(errors="replace"))
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def end_descendants(wait_s: float = 2.0) -> None:
    """Kill every descendant of this process (the host's: all the robot started) and reap them."""
    procs = psutil.Process().children(recursive=True)
    for proc in procs:
        with contextlib.suppress(psutil.NoSuchProcess):
            proc.kill()
    psutil.wait_procs(procs, timeout=wait_s)


def kill_group(proc: subprocess.Popen | ForkedHost | None, tree: bool = False) -> None:
    """Kill a child and its process group (it leads a session of its own), and reap it; with tree,
    also every descendant it had (a forked host is their child subreaper: they are all below it
    until it dies, then they would be orphans without a mark of the race)."""
    if proc is None:
        return
    below: list[psutil.Process] = []
    if tree and proc.poll() is None:
        with contextlib.suppress(psutil.Error):
            below = psutil.Process(proc.pid).children(recursive=True)
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    for child in below:
        with contextlib.suppress(psutil.Error):
            child.kill()
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(timeout=5)


class ChildSweep:
    """For a race: orphans of the race's processes come to this process (a child subreaper), and at
    the end every new descendant marked with the race's BOXBOX_RUN_DIR is killed and reaped."""

    def __init__(self, run_dir: Path) -> None:
        self.marker = str(run_dir)
        self.me = psutil.Process()
        self.before: set[int] = set()
        self.was_subreaper = 0

    def __enter__(self) -> ChildSweep:
        self.before = {p.pid for p in self.me.children(recursive=True)}
        flag = ctypes.c_int(0)
        if _libc.prctl(PR_GET_CHILD_SUBREAPER, ctypes.byref(flag)) == 0:
            self.was_subreaper = flag.value
        _libc.prctl(PR_SET_CHILD_SUBREAPER, 1)
        return self

    def __exit__(self, *exc) -> None:
        try:
            self.sweep()
        finally:
            _libc.prctl(PR_SET_CHILD_SUBREAPER, self.was_subreaper)

    def leftovers(self) -> list[psutil.Process]:
        found = []
        for proc in self.me.children(recursive=True):
            if proc.pid in self.before:
                continue
            try:
                if proc.environ().get("BOXBOX_RUN_DIR") == self.marker:
                    found.append(proc)
            except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
                continue
        return found

    def sweep(self) -> int:
        """Kill what is left of the race; returns how many there were."""
        procs = self.leftovers()
        for proc in procs:
            with contextlib.suppress(psutil.NoSuchProcess):
                proc.kill()
        psutil.wait_procs(procs, timeout=5)
        self._reap_orphans()
        return len(procs)

    def _reap_orphans(self) -> None:
        """Orphans that ended by themselves came to us as children: reap them (no zombies left)."""
        for proc in self.me.children():
            if proc.pid in self.before:
                continue
            with contextlib.suppress(psutil.NoSuchProcess, ChildProcessError):
                if proc.status() == psutil.STATUS_ZOMBIE:
                    os.waitpid(proc.pid, os.WNOHANG)
