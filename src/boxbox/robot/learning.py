"""Learning turn by turn: grip factors from the margins the car left to the track edge.

The tutorial robot adds the smallest margin it saw in a turn to that turn's radius for the next
lap.  Here each turn (a stretch where the speed profile is limited by curvature) has a grip
factor scaling its cornering speed: a lap with room to spare raises it, leaving the track or
picking up damage in the turn lowers it and caps it there.  The cap is not for good: every clean
lap in the turn lifts it by CEILING_RECOVERY, so a turn slowed by one bad lap (another car, a
slide out of the turn before) earns its speed back.  A raise is a trial: the section from the
turn's entry to the next turn's entry (or the line) is timed at the old factor and at the new one, and a raise
that made the section slower is taken back and the turn settles there (more corner speed is not
always less time: a wider exit, a later turn-in to the next turn).  Factors are kept per track and
car in a JSON file, so the next race starts from what the last one learned.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

MIN_FACTOR, MAX_FACTOR = 0.8, 1.5
OFF_MARGIN_M = -0.3  # a wheel this far over the edge counts as leaving the track
# this far over the edge, or CRASH_DAMAGE points in one lap, is a crash (2-3 m wide with no damage
# is running wide: a crash's cut for it left a turn slower than the learner alone ever makes it):
CRASH_MARGIN_M = -3.0
CRASH_DAMAGE = 50.0
CRASH_FACTOR = 0.9  # lost at once (a few per cent a lap crashed dirt-3 in the same turn lap after lap)
CEILING_RECOVERY = 1.01  # a clean lap in a turn lifts its ceiling by 1 %, up to MAX_FACTOR


@dataclass
class Turn:
    start_m: float
    end_m: float
    factor: float = 1.0
    ceiling: float = MAX_FACTOR  # lowered when the car went off here
    min_margin_m: float = 1e9  # this lap's smallest distance from the car's side to the edge
    max_error_m: float = -1.0  # this lap's largest distance from the racing line (-1: not measured)
    damaged: bool = False
    damage_points: float = 0.0  # damage taken in (or just after) this turn this lap
    settled: bool = False  # a trial here made the section slower: no more trials (until it goes off)
    eased: bool = False  # the last change was the understeer cut (a pace call, judged like a raise)
    entered_s: float = -1.0  # sim time the car entered the turn this lap (-1: not timed)
    driven_factor: float = 0.0  # the factor in force when the car entered it
    base_factor: float = 0.0  # the factor of the last section timed before a raise (0: none yet)
    base_s: float = 0.0  # that section's time


@dataclass
class TurnLearner:
    turns: list[Turn]
    length_m: float
    gain: float = 0.5
    target_margin_m: float = 0.5  # keep at least this much room to the edge in every turn
    # on a racing line: within this of the line (outwards, near the apex) counts as holding it
    steady_error_m: float = 1.0
    sample_index: list[int] = field(default_factory=list)  # turn index per profile sample, -1 outside
    last_turn: int = -1  # the turn driven most recently
    timing_turn: int = -1  # the turn whose section (entry to the next turn's entry) is being timed

    @classmethod
    def from_limits(cls, limits_mps: list[float], step_m: float, length_m: float, max_speed_mps: float,
                    gain: float = 0.5, target_margin_m: float = 0.5, steady_error_m: float = 1.0) -> TurnLearner:
        """Turns are the runs of samples whose limit is below the top speed."""
        n = len(limits_mps)
        limited = [v < 0.95 * max_speed_mps for v in limits_mps]
        turns: list[Turn] = []
        index = [-1] * n
        i = 0
        while i < n:
            if limited[i]:
                j = i
                while j < n and limited[j]:
                    j += 1
                turns.append(Turn(start_m=i * step_m, end_m=j * step_m))
                for k in range(i, j):
                    index[k] = len(turns) - 1
                i = j
            else:
                i += 1
        # a turn across the start line is one turn
        if len(turns) > 1 and limited[0] and limited[-1]:
            first = turns.pop(0)
            last = turns[-1]
            last.end_m = first.end_m + length_m
            index = [len(turns) - 1 if t == 0 else (t - 1 if t > 0 else -1) for t in index]
        return cls(turns=turns, length_m=length_m, gain=gain, target_margin_m=target_margin_m,
                   steady_error_m=steady_error_m, sample_index=index)

    def factors_per_sample(self) -> list[float]:
        return [self.turns[t].factor if t >= 0 else 1.0 for t in self.sample_index]

    def observe(self, sample: int, margin_m: float, damage_taken: float, line_error_m: float | None = None) -> None:
        """One drive step inside the lap: the car's margin to the edge at a profile sample, the damage
        points it took in this step (0: none) and, for a robot on a racing line, how far it is
        from that line."""
        t = self.sample_index[sample]
        if t >= 0:
            self.last_turn = t
            turn = self.turns[t]
            if margin_m < turn.min_margin_m:
                turn.min_margin_m = margin_m
            if line_error_m is not None and line_error_m > turn.max_error_m:
                turn.max_error_m = line_error_m
            if damage_taken:
                turn.damaged = True
                turn.damage_points += float(damage_taken)
        elif self.last_turn >= 0 and (damage_taken or margin_m < 0.0):
            # leaving the track or hitting something on the way out of a turn is that turn's doing
            turn = self.turns[self.last_turn]
            turn.damaged |= bool(damage_taken)
            turn.damage_points += float(damage_taken)
            if margin_m < turn.min_margin_m:
                turn.min_margin_m = margin_m

    def enter(self, t: int, time_s: float, spoiled: bool = False) -> None:
        """The car entered turn t at sim time time_s: that ends the section of the turn before
        (judged by _judge) and starts this one's.  spoiled (traffic, a pit stop): neither counts."""
        self.close(time_s, spoiled)
        turn = self.turns[t]
        turn.entered_s = -1.0 if spoiled else time_s
        turn.driven_factor = turn.factor
        self.timing_turn = t

    def close(self, time_s: float, spoiled: bool = False) -> None:
        """End the section being timed at time_s: at the next turn's entry, or at the line (so a
        section never runs into the next lap, and the last one of a race is judged too)."""
        if 0 <= self.timing_turn < len(self.turns):
            before = self.turns[self.timing_turn]
            if before.entered_s >= 0.0 and not spoiled:
                self._judge(before, time_s - before.entered_s)
            before.entered_s = -1.0
        self.timing_turn = -1

    @staticmethod
    def _judge(turn: Turn, section_s: float) -> None:
        """Keep a raise that made the section faster; take back one that made it slower."""
        f = turn.driven_factor
        trial = f > turn.base_factor or (f < turn.base_factor and turn.eased)
        if turn.base_factor == 0.0 or not trial or section_s <= turn.base_s:
            # the first timing, the same factor, a cut for safety, or a trial that paid
            turn.base_factor, turn.base_s = f, section_s
        else:
            if turn.factor == f:  # not changed since: back to what was faster, and stay there
                turn.factor = turn.base_factor
            turn.settled = True

    def end_lap(self) -> int:
        """Update every turn from the lap just driven; returns how many factors changed."""
        changed = 0
        for turn in self.turns:
            before = turn.factor
            if turn.min_margin_m == 1e9:
                continue  # not driven (pit lane, start)
            eased = False
            if turn.min_margin_m < CRASH_MARGIN_M or turn.damage_points >= CRASH_DAMAGE:
                turn.factor = max(MIN_FACTOR, turn.factor * CRASH_FACTOR)
                turn.ceiling = turn.factor
                turn.settled = False
            elif turn.min_margin_m < OFF_MARGIN_M or turn.damaged:
                turn.ceiling = max(MIN_FACTOR, turn.factor * 0.98)
                cut = 0.96 if turn.min_margin_m < -1.0 or turn.damaged else 0.98
                turn.factor = max(MIN_FACTOR, turn.factor * cut)
                turn.settled = False
            elif turn.max_error_m > 3.0 * self.steady_error_m and not turn.settled:
                # pushed off its racing line (understeer): the turn is taken faster than the line
                # allows, even when the track is wide enough to leave room at the edge
                turn.factor = max(MIN_FACTOR, turn.factor * 0.98)
                eased = True
            elif turn.settled:
                pass  # a raise here cost time: hold the factor that was faster
            elif 0.0 <= turn.max_error_m < self.steady_error_m:
                # a racing line uses the whole width, so the margin says little there; a car that
                # stayed on its line through the turn had grip to spare
                turn.ceiling = min(MAX_FACTOR, turn.ceiling * CEILING_RECOVERY)
                turn.factor = min(turn.ceiling, turn.factor * (1.0 + self.gain * 0.02))
            elif turn.max_error_m < 0.0 and turn.min_margin_m > self.target_margin_m:
                # no line to hold (a middle-line robot): room to spare beyond the margin we keep: take
                # part of it (equilibrium near the target, not at the edge, where one gust of
                # understeer costs a wall)
                spare = min(turn.min_margin_m - self.target_margin_m, 2.0)
                turn.ceiling = min(MAX_FACTOR, turn.ceiling * CEILING_RECOVERY)
                turn.factor = min(turn.ceiling, turn.factor * (1.0 + self.gain * 0.05 * spare))
            turn.eased = eased if turn.factor != before else turn.eased
            turn.min_margin_m = 1e9
            turn.max_error_m = -1.0
            turn.damaged = False
            turn.damage_points = 0.0
            changed += turn.factor != before
        return changed

    # --- persistence -------------------------------------------------------------------------
    def save(self, path: Path, track: str, car: str) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        data = {"track": track, "car": car,
                "turns": [{"start_m": round(t.start_m, 1), "end_m": round(t.end_m, 1), "factor": round(t.factor, 4),
                           "ceiling": round(t.ceiling, 4), "settled": t.settled} for t in self.turns]}
        from boxbox.files import write_json_atomic

        write_json_atomic(path, data, indent=1)  # a unique temporary file: races at once may save together

    def load(self, path: Path) -> bool:
        """Take the factors of turns that start within 10 m of a stored one."""
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
            return False
        stored = data.get("turns", [])
        for turn in self.turns:
            for s in stored:
                if abs(s["start_m"] - turn.start_m) < 10.0:
                    turn.factor = min(MAX_FACTOR, max(MIN_FACTOR, float(s["factor"])))
                    turn.ceiling = min(MAX_FACTOR, max(MIN_FACTOR, float(s.get("ceiling", MAX_FACTOR))))
                    turn.settled = bool(s.get("settled", False))
                    break
        return True
