"""Opponents: who is where relative to us (`nearby`, then `relate`: each car's relation to us as
flags, once a step, that every filter reads), and the tutorial's filters that steer for them (the
brakes for a car ahead are robot/behind.py's).

- side collision steering filter: steer away from a car alongside;
- overtaking: move the line sideways towards the free side of a slower car ahead;
- letting a faster lapping car pass: move aside when it is close behind.
Everything is per step and cheap: one pass over the opponents in plain Python.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from boxbox.model.state import CAR_STATE_OUT, Opponent, State


@dataclass(slots=True)
class Nearby:
    """One opponent relative to us."""

    dist_m: float  # centre to centre along the track, + ahead
    gap_m: float  # bumper to bumper: dist_m minus a car length (ahead) or plus one (behind)
    lateral_m: float  # its to_middle minus ours, + to our left
    # the size of its velocity; from nearby() with the track's heading, 0 when it moves backwards along
    # the track (reversing, or turned round)
    speed_mps: float
    laps_ahead: int  # its laps minus ours: > 0 means it is lapping us
    width_m: float = 0.0  # its width (0: unknown, take ours)
    mid_m: float = 0.0  # its to_middle (m, + left of the track's middle)
    index: int = -1  # its car index (-1: unknown)
    # its velocity across the track (m/s, + to the left) and the angle of its velocity off its own
    # heading (rad, its slip): from nearby() with the track's heading, else 0
    across_mps: float = 0.0
    slip_rad: float = 0.0
    # its relation to us, flags every filter reads (bt's opponent states): ahead and lapping when made,
    # the lanes set once a step by relate() (they move with racecraft's prediction of lateral_m)
    ahead: bool = field(init=False, default=False)  # dist_m > 0
    lapping: bool = field(init=False, default=False)  # it is lapping us (laps_ahead > 0)
    in_our_lane: bool = field(init=False, default=False)  # the tutorial's lane: centre within our width + side margin
    sides_in_lane: bool = field(init=False, default=False)  # racecraft's lane: its side within lane_m of ours

    def __post_init__(self) -> None:
        self.ahead = self.dist_m > 0.0
        self.lapping = self.laps_ahead > 0


@dataclass(frozen=True)
class OpponentParams:
    front_range_m: float = 200.0
    back_range_m: float = 50.0
    length_margin_m: float = 3.0
    side_margin_m: float = 1.0
    overtake_step_m: float = 0.1
    # pass a car we reach within this many seconds on the side we are on, when we are already this
    # far aside of it (0: the tutorial's side, the one with more room, even across the car's path)
    keep_side_s: float = 0.0
    keep_side_lateral_m: float = 1.0
    # passing a car at our speed (in its slipstream): a car close ahead at least this much slower
    # than we would go there alone is passed too, not only one slower than us (0: off, the tutorial's)
    draft_mps: float = 0.0
    # the fixed-gap brake as the share of a full brake that slows us to the car's speed before the gap
    # is down to this many metres (full brake closer), not a full brake whenever it fires (0: the
    # tutorial's full brake).  In a slipstream it fired a full brake at 82 m/s every 0.6 s
    soft_gap_m: float = 0.0
    # a car out of control ahead (sliding more than this many degrees off its heading, or crossing the
    # road at more than half its speed) is braked for where its slide takes it by the time we reach
    # it, not only where it is (0: off).  b-speedway, lap 3: a car spinning across the road from
    # 20 m to our left, 80 m ahead; the lane of now saw it 21 m ahead, 0.4 s before contact at 85 m/s
    hazard_slip_deg: float = 0.0
    hazard_horizon_s: float = 2.0  # ... its slide followed this far ahead at most
    # a car we are lapping is passed on our side of it, not on the side with more room, for a robot
    # that moves away from a car lapping it (False: the tutorial's; not all do: 6 % more damage in
    # 190 field races, `bench-field --tracks all --repeats 5`; docs/racecraft.md, what was tried)
    lapped_own_side: bool = False


def track_velocity_mps(o: Opponent, track_heading_rad: float) -> tuple[float, float]:
    """A car's velocity (along the track + forwards, across it + to the left), m/s: its car-frame
    velocity turned by its yaw relative to the track.  A car backing into us, or turned round, moves
    at its full speed, and only the projection tells which way (bt's opponent speed is the same)."""
    rel = o.yaw_rad - track_heading_rad
    cos_rel, sin_rel = math.cos(rel), math.sin(rel)
    return (o.speed_x_mps * cos_rel - o.speed_y_mps * sin_rel, o.speed_x_mps * sin_rel + o.speed_y_mps * cos_rel)


def nearby(state: State, length_m: float, track_length_m: float, back_range_m: float,
           front_range_m: float, heading_at: Callable[[float], float] | None = None) -> list[Nearby]:
    """The cars within back_range_m behind and front_range_m ahead, relative to us.  heading_at(dist_m)
    -> the track's direction there (rad): with it a car moving backwards along the track counts as
    stopped.  Its speed is the size of its velocity, not its share along the track: that share
    (bt's) made a car at a slight angle slower than us and braked for it (190 field races: 394
    places, not 316)."""
    out = []
    half = track_length_m / 2
    my_dist, my_mid, my_laps = state.dist_from_start_m, state.to_middle_m, state.laps
    for o in state.opponents:
        if int(o.car_state) & CAR_STATE_OUT or not math.isfinite(o.dist_from_start_m + o.to_middle_m + o.speed_mps):
            continue  # out of the race, or a car whose state TORCS lost in a pile-up (NaN): no input to steer by
        raw = o.dist_from_start_m - my_dist
        d = raw
        if d > half:
            d -= track_length_m
        elif d < -half:
            d += track_length_m
        gap = d - length_m if d > 0 else d + length_m
        if -back_range_m < d < front_range_m:
            # whole laps between us, counting the start line between the two cars
            laps_ahead = round(((o.laps - my_laps) * track_length_m + raw - d) / track_length_m)
            speed, across, slip = o.speed_mps, 0.0, 0.0
            if heading_at is not None:
                along, across = track_velocity_mps(o, heading_at(o.dist_from_start_m))
                slip = math.atan2(o.speed_y_mps, o.speed_x_mps) if o.speed_x_mps or o.speed_y_mps else 0.0
                if along < 0.0:
                    speed = 0.0  # backing into us, or turned round: stopped for our filters, not moving away
            out.append(Nearby(d, gap, o.to_middle_m - my_mid, speed, laps_ahead, o.width_m, o.to_middle_m,
                              int(o.car_index), across, slip))
    return out


def in_lane(c: Nearby, width_m: float, margin_m: float, half_widths: bool = False) -> bool:
    """Whether car c is in our lane, the one test every filter asks: its centre within our width plus
    margin_m of ours (the tutorial's lane, with OpponentParams.side_margin_m: the fixed-gap brake,
    following), or with half_widths, its side within margin_m of ours (half of both widths apart
    plus margin_m, its width ours when unknown: racecraft's touch of brake and wrecks,
    RacecraftParams.lane_m)."""
    reach_m = 0.5 * (width_m + (c.width_m or width_m)) if half_widths else width_m
    return abs(c.lateral_m) < reach_m + margin_m


def relate(cars: list[Nearby], width_m: float, side_margin_m: float, lane_m: float) -> list[Nearby]:
    """Set whether each car is in our lane by either definition (`in_lane` with side_margin_m, the
    tutorial's, and with lane_m and half widths, racecraft's), once a step on the cars as the
    filters see them (after racecraft's prediction); the cars, changed in place."""
    for c in cars:
        c.in_our_lane = in_lane(c, width_m, side_margin_m)
        c.sides_in_lane = in_lane(c, width_m, lane_m, half_widths=True)
    return cars


def side_steer(steer: float, cars: list[Nearby], length_m: float, width_m: float, steer_lock_rad: float,
               p: OpponentParams, gain_rad_per_m: float = 0.1) -> float:
    """Steer away from a car alongside that is closer than the side margin (gain_rad_per_m of
    steering per metre it is too close)."""
    for c in cars:
        if abs(c.dist_m) < length_m:  # alongside
            free = abs(c.lateral_m) - width_m
            if free < p.side_margin_m:
                push = (p.side_margin_m - free) * gain_rad_per_m / steer_lock_rad
                steer += -push if c.lateral_m > 0 else push
    return max(-1.0, min(1.0, steer))


def _too_close_to_cross(c: Nearby, my_speed_mps: float, p: OpponentParams) -> bool:
    """Whether we reach car c, already keep_side_lateral_m aside of it, within keep_side_s: too
    soon to cross behind it to its other side (e-track-1 at 240 m: 4.6 m right of a car in the
    track's middle, 14 m/s faster and 9 m behind, the tutorial's side was its left; boxbox steered
    across into it at 47 m/s)."""
    if p.keep_side_s <= 0.0 or abs(c.lateral_m) < p.keep_side_lateral_m:
        return False
    return c.gap_m < (my_speed_mps - c.speed_mps) * p.keep_side_s


def overtake_offset(offset_m: float, my_speed_mps: float, my_to_middle_m: float, cars: list[Nearby],
                    half_width_m: float, length_m: float, p: OpponentParams, alone_mps: float = 0.0) -> float:
    """Lateral offset added to the line: towards the free side of a slower car close ahead (slower
    than us, or with p.draft_mps, by that much slower than `alone_mps`, the speed we would go here
    alone: a car we follow at its speed holds us up too), aside for a lapping car close behind,
    else back towards zero."""
    target = None
    slower_than = max(my_speed_mps, alone_mps - p.draft_mps) if p.draft_mps > 0.0 else my_speed_mps
    for c in cars:
        if c.ahead and c.gap_m < max(2.0 * length_m, (my_speed_mps - c.speed_mps) * 2.0) \
                and c.speed_mps < slower_than:
            # pass on the side with more room: its position is my_to_middle + lateral
            other = my_to_middle_m + c.lateral_m
            target = -half_width_m if other > 0 else half_width_m
            if _too_close_to_cross(c, my_speed_mps, p) or (p.lapped_own_side and c.laps_ahead < 0):
                target = half_width_m if c.lateral_m < 0 else -half_width_m
            break
        if c.lapping and -4.0 * length_m < c.dist_m < 0:
            other = my_to_middle_m + c.lateral_m
            target = -half_width_m if other > 0 else half_width_m
    if target is None:
        target = 0.0
    step = p.overtake_step_m
    if offset_m < target:
        return min(target, offset_m + step)
    return max(target, offset_m - step)
