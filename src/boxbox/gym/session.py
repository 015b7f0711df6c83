"""The env's TORCS races, one at a time (gym/race.py), with spares made ready ahead (gym/spare.py).

The session's folder (a folder per race: TORCS's local folder, the race file, the socket, TORCS's
stderr) is a temporary folder removed on close (or by the next session, when the env's process was
killed outright).  Where TORCS and the driving thread run: gym/cores.py.
"""

from __future__ import annotations

import os
import tempfile
import weakref
from collections.abc import Sequence
from pathlib import Path

from boxbox.gym.cores import CoreFollow, CorePin, IdleShares, spare_core, usable_cpus
from boxbox.gym.race import (
    FOLDER_PREFIX,
    STEP_TIMEOUT_S_DEFAULT,
    GymRace,
    PitHandler,
    RaceOrder,
    SessionResources,
    Started,
    clean_up,
)
from boxbox.model import PitOrder, State
from boxbox.torcs.launch import remove_stale_sockets, socket_root
from boxbox.torcs.processes import pick_cpu
from boxbox.torcs.setup import Overlay


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
        self.dir = Path(tempfile.mkdtemp(prefix=f"{FOLDER_PREFIX}{os.getpid()}-", dir=socket_root()))
        self.shared = SessionResources(self.dir)
        self._finalizer = weakref.finalize(self, clean_up, self.shared)
        # `with session.pin:` around a step or a reset: the cpu the user chose, or the caller's own
        self.pin: CorePin | CoreFollow = CorePin(self.cpu) if cpu is not None else CoreFollow(self)
        self.race: GymRace | None = None
        self._count = 0  # races made: their folders' names
        self.pool = SparePool(spares, self._new_race) if spares else None
        self.cores = usable_cpus()  # at the start: where the spares may load (the thread moves later)
        self.idle = IdleShares()

    def start(self, order: RaceOrder, upcoming: Sequence[RaceOrder] | None = ()) -> Started:
        """The race `order` asks for, at its first drive step (the last race killed first): a spare
        made ready for it when there is one, else a fresh TORCS.  Then spares for `upcoming` (None:
        the spares stay as they are)."""
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
        if self.pool is not None and upcoming is not None:
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

    def _new_race(self, order: RaceOrder, spare: bool = False) -> GymRace:
        self._count += 1
        return GymRace(order, self.overlay, self.shared, self.dir / f"r{self._count}",
                    self.pool_cpu() if spare else self.cpu, self.step_timeout_s)

    def pool_cpu(self) -> int:
        """Where a spare loads: the idlest other core if it was idle at least
        half the time since the last spare (TORCS's loading, ~15 ms of CPU an episode, then runs
        beside the episode: 5,700 -> 9,400 steps/s on an idle 2-core machine), else the race's own
        (on a busy machine a spare on another core was late: reset p95 30-80 ms against 2-3 ms)."""
        return spare_core(self.cpu, self.cores, self.idle.shares())
