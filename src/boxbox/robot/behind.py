"""The brake behind a car: every rule that brakes for a car ahead, in one place (the robot's
chain calls them in turn once a step with the cars near: robot/tutorial/traffic.py `_avoid_collision`).

- `touch_brake`: racecraft's lift or touch of brake for a car in our lane closer than
  BehindParams.margin_m, unless it pulls away (close_opening_mps);
- `collision_brake`: the tutorial's fixed-gap filter, a full brake when the gap to a slower car in
  our lane is within our braking distance to its speed plus OpponentParams.length_margin_m;
- `hazard_brake`: a full brake for a car out of control ahead whose slide crosses our lane before
  we reach it (off: hazard_slip_deg 0).
"Ahead" and "in our lane" are the flags robot/opponents.py's `relate` sets on each car once a step
(`in_lane`, one predicate, with each rule's margin).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from boxbox.robot.opponents import Nearby, OpponentParams


@dataclass(frozen=True)
class BehindParams:
    """racecraft's brake behind a car (RacecraftParams, and so TutorialParams, extend it: setup
    files, --set and tune reach it); the fixed-gap filter's are OpponentParams'."""

    margin_m: float = 2.0  # bumper gap kept to the car ahead
    close_brake: float = 0.5  # the brake with a car ahead in our lane touching (less as the gap grows)
    # ... unless it is faster than us by more than this (it pulls away): braking then only cost the exit
    # behind it (aalborg at 820 m, every lap: 18 m/s braking 0.2 behind tita:3 at 22, 30 m lost by
    # the next braking zone).  190 field races: 443 places with the brake whatever its speed, 343
    # with 1 m/s, 316 with 0, and the same races with -1: a slower car this close gets the fixed-gap
    # filter's full brake anyway (docs/racecraft.md)
    close_opening_mps: float = 0.0
    lane_m: float = 1.0  # a car ahead overlapping our width plus this is in our lane (brake for it)


def touch_brake(v: float, cars: list[Nearby], p: BehindParams) -> float:
    """The brake for the closest car ahead in our lane (its side within p.lane_m of ours: the cars'
    sides_in_lane, from `relate` with p.lane_m) closer
    than p.margin_m bumper to bumper: p.close_brake touching, less as the gap grows, none for a car
    faster than us by more than p.close_opening_mps (it pulls away)."""
    want = 0.0
    for c in cars:
        if not (c.ahead and c.sides_in_lane):
            continue
        if c.gap_m < p.margin_m and c.speed_mps <= v + p.close_opening_mps:
            want = max(want, p.close_brake * (1.0 - max(0.0, c.gap_m) / p.margin_m))
    return want


def gap_too_short(need_m: float, gap_m: float, p: OpponentParams) -> bool:
    """The fixed-gap filter's rule: the braking distance need_m plus the length margin is more than
    the bumper gap, or the gap is under the margin anyway."""
    return need_m + p.length_margin_m > gap_m or gap_m < p.length_margin_m


def collision_brake(brake: float, speed_mps: float, cars: list[Nearby], p: OpponentParams, brakedist) -> float:
    """Full brake when the gap to a slower car in our lane (in_our_lane, from `relate` with
    p.side_margin_m) is within our braking distance (with
    p.soft_gap_m: the share of a full brake that slows us to its speed within the gap beyond that)."""
    want = 0.0
    for c in cars:
        if c.ahead and c.speed_mps < speed_mps and c.in_our_lane:
            need = brakedist(speed_mps, c.speed_mps)
            if gap_too_short(need, c.gap_m, p):
                if p.soft_gap_m <= 0.0:
                    return 1.0
                room_m = c.gap_m - p.soft_gap_m
                want = max(want, 1.0 if room_m <= need else need / room_m)
    return max(brake, want)


HAZARD_MIN_SPEED_MPS = 3.0  # a car slower than this is a stopped car for the filters, not a slide


def out_of_control(c: Nearby, p: OpponentParams) -> bool:
    """Whether car c slides more than p.hazard_slip_deg off its heading, or crosses the road at more
    than half its speed (its course 30 degrees or more off the track's): a spin or a crash, where
    it is now says little about where it will be."""
    if c.speed_mps < HAZARD_MIN_SPEED_MPS:
        return False
    return abs(c.slip_rad) > math.radians(p.hazard_slip_deg) or abs(c.across_mps) > 0.5 * c.speed_mps


def hazard_brake(brake: float, speed_mps: float, my_mid_m: float, cars: list[Nearby], width_m: float,
                 p: OpponentParams, brakedist) -> float:
    """Full brake for a car out of control ahead whose slide crosses our lane before we reach it
    (followed at its speed across the track for the time we take to close the gap, at most
    p.hazard_horizon_s) when we could not slow to its speed along the track within the gap: the
    fixed-gap filter for where it is going, not where it is.  Not stopped at the track's edge: there
    the slide ends, but our lane is inside it, so the answer is the same while we are on the road."""
    if p.hazard_slip_deg <= 0.0:
        return brake
    lane_m = width_m + p.side_margin_m
    for c in cars:
        if not c.ahead or not out_of_control(c, p):
            continue
        along = math.sqrt(max(0.0, c.speed_mps * c.speed_mps - c.across_mps * c.across_mps))
        if speed_mps <= along:
            continue
        t_s = min(p.hazard_horizon_s, max(0.0, c.gap_m) / (speed_mps - along))
        there = c.mid_m + c.across_mps * t_s
        lo, hi = min(c.mid_m, there), max(c.mid_m, there)
        if lo < my_mid_m + lane_m and hi > my_mid_m - lane_m and gap_too_short(brakedist(speed_mps, along), c.gap_m, p):
            return 1.0
    return brake
