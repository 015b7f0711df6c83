"""Spare races: TORCS started and served up to its first drive step while the episode runs, so a
reset takes one over instead of waiting for a fresh TORCS (~25 ms, most of it TORCS loading).

The pool keeps a spare for each of the next episodes (`plan`, with the episodes the env has drawn
ahead from its seeded RNG); `take` hands over the one made for the reset's episode (waiting for it
if it is still loading), or none when the reset asked for another race (the env then starts a
fresh TORCS: the same race a spare would have been, so the episode is the same bit for bit).
Spares are made in worker threads (one per spare, living until close: TORCS dies with the
thread that started it), which mostly wait on TORCS; races that are done are killed at once and
collected there too, off the reset's time.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor

from boxbox.gym.session import Race, RaceOrder, Started

MAX_SPARES = 8


class SparePool:
    """Races made ready ahead for the episodes to come, `depth` at most."""

    def __init__(self, depth: int, new_race: Callable[[RaceOrder, bool], Race]) -> None:
        self.depth = depth
        self.new_race = new_race
        self.workers = ThreadPoolExecutor(max_workers=depth + 1, thread_name_prefix="boxbox-spare")
        self.spares: list[tuple[Race, Future[Started]]] = []  # in the order they were started
        self.taken = 0  # spares handed over (tests and the bench read it)
        self.reaping: list[Future] = []  # races being collected

    def take(self, order: RaceOrder) -> tuple[Race, Started] | None:
        """The spare made for `order` (its key), ready; None when there is none (or it failed)."""
        for i, (race, future) in enumerate(self.spares):
            if race.order == order:
                del self.spares[i]
                try:
                    started = future.result()
                except Exception:  # noqa: BLE001  (a spare that failed is dropped; the reset starts afresh)
                    self.retire(race)
                    return None
                self.taken += 1
                return race, started
        return None

    def plan(self, upcoming: Sequence[RaceOrder]) -> None:
        """Keep the spares that match the next episodes, drop the others, start the missing ones."""
        wanted = list(upcoming[: self.depth])
        kept: list[tuple[Race, Future[Started]]] = []
        for race, future in self.spares:
            if race.order in wanted:
                wanted.remove(race.order)
                kept.append((race, future))
            else:
                self.retire(race, future)
        for order in wanted:
            race = self.new_race(order, True)
            kept.append((race, self.workers.submit(race.prepare)))
        self.spares = kept

    def retire(self, race: Race, future: Future | None = None) -> None:
        """Kill a race now (a spare still loading stops there) and collect it in a worker."""
        if future is not None and future.cancel():
            race.reap()  # never started: nothing runs, only its folder (if any) to remove
            return
        race.kill()
        self.reaping = [f for f in self.reaping if not f.done()]
        with contextlib.suppress(RuntimeError):  # the pool is closing: close() reaps it
            self.reaping.append(self.workers.submit(_reap_after, race, future))
            return
        race.reap()

    def settle(self) -> None:
        """Wait until every spare is ready (or failed) and every race done with is collected: the
        processes and files are then those of the race and its spares (tests, bench-gym)."""
        for future in [f for _race, f in self.spares] + self.reaping:
            with contextlib.suppress(Exception):
                future.result()
        self.reaping = []

    def close(self) -> None:
        """Kill every spare and wait for the workers (nothing of them is left)."""
        spares, self.spares = self.spares, []
        for race, _future in spares:
            race.kill()
        self.workers.shutdown(wait=True, cancel_futures=True)
        for race, _future in spares:
            race.reap()


def _reap_after(race: Race, future: Future | None) -> None:
    if future is not None:  # its prepare ends (TORCS is killed) before it is collected
        with contextlib.suppress(Exception):
            future.result()
    race.reap()

