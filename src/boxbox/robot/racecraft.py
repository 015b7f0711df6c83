"""Racecraft: passing, racing side by side, being lapped and braking for cars, from a prediction
of each nearby car (control/traffic.py has the geometry on plain numbers; docs/racecraft.md the
measurements that chose the defaults, and the options measured and retired).

Only ever consulted when a car is near (robot/opponents.py `nearby`): a car racing alone drives
exactly as without it.  Per step:

- `predict`: each car's lateral position as it will be lateral_ahead_s from now when it is closing
  in on us sideways (its lateral speed relative to us over the last step), so a car cutting across
  counts as in our lane before it is.
- `offset`: the lateral offset of the racing line.  By default the tutorial's overtaking offset
  (towards the free side of a slower car ahead, aside for a car lapping us), then: round a car
  stopped close ahead, never further out than the track allows, back to the line where the turn
  ahead needs more than hold_line_grip_share of the grip at our speed (the speed profile is the
  line's: off it the radius is another; an offset towards the turn's outside only widens it and
  is kept), and inside the band that cars alongside leave us (room side by side).  A pass under
  way on the inside of the coming turn (a car within commit_lengths ahead, moved aside towards the
  inside) is not called back to the line (keep_inside), and drives at the speed of the inside's
  tighter radius (inside_speed): without it a faster car never got by a slower one in a turn.
- `brake`: a touch of brake for a car touching ahead in our lane, unless it pulls away
  (robot/behind.py `touch_brake`, beside the tutorial's fixed-gap filter).
- `blocking` / `wreck_target`: stopped behind a stopped car in our lane (a wreck) for blocked_s,
  the robot backs away blocked_back_lengths car lengths and then drives round it (and any other
  stopped car in its way for wreck_s) at wreck_speed_mps, up to the track's edge, not braking for it.
- `spoiled` / `tainted`: whether traffic shaped the last steps (a car close, the line moved aside,
  a brake for a car), so the learner drops the whole turn for this lap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from boxbox.control.traffic import pass_side, room
from boxbox.model.constants import G_MPS2
from boxbox.robot.behind import BehindParams, touch_brake
from boxbox.robot.opponents import Nearby, in_lane

TURN_CURVATURE_1PM = 1.0 / 300.0  # the line curves more than this: a turn whose inside counts


@dataclass(frozen=True)
class RacecraftParams(BehindParams):
    # the brake behind a car's first (robot/behind.py BehindParams), then passing, side by side, wrecks
    horizon_s: float = 2.0  # the turn whose inside counts: the line's curvature this many seconds ahead
    # lateral gap kept to a car alongside: with the inside pass kept through the turn, 1 m let boxbox
    # touch bt:2 passing it on g-track-1's first lap (third of three, 931 damage; 1.5 m: first, none)
    side_gap_m: float = 1.5
    edge_m: float = 1.0  # our centre this far inside the track's edge beyond half our width
    side_push_rad_per_m: float = 0.3  # steering away from a car alongside closer than the side margin
    hold_line_grip_share: float = 0.5  # a turn ahead needing this share of the grip at our speed: back to the line
    turn_ahead_s: float = 1.5  # how far ahead the turn is looked for
    lateral_ahead_s: float = 0.5  # how far ahead a car closing in sideways is seen where it will be
    stopped_mps: float = 3.0  # a car this slow close ahead is driven round, whatever our speed
    spoil_m: float = 15.0  # a car this close (centre to centre) shapes our driving
    spoil_hold_s: float = 1.0  # ... for this long after
    # a pass on the inside of the coming turn is not called back to the line: without it a faster
    # car never got by (boxbox from behind inferno:4 alone, 5 laps: stuck behind on 4 of 6 tracks)
    keep_inside: bool = True
    commit_lengths: float = 2.5  # a pass aside for a car within this many car lengths ahead is under way
    inside_speed: bool = True  # an offset towards a turn's inside caps the speed to its tighter radius
    # an offset towards the coming turn's outside is not called back to the line: it widens the
    # radius, so the line's speed holds there (g-track-1 from last of 10, 6-14 laps: third behind
    # olethros:2, 11 m/s below our line in its long turns, in 8 of 9 races; with it 3 to 7 wins)
    keep_outside: bool = True
    # stopped this long behind a stopped car in our lane (a wreck): back away from it to steer round
    # (mixed-2's narrow turn at 257 m: boxbox sat 33 s behind tita:3's wreck with no side wide
    # enough for the margins of a pass at speed)
    blocked_s: float = 2.0
    # ... or this long when it takes damage meanwhile: pushing a car that does not move (dirt-4's
    # first lap: 1,860 damage at full throttle against a car jammed ahead in the 2 s of blocked_s)
    blocked_grinding_s: float = 0.3
    blocked_back_lengths: float = 2.5  # ... this many car lengths before driving round it
    wreck_gap_m: float = 0.5  # then round it at this lateral gap, up to the track's edge,
    wreck_speed_mps: float = 5.0  # ... no faster than this,
    wreck_s: float = 15.0  # ... for at most this long


def converging(cars: list[Nearby], rates_mps: list[float], ahead_s: float) -> list[Nearby]:
    """The cars with their lateral positions moved ahead_s along their lateral speed relative to
    us, where that brings them closer to our line (never further: a car moving away still counts
    where it is now)."""
    out = []
    for c, rate in zip(cars, rates_mps, strict=True):
        moved = c.lateral_m + rate * ahead_s
        if abs(moved) < abs(c.lateral_m) and moved * c.lateral_m > 0.0:
            shift = moved - c.lateral_m
            c = replace(c, lateral_m=moved, mid_m=c.mid_m + shift)
        elif moved * c.lateral_m <= 0.0 and c.lateral_m:
            # predicted across us: at our centre, on the side it is on (mid_m exactly ours made room()
            # take a car on our right for one on our left and steer us into it; docs/racecraft.md's table)
            side = math.copysign(1e-3, c.lateral_m)
            c = replace(c, lateral_m=side, mid_m=c.mid_m - c.lateral_m + side)
        out.append(c)
    return out


def inside_speed_mps(target_mps: float, k_1pm: float, offset_m: float) -> float:
    """The speed for a line moved offset_m (+ left) from one of curvature k_1pm (+ left) at
    target_mps: towards the inside the radius shrinks by the offset (1/k - d), and the speed the
    same grip allows with it (v^2 k is the lateral acceleration); towards the outside, unchanged."""
    tight = k_1pm * offset_m
    if tight <= 0.0:
        return target_mps
    return target_mps * math.sqrt(max(0.25, 1.0 - tight))


class Racecraft:
    """Per-race state of the traffic decisions (the pass under way, the learner guard)."""

    def __init__(self, params: RacecraftParams, width_m: float, length_m: float, mu: float) -> None:
        self.p = params
        self.width_m = width_m
        self.length_m = length_m
        self.decel_mps2 = mu * G_MPS2
        self.pass_side = 0.0  # +1 left, -1 right, 0: no pass under way
        self.spoiled_until_s = -math.inf
        self._lateral: dict[int, tuple[float, float]] = {}  # car index -> (time, lateral to us)
        self._taint_lap = -1
        self._tainted: set[int] = set()  # turns where traffic shaped a step this lap

    def predict(self, now_s: float, cars: list[Nearby]) -> list[Nearby]:
        """The cars as they will be laterally lateral_ahead_s from now (closing in on us only),
        from their lateral speed relative to us over the last step."""
        rates = []
        for c in cars:
            last = self._lateral.get(c.index)
            dt = now_s - last[0] if last else 0.0
            fresh = last is not None and 0.0 < dt < 0.1
            rates.append((c.lateral_m - last[1]) / dt if last and fresh else 0.0)
            self._lateral[c.index] = (now_s, c.lateral_m)
        return converging(cars, rates, self.p.lateral_ahead_s)

    def spoiled(self, now_s: float) -> bool:
        return now_s < self.spoiled_until_s

    def tainted(self, now_s: float, lap: int, turn: int) -> tuple[bool, bool]:
        """(skip this step, newly tainted turn) for the learner: a turn (-1: none) where traffic
        shaped any step this lap is judged on none of its steps (judged on the rest it would look
        easier than it is: the hard part is where the car was lifting or aside)."""
        if lap != self._taint_lap:
            self._taint_lap = lap
            self._tainted.clear()
        if self.spoiled(now_s):
            new = turn >= 0 and turn not in self._tainted
            if new:
                self._tainted.add(turn)
            return True, new
        return turn >= 0 and turn in self._tainted, False

    def mark_spoiled(self, now_s: float) -> None:
        """Traffic shapes this step and the next spoil_hold_s: the learner skips them."""
        self.spoiled_until_s = now_s + self.p.spoil_hold_s

    # --- the line's offset ----------------------------------------------------------------------
    def offset(self, now_s: float, v: float, my_mid_m: float, cars: list[Nearby], offset_m: float, line_off_m: float,
               edges_m: tuple[float, float], inside_sign: float, step_m: float, base_offset_m: float,
               turn_1pm: float = 0.0) -> float:
        """The new lateral offset of the line (see the module's docstring).  edges_m: the track's
        (left, right) edges here as lateral positions; base_offset_m: the tutorial's overtaking
        offset, which gets the bounds here and the room side by side; turn_1pm: the line's sharpest
        curvature in the next seconds: in a turn the offset goes back to the line (the speed profile
        is the line's: off it the radius is another), unless a car alongside needs room."""
        p = self.p
        left = edges_m[0] - 0.5 * self.width_m - p.edge_m
        right = edges_m[1] + 0.5 * self.width_m + p.edge_m
        blocked = self._round_stopped(cars, left, right, inside_sign)
        if blocked is not None:
            want = blocked - line_off_m
            base_offset_m = min(want, offset_m + step_m) if offset_m < want else max(want, offset_m - step_m)
        new = base_offset_m  # moved aside, but never further out than the track allows (or the line is)
        self.pass_side = self._committed_side(cars, base_offset_m)
        if new > 0.0:
            new = max(0.0, min(new, left - line_off_m))
        elif new < 0.0:
            new = min(0.0, max(new, right - line_off_m))
        inside_pass = p.keep_inside and self.pass_side != 0.0 and self.pass_side == inside_sign
        outside = p.keep_outside and new * inside_sign < 0.0
        if v * v * turn_1pm > p.hold_line_grip_share * self.decel_mps2 and not inside_pass and not outside:
            new = max(0.0, offset_m - step_m) if offset_m > 0.0 else min(0.0, offset_m + step_m)
        alongside = [(c.mid_m, c.width_m or self.width_m) for c in cars if abs(c.dist_m) < self.length_m + 1.0]
        if alongside:
            lo, hi = room(my_mid_m, alongside, self.width_m, p.side_gap_m, left, right)
            new = min(hi, max(lo, line_off_m + new)) - line_off_m
        if new or any(abs(c.dist_m) < p.spoil_m for c in cars):
            self.mark_spoiled(now_s)
        return new

    def _committed_side(self, cars: list[Nearby], base_offset_m: float) -> float:
        """The side of a pass under way on the tutorial's overtaking offset (+1 left, -1 right, 0
        none): moved aside with a car we are not lapped by within commit_lengths car lengths ahead.
        Farther back the pass is not under way: holding an inside offset through a turn then only
        costs time behind the car (g-track-1, 3 lengths: stuck behind inferno:4 for 5 laps)."""
        if not base_offset_m:
            return 0.0
        reach = self.p.commit_lengths * self.length_m
        if any(c.ahead and c.dist_m < reach and not c.lapping for c in cars):
            return math.copysign(1.0, base_offset_m)
        return 0.0

    def _round_stopped(self, cars: list[Nearby], left: float, right: float, inside_sign: float) -> float | None:
        """Our lateral target round a car stopped (a crash) close ahead in our way, or None: the
        tutorial's overtaking passes only cars slower than us, so behind a stopped car we stopped too."""
        p = self.p
        for c in cars:
            if c.ahead and c.dist_m < 3.0 * self.length_m and c.speed_mps < p.stopped_mps \
                    and in_lane(c, self.width_m, p.side_gap_m):  # too close aside to pass at side_gap_m
                chosen = pass_side(c.mid_m, self.width_m, c.width_m or self.width_m, p.side_gap_m, left, right,
                                   inside_sign)
                return None if chosen is None else chosen[1]
        return None

    def stopped_ahead(self, cars: list[Nearby], reach_lengths: float = 3.0) -> Nearby | None:
        """The nearest stopped car ahead (or alongside) within reach_lengths car lengths and
        overlapping our lane (sides_in_lane), or None."""
        p = self.p
        near = [c for c in cars if -self.length_m < c.dist_m < reach_lengths * self.length_m
                and c.speed_mps < p.stopped_mps and c.sides_in_lane]
        return min(near, key=lambda c: c.dist_m, default=None)

    def blocking(self, v: float, cars: list[Nearby]) -> Nearby | None:
        """The stopped car close ahead in our lane while we are stopped too, or None: a wreck we
        cannot steer round from where we stand."""
        if v >= self.p.stopped_mps:
            return None
        c = self.stopped_ahead(cars, 2.0)
        return c if c is not None and c.dist_m > 0.0 else None

    def wreck_target(self, c: Nearby, left_m: float, right_m: float) -> float | None:
        """Our lateral position (+ left) to drive by a wreck, car c, at walking pace: wreck_gap_m
        beside it on the side with more room up to the track's edges (left_m, right_m as lateral
        positions), or None when neither side has our width."""
        half = 0.5 * self.width_m
        chosen = pass_side(c.mid_m, self.width_m, c.width_m or self.width_m, self.p.wreck_gap_m, left_m - half,
                           right_m + half, 0.0)
        return None if chosen is None else chosen[1]

    # --- braking for the car ahead --------------------------------------------------------------
    def brake(self, now_s: float, brake: float, v: float, cars: list[Nearby]) -> float:
        """brake, raised by robot/behind.py's touch_brake for a car touching ahead (the step is then
        shaped by traffic: spoiled for the learner)."""
        want = touch_brake(v, cars, self.p)
        if want <= 0.0:
            return brake
        self.mark_spoiled(now_s)
        return max(brake, want)
