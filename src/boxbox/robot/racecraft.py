"""Racecraft: passing, racing side by side, being lapped and braking for cars, from a prediction
of each nearby car (control/traffic.py has the physics on plain numbers; docs/racecraft.md the
measurements that chose the defaults).

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
  is kept), and inside the band that cars alongside leave us (room side by side).
  plan_passes=True plans passes instead (the inside of the coming turn when it has room, no
  further aside than needed, only when the pass completes before the braking zone or is on the
  inside, given up after abort_s); it measured worse in the field.  A pass under way on the inside
  of the coming turn (a car within commit_lengths ahead, moved aside towards the inside) is not
  called back to the line (keep_inside), and drives at the speed of the inside's tighter radius
  (inside_speed): without it a faster car never got by a slower one in a turn.
- `brake`: a touch of brake for a car touching ahead in our lane, unless it pulls away; with
  brake_mode "ttc" or "both" also braking from the predicted closest gap (we brake after a
  reaction time, it slows towards the speed our own profile needs where it is going), softer in
  front of a close follower.  The default "gap" keeps the tutorial's fixed-gap filter for the rest.
- Options measured and left off (docs/racecraft.md): `lift_m` (the throttle off that far before
  the fixed-gap brake would act behind a slower car, instead of full throttle and full brake in
  turn: on the robot of 2026-11-24 it saved a stop for fuel in 10-lap field races; on the final
  one it cost passes), `braking_ahead_mps2` (brake for a car ahead
  in our lane that brakes hard, its deceleration measured over the last steps: the fixed-gap filter
  takes its speed of now, and a car braking earlier than our profile was run into),
  `inward_grip_share` (a move towards a turn's
  inside only with grip to spare), `yield_inside` (brake to fall in behind a car alongside on the
  outside of the coming turn), `next_turn_s` (the first turn ahead is the inside to pass on),
  `path_lane` (a car ahead judged where our line meets it: `on_our_path`), `learn_lines` and
  `path_pass` (that place from the line the car was seen on before, robot/opponent_lines.py; a car
  off our path there is not passed aside), `conflict_s` (brake for a car whose remembered line
  turns in across ours while we overlap: `conflict_time_s`).
- `blocking` / `wreck_target`: stopped behind a stopped car in our lane (a wreck) for blocked_s,
  the robot backs away blocked_back_lengths car lengths and then drives round it (and any other
  stopped car in its way for wreck_s) at wreck_speed_mps, up to the track's edge, not braking for it.
- `spoiled` / `tainted`: whether traffic shaped the last steps (a car close, the line moved aside,
  a brake for a car), so the learner drops the whole turn for this lap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from boxbox.control.traffic import brake_for, closing_time_s, min_gap_m, pass_pays, pass_side, room
from boxbox.model.constants import G_MPS2
from boxbox.robot.opponents import Nearby

TURN_CURVATURE_1PM = 1.0 / 300.0  # the line curves more than this: a turn whose inside counts


@dataclass(frozen=True)
class RacecraftParams:
    brake_mode: str = "gap"  # ttc: the prediction; gap: the tutorial's fixed gap; both: the harder of the two
    plan_passes: bool = False  # False: the tutorial's overtaking offset, with room side by side
    horizon_s: float = 2.0  # how far ahead other cars are predicted
    reaction_s: float = 0.1  # we brake this long after deciding to
    brake_share: float = 0.75  # share of the tyres' grip counted on braking for a car (no downforce)
    margin_m: float = 2.0  # bumper gap kept to the car ahead
    close_brake: float = 0.5  # the brake with a car ahead in our lane touching (less as the gap grows)
    # ... unless it is faster than us by more than this (it pulls away): braking then only cost the exit
    # behind it (aalborg at 820 m, every lap: 18 m/s braking 0.2 behind tita:3 at 22, 30 m lost by
    # the next braking zone).  190 field races: 443 places with the brake whatever its speed, 343
    # with 1 m/s, 316 with 0, and the same races with -1: in brake_mode "gap" a slower car this close
    # gets the fixed-gap filter's full brake anyway (docs/racecraft.md, session 14)
    close_opening_mps: float = 0.0
    band_m: float = 4.0  # the brake rises from 0 to 1 as the predicted gap falls this much to the margin
    # lateral gap kept to a car alongside: with the inside pass kept through the turn, 1 m let boxbox
    # touch bt:2 passing it on g-track-1's first lap (third of three, 931 damage; 1.5 m: first, none)
    side_gap_m: float = 1.5
    pass_gap_m: float = 1.5  # lateral gap aimed at passing a car
    lane_m: float = 1.0  # a car ahead overlapping our width plus this is in our lane (brake for it)
    edge_m: float = 1.0  # our centre this far inside the track's edge beyond half our width
    pass_time_s: float = 3.0  # a slower car reached within this starts a pass
    abort_s: float = 6.0  # a pass not done by then is given up
    cooldown_s: float = 3.0  # after an abort, no new pass for this long
    lapped_back_m: float = 40.0  # a car lapping us this close behind is let by
    follower_m: float = 10.0  # a car this close behind is a follower we do not brake hard in front of
    follower_brake: float = 0.5  # the brake for a car ahead in front of a follower (unless at the margin)
    side_push_rad_per_m: float = 0.3  # steering away from a car alongside closer than the side margin
    hold_line_grip_share: float = 0.5  # a turn ahead needing this share of the grip at our speed: back to the line
    turn_ahead_s: float = 1.5  # how far ahead the turn is looked for
    lateral_ahead_s: float = 0.5  # how far ahead a car closing in sideways is seen where it will be
    stopped_mps: float = 3.0  # a car this slow close ahead is driven round, whatever our speed
    spoil_m: float = 15.0  # a car this close (centre to centre) shapes our driving
    spoil_hold_s: float = 1.0  # ... for this long after
    inward_grip_share: float = 0.0  # a full step towards a turn's inside needs this share of grip spare (0: no limit)
    yield_inside: bool = False  # brake to fall behind a car alongside ahead on the outside of the coming turn
    yield_side_m: float = 1.5  # ... that close sideways (beyond our width)
    braking_ahead_mps2: float = 0.0  # a car ahead braking harder than this is predicted braking on (0: off)
    next_turn_s: float = 0.0  # the turn whose inside counts: the first within this many s (0: horizon_s ahead)
    # a pass on the inside of the coming turn is not called back to the line: without it a faster
    # car never got by (boxbox from behind inferno:4 alone, 5 laps: stuck behind on 4 of 6 tracks)
    keep_inside: bool = True
    commit_lengths: float = 2.5  # a pass aside for a car within this many car lengths ahead is under way
    # lift off the throttle this far before the fixed-gap brake would brake (0: off; 5 m cost 3.2 s of
    # passing two cars on g-track-1 for the same places over 8-12 lap fields: docs/racecraft.md)
    lift_m: float = 0.0
    inside_speed: bool = True  # an offset towards a turn's inside caps the speed to its tighter radius
    # an offset towards the coming turn's outside is not called back to the line: it widens the
    # radius, so the line's speed holds there (g-track-1 from last of 10, 6-14 laps: third behind
    # olethros:2, 11 m/s below our line in its long turns, in 8 of 9 races; with it 3 to 7 wins)
    keep_outside: bool = True
    # a car ahead counts as in our lane where our line will be when we reach it, not only where we are
    # (aalborg's S at 1600 m: the line swings 4.6 m across onto a car taking it at 12 m/s, which the
    # lane of now saw 7 m aside until 0.3 s before contact, 500-900 damage a lap behind bt:2).  Off:
    # braking for more cars cost passes (the 2-car matrix, docs/racecraft.md: 380 s lost, not 302)
    path_lane: bool = False
    path_lane_s: float = 2.0  # ... when we reach it within this many seconds
    # ... where it will be from the line it was seen on there before (robot/opponent_lines.py)
    learn_lines: bool = False
    # a slower car ahead off our path where we reach it is not passed aside (the line goes by); with
    # learn_lines: the matrix as before (301 s), 54 field races 185 places, not 179: off
    path_pass: bool = False
    # brake for a car near ahead, not in our lane now, that its own line (robot/opponent_lines.py) takes
    # across ours while we overlap within this many seconds (0: off).  1 s: boxbox's damage in 54 field
    # races fell from 82,577 to 36,322 (aalborg 23,058 to 318), but its places rose from 169 to 239
    # (g-track-1 7th to 10th): most passes are made side by side with such a car
    conflict_s: float = 0.0
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
            # take a car on our right for one on our left and steer us into it; docs/racecraft.md, session 16)
            side = math.copysign(1e-3, c.lateral_m)
            c = replace(c, lateral_m=side, mid_m=c.mid_m - c.lateral_m + side)
        out.append(c)
    return out


def on_our_path(cars: list[Nearby], my_speed_mps: float, horizon_s: float, line_mid_at,
                their_mid_at=None, lapped_only: bool = False) -> list[Nearby]:
    """The cars with the lateral of a slower car clear ahead taken against our line where we reach
    it, after closing_time_s within horizon_s (line_mid_at(ahead_m) -> our line's to_middle that far
    ahead).  their_mid_at(car, ahead_m) -> (its to_middle that far ahead of where it is, whether
    that is known): known, the lateral there is the car's; unknown, the car keeps its to_middle and
    counts there only when that is closer than now.  A car alongside is where it is, and with
    lapped_only so is every car we are not lapping."""
    out = []
    for c in cars:
        if lapped_only and c.laps_ahead >= 0:
            out.append(c)
            continue
        t_s = closing_time_s(c.gap_m, my_speed_mps, c.speed_mps) if c.gap_m > 0.0 else math.inf
        if t_s < horizon_s:
            mid, known = their_mid_at(c, c.speed_mps * t_s) if their_mid_at else (c.mid_m, False)
            meet = mid - line_mid_at(my_speed_mps * t_s)
            if known or abs(meet) < abs(c.lateral_m):
                c = replace(c, lateral_m=meet, mid_m=mid)
        out.append(c)
    return out


def conflict_time_s(c: Nearby, my_speed_mps: float, length_m: float, clear_m: float, horizon_s: float,
                    line_mid_at, their_mid_at, step_s: float = 0.1) -> float:
    """The first time (s, within horizon_s; inf: none) at which car c, at its speed on its own
    line (their_mid_at(car, ahead_m) -> (its to_middle that far on, known)), and we at ours on our
    line (line_mid_at(ahead_m)) overlap lengthwise and are less than clear_m apart centre to centre
    sideways: a car alongside on the outside of a turn turning in across us, seen before it does."""
    t_s = step_s
    while t_s <= horizon_s + 1e-9:
        ahead_m = c.dist_m + (c.speed_mps - my_speed_mps) * t_s  # its centre ahead of ours then
        if abs(ahead_m) < length_m:
            mid, _ = their_mid_at(c, c.speed_mps * t_s)
            if abs(mid - line_mid_at(my_speed_mps * t_s)) < clear_m:
                return t_s
        t_s += step_s
    return math.inf


def inward_step(offset_m: float, new_m: float, k_1pm: float, v: float, grip_mps2: float, step_m: float,
                grip_share: float) -> float:
    """new_m, its move towards the inside of the turn the car is in (curvature k_1pm, + left)
    shortened by the grip left over: a move inwards tightens the path, and at the limit there is no
    grip for it (a move outwards eases the path and is not held).  Full step with grip_share of the
    grip spare, none with none spare."""
    if grip_share <= 0.0 or (new_m - offset_m) * k_1pm <= 0.0:
        return new_m
    spare = 1.0 - v * v * abs(k_1pm) / grip_mps2
    allowed = step_m * max(0.0, min(1.0, spare / grip_share))
    return offset_m + max(-allowed, min(allowed, new_m - offset_m))


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
        self.pass_since_s = 0.0
        self.no_pass_until_s = -math.inf
        self.spoiled_until_s = -math.inf
        self._lateral: dict[int, tuple[float, float, float]] = {}  # car index -> (time, lateral to us, speed)
        self._accel: dict[int, float] = {}  # car index -> its measured acceleration (m/s^2)
        self._taint_lap = -1
        self._tainted: set[int] = set()  # turns where traffic shaped a step this lap
        self._inside = 0.0  # the inside of the turn we are coming to (+1 left, -1 right, 0 none), from offset()

    def predict(self, now_s: float, cars: list[Nearby]) -> list[Nearby]:
        """The cars as they will be laterally lateral_ahead_s from now (closing in on us only),
        from their lateral speed relative to us over the last step."""
        rates = []
        for c in cars:
            last = self._lateral.get(c.index)
            dt = now_s - last[0] if last else 0.0
            fresh = last is not None and 0.0 < dt < 0.1
            rates.append((c.lateral_m - last[1]) / dt if last and fresh else 0.0)
            accel = self._accel.get(c.index, 0.0)
            if last and fresh:  # smoothed over ~0.1 s: a contact jolts one step's speed
                accel += min(1.0, dt / 0.1) * ((c.speed_mps - last[2]) / dt - accel)
            self._accel[c.index] = accel if fresh else 0.0
            self._lateral[c.index] = (now_s, c.lateral_m, c.speed_mps)
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
               edges_m: tuple[float, float], inside_sign: float, straight_m: float, step_m: float,
               base_offset_m: float | None = None, turn_1pm: float = 0.0, here_1pm: float = 0.0) -> float:
        """The new lateral offset of the line (see the module's docstring).  edges_m: the track's
        (left, right) edges here as lateral positions; straight_m: road ahead before the next
        braking zone; base_offset_m: an offset chosen elsewhere (the tutorial's overtaking) that
        only gets the room side by side; turn_1pm: the line's sharpest curvature in the next
        seconds: in a turn the offset goes back to the line (the speed profile is the line's: off
        it the radius is another), unless a car alongside needs room."""
        p = self.p
        self._inside = inside_sign
        left = edges_m[0] - 0.5 * self.width_m - p.edge_m
        right = edges_m[1] + 0.5 * self.width_m + p.edge_m
        if base_offset_m is None:
            target = self._pass_target(now_s, v, cars, my_mid_m, line_off_m, left, right, inside_sign, straight_m)
            if target is None:
                target = self._yield_target(cars, my_mid_m, left, right)
            want = 0.0 if target is None else target - line_off_m
            new = min(want, offset_m + step_m) if offset_m < want else max(want, offset_m - step_m)
        else:
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
        new = inward_step(offset_m, new, here_1pm, v, self.decel_mps2, step_m, p.inward_grip_share)
        alongside = [(c.mid_m, c.width_m or self.width_m) for c in cars if abs(c.dist_m) < self.length_m + 1.0]
        if alongside:
            lo, hi = room(my_mid_m, alongside, self.width_m, p.side_gap_m, left, right)
            new = min(hi, max(lo, line_off_m + new)) - line_off_m
        if new or any(abs(c.dist_m) < p.spoil_m for c in cars):
            self.mark_spoiled(now_s)
        return new

    def _pass_target(self, now_s: float, v: float, cars: list[Nearby], my_mid_m: float, line_off_m: float,
                     left: float, right: float, inside_sign: float, straight_m: float) -> float | None:
        """Our lateral target passing the slower car ahead in our way, or None."""
        p = self.p
        ahead = [c for c in cars if c.dist_m > 0.0 and c.speed_mps < v and c.laps_ahead <= 0
                 and abs(c.lateral_m) < self.width_m + 2.0 * p.pass_gap_m
                 and c.gap_m < max(2.0 * self.length_m, (v - c.speed_mps) * p.pass_time_s)]
        if not ahead or now_s < self.no_pass_until_s:
            self.pass_side = 0.0
            return None
        c = min(ahead, key=lambda x: x.dist_m)
        other_w = c.width_m or self.width_m
        if abs(line_off_m - c.mid_m) >= 0.5 * (self.width_m + other_w) + p.pass_gap_m:
            self.pass_side = 0.0
            return None  # the racing line goes by it: keep the line
        if self.pass_side == 0.0:
            self.pass_since_s = now_s
        elif now_s - self.pass_since_s > p.abort_s:
            self.pass_side = 0.0
            self.no_pass_until_s = now_s + p.cooldown_s
            return None
        sticky = self.pass_side or inside_sign
        close = c.gap_m < self.length_m  # too close to cross behind it: pass on the side we are on
        chosen = pass_side(c.mid_m, self.width_m, other_w, p.pass_gap_m, left, right, sticky,
                           my_mid_m if close else None)
        if chosen is None:
            self.pass_side = 0.0
            return None  # no room either side: stay behind (brake() keeps the gap)
        side, target = chosen
        if self.pass_side == 0.0 and not pass_pays(c.gap_m, v, c.speed_mps, self.length_m, straight_m,
                                                    side == inside_sign):
            return None  # would end side by side on the outside of a turn: wait behind
        self.pass_side = side
        return target

    def _committed_side(self, cars: list[Nearby], base_offset_m: float) -> float:
        """The side of a pass under way on the tutorial's overtaking offset (+1 left, -1 right, 0
        none): moved aside with a car we are not lapped by within commit_lengths car lengths ahead.
        Farther back the pass is not under way: holding an inside offset through a turn then only
        costs time behind the car (g-track-1, 3 lengths: stuck behind inferno:4 for 5 laps)."""
        if not base_offset_m:
            return 0.0
        reach = self.p.commit_lengths * self.length_m
        if any(0.0 < c.dist_m < reach and c.laps_ahead <= 0 for c in cars):
            return math.copysign(1.0, base_offset_m)
        return 0.0

    def _round_stopped(self, cars: list[Nearby], left: float, right: float, inside_sign: float) -> float | None:
        """Our lateral target round a car stopped (a crash) close ahead in our way, or None: the
        tutorial's overtaking passes only cars slower than us, so behind a stopped car we stopped too."""
        p = self.p
        for c in cars:
            if 0.0 < c.dist_m < 3.0 * self.length_m and c.speed_mps < p.stopped_mps \
                    and abs(c.lateral_m) < self.width_m + p.side_gap_m:
                chosen = pass_side(c.mid_m, self.width_m, c.width_m or self.width_m, p.side_gap_m, left, right,
                                   inside_sign)
                return None if chosen is None else chosen[1]
        return None

    def stopped_ahead(self, cars: list[Nearby], reach_lengths: float = 3.0) -> Nearby | None:
        """The nearest stopped car ahead (or alongside) within reach_lengths car lengths and
        overlapping our lane, or None."""
        p = self.p
        near = [c for c in cars if -self.length_m < c.dist_m < reach_lengths * self.length_m
                and c.speed_mps < p.stopped_mps
                and abs(c.lateral_m) < 0.5 * (self.width_m + (c.width_m or self.width_m)) + p.lane_m]
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

    def _yield_target(self, cars: list[Nearby], my_mid_m: float, left: float, right: float) -> float | None:
        """Aside for a car lapping us from close behind: the side it is not on."""
        for c in cars:
            if c.laps_ahead > 0 and -self.p.lapped_back_m < c.dist_m < 0.0:
                return right if c.mid_m > my_mid_m else left
        return None

    def _braking_ahead(self, v: float, cars: list[Nearby]) -> float:
        """Brake for a car ahead in our lane that is braking (measured): the closest gap predicted
        when it keeps braking as hard for the horizon (no lower than half its speed) and we brake
        after a reaction time.  The fixed-gap filter takes its speed of now, and in a braking zone
        where it brakes earlier than our profile we ran into it."""
        p = self.p
        want = 0.0
        for c in cars:
            a = self._accel.get(c.index, 0.0)
            if c.dist_m <= 0.0 or a > -p.braking_ahead_mps2 or c.speed_mps >= v \
                    or abs(c.lateral_m) >= 0.5 * (self.width_m + (c.width_m or self.width_m)) + p.lane_m:
                continue
            target = max(0.5 * c.speed_mps, c.speed_mps + a * p.horizon_s)
            gap = min_gap_m(c.gap_m, v, c.speed_mps, target, p.brake_share * self.decel_mps2, -a,
                            p.reaction_s, p.horizon_s)
            want = max(want, brake_for(gap, p.margin_m, p.band_m))
        return want

    def lift(self, accel: float, v: float, cars: list[Nearby], brakedist) -> float:
        """No throttle when a slower car ahead in our lane is within lift_m of the gap the
        fixed-gap filter brakes at: behind a car, full throttle then full brake every other step
        burns fuel for nothing (a 10-lap race behind traffic needed a stop for fuel) and closes in
        harder than needed."""
        p = self.p
        if accel <= 0.0 or p.lift_m <= 0.0:
            return accel
        for c in cars:
            if 0.0 < c.dist_m and c.speed_mps < v and abs(c.lateral_m) < self.width_m + p.side_gap_m \
                    and brakedist(v, c.speed_mps) + p.lift_m > c.gap_m:
                return 0.0
        return accel

    def _yield_brake(self, cars: list[Nearby]) -> float:
        """Brake to fall in behind a car alongside and ahead of us on the outside of the turn we
        are coming to: it turns in to its apex and does not see us (TORCS's robots squeeze a car on
        their inside into the edge); a pass on the inside is made ahead of it or not at all."""
        if not self._inside:
            return 0.0
        for c in cars:
            if -0.5 * self.length_m < c.dist_m < self.length_m + 1.0 and c.lateral_m * self._inside < 0.0 \
                    and abs(c.lateral_m) < self.width_m + self.p.yield_side_m:
                return 1.0
        return 0.0

    # --- braking for the car ahead --------------------------------------------------------------
    def brake(self, now_s: float, brake: float, v: float, cars: list[Nearby], other_target,
              predict: bool = True) -> float:
        """brake, raised where a car ahead in our lane would come closer than the margin (predict:
        from the prediction; always: a car already closer than the margin gets a lift or a touch
        of brake, unless it is faster than us by close_opening_mps).  other_target(car) -> the
        speed it is predicted to slow to within the horizon."""
        p = self.p
        want = 0.0
        closest = math.inf
        for c in cars:
            if c.dist_m <= 0.0 or abs(c.lateral_m) >= 0.5 * (self.width_m + (c.width_m or self.width_m)) + p.lane_m:
                continue
            if c.gap_m < p.margin_m and c.speed_mps <= v + p.close_opening_mps:
                closest = min(closest, c.gap_m)
                want = max(want, p.close_brake * (1.0 - max(0.0, c.gap_m) / p.margin_m))
            if not predict:
                continue
            gap = min_gap_m(c.gap_m, v, c.speed_mps, other_target(c), p.brake_share * self.decel_mps2,
                            self.decel_mps2, p.reaction_s, p.horizon_s)
            closest = min(closest, gap)
            want = max(want, brake_for(gap, p.margin_m, p.band_m))
        if p.yield_inside:
            want = max(want, self._yield_brake(cars))
        if p.braking_ahead_mps2 > 0.0:
            want = max(want, self._braking_ahead(v, cars))
        if want <= 0.0:
            return brake
        self.mark_spoiled(now_s)
        follower = any(-p.follower_m < c.dist_m < 0.0 and abs(c.lateral_m) < self.width_m for c in cars)
        if follower and closest > p.margin_m:
            want = min(want, p.follower_brake)
        return max(brake, want)
