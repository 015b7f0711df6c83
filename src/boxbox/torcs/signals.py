"""Signals while a race runs: Ctrl-C, SIGTERM and SIGHUP ask the race to stop, once.

Without this, each signal raised KeyboardInterrupt wherever the launcher happened to be: a second
Ctrl-C while the first was being handled lost the results, and SIGHUP (the terminal closed) killed
the launcher outright, results and clean-up with it.  `StopSignals` notes them instead and wakes the
launcher's select loop (a wakeup pipe), which stops TORCS, collects and writes the results; further
signals change nothing.  The previous handlers come back when the race is over.

Who sent a signal is known too: the stop signals are blocked in the launcher's threads and taken by
one thread of its own with sigwaitinfo, which gives the sender's pid (a Python handler does not).  A
robot that signals its parent (the launcher) is then told apart from a Ctrl-C: the race is its fault,
not an interruption (`from_race`).  A signal that reaches a thread started before the race (where it
is not blocked) is noted by the handler, its sender unknown: an interruption.

A command that shows the race's results holds its own `StopSignals` around the race and the
showing (`boxbox race`: the table, the report): the race's own then shares it, so a Ctrl-C just
after the finish neither cuts the table and report short (a KeyboardInterrupt) nor goes unsaid
(noted once the race's result was made: exit 0); the command says it, with exit 130, at its end.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_HELD: list[StopSignals] = []  # the outermost context that holds the signals now (at most one)


class StopSignals:
    """A context for one race. `wakeup_fd` becomes readable when a stop signal arrived (None when
    not in the main thread, where Python cannot catch signals: then the caller's handlers stay)."""

    def __init__(self) -> None:
        self.received: list[int] = []
        self.wakeup_fd: int | None = None
        self._write_fd: int | None = None
        self._old: dict[int, object] = {}
        self._old_wakeup = -1
        self._shared = False
        # (signal, sender pid, the sender's session: -1 when gone) of each taken by the waiter
        self.senders: list[tuple[int, int, int]] = []
        self._waiter: threading.Thread | None = None
        self._closing = False

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is not threading.main_thread():
            return self
        if _HELD:  # a command holds them around this race: its notes are this race's
            self._shared = True
            self.received, self.wakeup_fd = _HELD[0].received, _HELD[0].wakeup_fd
            self.senders = _HELD[0].senders
            return self
        _HELD.append(self)
        self.wakeup_fd, self._write_fd = os.pipe()
        os.set_blocking(self.wakeup_fd, False)
        os.set_blocking(self._write_fd, False)
        for sig in STOP_SIGNALS:
            self._old[sig] = signal.signal(sig, self._note)
        self._old_wakeup = signal.set_wakeup_fd(self._write_fd, warn_on_full_buffer=False)
        # children unblock them first (processes.unblock_stop_signals): the mask is inherited
        signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
        self._waiter = threading.Thread(target=self._wait, name="boxbox-stop-signals", daemon=True)
        self._waiter.start()
        return self

    def _note(self, signum: int, frame) -> None:
        self.received.append(signum)

    def _wait(self) -> None:
        """Take each stop signal with its sender, note it and wake the launcher, until __exit__."""
        while True:
            info = signal.sigwaitinfo(STOP_SIGNALS)
            if self._closing and info.si_pid == os.getpid():
                return
            try:
                session = os.getsid(info.si_pid)
            except OSError:  # the sender is gone
                session = -1
            self.senders.append((info.si_signo, info.si_pid, session))
            self.received.append(info.si_signo)
            if self._write_fd is not None:
                with contextlib.suppress(OSError):
                    os.write(self._write_fd, bytes([info.si_signo]))

    def from_race(self, pids: set[int]) -> bool:
        """Whether every stop signal came from a process of the race: one of `pids` or a process in a
        session one of them leads (the robot host and TORCS each lead their own)."""
        return bool(self.senders) and len(self.senders) == len(self.received) and \
            all(pid in pids or session in pids for _, pid, session in self.senders)

    @property
    def stopped(self) -> bool:
        return bool(self.received)

    def names(self) -> str:
        return ", ".join(dict.fromkeys(signal.Signals(s).name for s in self.received))

    def drain(self) -> None:
        if self.wakeup_fd is not None:
            try:
                while os.read(self.wakeup_fd, 64):
                    pass
            except BlockingIOError:
                pass

    def __exit__(self, *exc) -> None:
        if self._shared or self.wakeup_fd is None:
            return
        _HELD.remove(self)
        if self._waiter is not None:
            self._closing = True
            signal.pthread_kill(self._waiter.ident or 0, signal.SIGHUP)
            self._waiter.join(1.0)
        # a signal still pending goes to the handler now (noted, an interruption)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
        signal.set_wakeup_fd(self._old_wakeup)
        if not self.received:
            for sig, handler in self._old.items():
                signal.signal(sig, handler)  # type: ignore[arg-type]
        # else this handler stays: a late Ctrl-C (pressed again as the stopped race winds down) is
        # noted, not raised, so the results being written and the exit status 130 hold; the
        # command line exits next, and boxbox.race puts Python's handlers back (restore_handlers)
        for fd in (self.wakeup_fd, self._write_fd):
            if fd is not None:
                os.close(fd)
        self.wakeup_fd = self._write_fd = None


def restore_handlers() -> None:
    """Python's own handlers for the stop signals again, where a stopped race left its own."""
    if threading.current_thread() is not threading.main_thread():
        return
    for sig in STOP_SIGNALS:
        handler = signal.getsignal(sig)
        if getattr(handler, "__self__", None).__class__ is StopSignals:
            signal.signal(sig, signal.default_int_handler if sig == signal.SIGINT else signal.SIG_DFL)
