"""Spare races: TORCS started and served up to its first drive step while the episode runs, so a
reset takes one over instead of waiting for a fresh TORCS (~25 ms, most of it TORCS loading).

The pool keeps a spare for each of the next episodes (`plan`, with the episodes the env has drawn
ahead from its seeded RNG); `take` hands over the one made for the reset's episode (finishing its
set-up if it is not done), or none when the reset asked for another race (the env then starts a
fresh TORCS: the same race a spare would have been, so the episode is the same bit for bit).

No thread: the env's own thread takes each spare's set-up a little further at every step
(`advance`: one socket call that does not wait; TORCS loads on its own meanwhile, and answers the
next set-up message when it is ready), so the set-up takes no core time from the learner beyond
those calls and no lock is held: a thread would hold Python's GIL while the learner's thread waits
on TORCS's answer, costing up to 5 ms (the GIL's switch interval) a step.  Races done with are
killed at once and collected at a later step, when TORCS has gone.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from boxbox.gym.race import GymRace, RaceOrder, Started, TorcsGone

MAX_SPARES = 8


class SparePool:
    """Races made ready ahead for the episodes to come, `depth` at most."""

    def __init__(self, depth: int, new_race: Callable[[RaceOrder, bool], GymRace]) -> None:
        self.depth = depth
        self.new_race = new_race
        self.spares: list[GymRace] = []  # in the order of the episodes they are for
        self.dying: list[GymRace] = []  # killed, to collect
        self.taken = 0  # spares handed over (tests and the bench read it)
        self.pending = False  # a spare to set up, or a race to collect: `advance` has work

    def take(self, order: RaceOrder) -> tuple[GymRace, Started] | None:
        """The spare made for `order` (its key), ready; None when there is none (or it failed)."""
        for i, race in enumerate(self.spares):
            if race.order == order:
                del self.spares[i]
                try:
                    started = race.prepare()
                except TorcsGone:  # a spare that failed is dropped; the reset starts afresh
                    self.retire(race)
                    return None
                self.taken += 1
                return race, started
        return None

    def plan(self, upcoming: Sequence[RaceOrder]) -> None:
        """Keep the spares that match the next episodes, drop the others, add the missing ones
        (set up from the next `advance` on)."""
        wanted = list(upcoming[: self.depth])
        kept: list[GymRace] = []
        for race in self.spares:
            if race.order in wanted:
                wanted.remove(race.order)
                kept.append(race)
            else:
                self.retire(race)
        kept += [self.new_race(order, True) for order in wanted]
        self.spares = kept
        self.pending = True

    def advance(self) -> None:
        """One non-waiting turn: collect a race that has gone, and take the first spare that is
        not ready one message further."""
        if self.dying and self.dying[0].reap(block=False):
            del self.dying[0]
        for race in self.spares:
            if race.started is None:
                try:
                    race.advance()
                except TorcsGone:  # prepare() at the reset says what went wrong, or a fresh start
                    pass
                return
        self.pending = bool(self.dying)

    def retire(self, race: GymRace) -> None:
        """Kill a race now; it is collected at a later `advance` (or at close)."""
        race.kill()
        self.dying.append(race)
        self.pending = True

    def settle(self) -> None:
        """Finish every spare's set-up and collect every race done with: the processes and files
        are then those of the race and its spares (tests, bench-gym)."""
        for race in self.spares:
            try:
                race.prepare()
            except TorcsGone:
                pass
        for race in self.dying:
            race.reap()
        self.dying = []
        self.pending = False

    def close(self) -> None:
        """Kill every spare and collect them all (nothing of them is left)."""
        races, self.spares = self.spares + self.dying, []
        self.dying = []
        for race in races:
            race.kill()
        for race in races:
            race.reap()
        self.pending = False
