"""CPU placement of the gym's races: TORCS on the core of the thread that drives it.

TORCS is pinned to one core, the core the thread that drives it is on (`CoreFollow`, at each step
and reset, moves TORCS when the thread has moved, and holds the thread where it is for the step):
they strictly alternate, so a round trip on one core costs ~11 us instead of ~50 us across cores.
The thread is never moved (a migration costs ~30 us) and has its own cores back between steps, so
the threads it starts (a learner's) keep its cores.  With `cpu=` both TORCS and the thread run on
that core while it drives (`CorePin`).  A spare race loads on the idlest other core when it was
idle enough (`spare_core`).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import psutil

if TYPE_CHECKING:
    from boxbox.gym.session import Session


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


