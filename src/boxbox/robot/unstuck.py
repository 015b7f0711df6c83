"""Getting unstuck, for any robot: backing out of a wall, waiting for a car coming from behind,
held on the brakes when boxed in, braking blind while TORCS has lost the car's place.

A robot asks the part first, every drive step; it answers Controls while the car is stuck (and
backing out), None while the robot should drive on:

    class MyRobot(Robot):
        def on_track(self, track, car):
            super().on_track(track, car)
            self.unstuck = Unstuck(track, car)

        def drive(self, state):
            backing = self.unstuck.step(state)
            if backing is not None:
                return backing
            return my_controls(state)

Stuck is slow, sideways, off the middle and pointing to the near edge for `UnstuckParams.time_s`
(a car that drives forward from there hits the same wall again), or turned round and taking
damage (at once: each step costs damage).  The car then backs out, the nose steered back to the
track's direction, until it points along the track again (at most REVERSE_MAX_S).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from boxbox.model import Car, Controls, State, Track
from boxbox.model.constants import DRIVE_STEP_S
from boxbox.robot.opponents import OpponentParams, nearby
from boxbox.robot.racingline import middle_line

REVERSE_MAX_S = 4.0  # longest time backing out in one go
REVERSE_MAX_MPS = 4.0  # no throttle in reverse beyond this speed
REVERSE_ACCEL = 0.6  # throttle while backing out
BACKWARDS_RAD = 0.5 * math.pi  # pointing further than this from the track's direction: turned round
GRINDING_S = 0.5  # damage this recent: still pushing into something
BOXED_MPS = 1.0  # backing out slower than this and grinding: boxed in (cars stopped front and back)
BOXED_HOLD_S = 1.0  # boxed in: held on the brakes this long before trying again
REVERSE_CLEAR_S = 3.0  # no backing while a car coming from behind would reach us within this


@dataclass(frozen=True)
class UnstuckParams:
    """When the car counts as stuck: the defaults for any robot, and of the tutorial robot's
    stuck_* parameters (robot/params.py reads them here: change one here and both follow)."""

    angle_deg: float = 30.0  # pointing further than this from the track's direction ...
    speed_mps: float = 5.0  # ... slower than this ...
    offset_m: float = 3.0  # ... further than this from the middle, towards the near edge ...
    time_s: float = 2.0  # ... for longer than this: stuck
    back_range_m: float = OpponentParams.back_range_m  # cars this far behind are watched for while backing


def middle_heading(track: Track) -> Callable[[float], float]:
    """The track's direction (rad) at a distance from the start, from its middle line every 2 m."""
    mid = middle_line(track)
    headings = mid.heading_rad.tolist()
    n = len(headings) - 1
    step_m = track.length_m / n
    return lambda dist_m: headings[int(dist_m / step_m) % n]


class Unstuck:
    """Backing out of a stuck position, boxed in, blind: `step` every drive step."""

    def __init__(self, track: Track, car: Car, params: UnstuckParams | None = None,
                 heading_at: Callable[[float], float] | None = None) -> None:
        """heading_at(dist_m) -> the track's direction there (rad), for the cars behind (a robot
        with its own line passes its own; by default the middle line's)."""
        self.track, self.car = track, car
        self.params = params or UnstuckParams()
        self._heading_at = heading_at or middle_heading(track)
        self._inv_lock = 1.0 / car.steer_lock_rad
        self._stuck_angle = math.radians(self.params.angle_deg)
        self.stuck_steps = 0  # drive steps stuck in a row
        self.reversing = False  # backing out now
        self.reverse_steps = 0  # drive steps backed out so far
        self.hold_until_s = -math.inf  # boxed in: on the brakes until then
        self._damage_seen, self._grinding_until_s = 0.0, -math.inf  # for grinding()
        self._backing_on_throttle = False  # the last backing step gave throttle (not waiting for a car)
        self._backing_from_m: float | None = None  # backing away from a wreck: from here ...
        self._back_m = 0.0  # ... this far

    def step(self, s: State) -> Controls | None:
        """The controls that get the car unstuck, or None: not stuck, drive on."""
        if s.dist_from_start_m != s.dist_from_start_m:  # NaN: TORCS lost the car's place (a pile-up)
            return self.blind(s)
        if s.sim_time_s < self.hold_until_s:  # boxed in: pushing either way only takes damage
            self._damage_seen = s.damage  # what hits us meanwhile is no reason to back out after
            return self.blind(s)
        if self._stuck(s):
            return self._back_out(s)
        return None

    def blind(self, s: State) -> Controls:
        """No place on the track to drive by: brake in the gear the car is in until TORCS finds it."""
        gear = int(s.gear) if s.gear == s.gear and 1 <= s.gear <= self.car.max_gear else 1
        return Controls(steer=0.0, accel=0.0, brake=1.0, clutch=0.0, gear=gear)

    def back_away(self, s: State, back_m: float) -> None:
        """Back out from the next step on until back_m behind where the car is now (away from a
        stopped car in its way that it cannot steer round from where it stands)."""
        self.reversing, self.reverse_steps = True, 0
        self._backing_from_m, self._back_m = s.dist_from_start_m, back_m

    def grinding(self, s: State) -> bool:
        """Whether the car took damage within the last GRINDING_S (called every step, so damage
        taken long ago is never new)."""
        if s.damage > self._damage_seen:
            self._damage_seen, self._grinding_until_s = s.damage, s.sim_time_s + GRINDING_S
        return s.sim_time_s < self._grinding_until_s

    def _back_out(self, s: State) -> Controls:
        """Reverse, steering the nose back towards the track's direction; held on the brakes while
        a car comes up from behind (the backing car is in its way)."""
        steer = max(-1.0, min(1.0, -s.angle_rad * self._inv_lock))
        self._backing_on_throttle = False
        if s.opponents and self._coming_from_behind(s):
            self.reverse_steps -= 1  # waiting is no time spent backing
            return Controls(steer=steer, accel=0.0, brake=1.0, clutch=0.0, gear=-1)
        # backing out is for turning round, not for speed: off the track it slid into walls at 11 m/s
        accel = REVERSE_ACCEL if s.speed_x_mps > -REVERSE_MAX_MPS else 0.0
        self._backing_on_throttle = accel > 0.0
        return Controls(steer=steer, accel=accel, brake=0.0, clutch=0.0, gear=-1)

    def _coming_from_behind(self, s: State) -> bool:
        """A moving car behind us that reaches us within REVERSE_CLEAR_S (e-track-2, 10 laps: boxbox
        backed off the grass at 3000 m into bt:2 and berniw:3 coming by, 242 damage)."""
        cars = nearby(s, self.car.length_m, self.track.length_m, self.params.back_range_m, 0.0, self._heading_at)
        return any(c.dist_m < 0.0 and c.speed_mps > REVERSE_MAX_MPS
                   and -c.dist_m < (c.speed_mps + REVERSE_MAX_MPS) * REVERSE_CLEAR_S for c in cars)

    def _stuck(self, s: State) -> bool:
        """Reverse out after time_s of being slow, sideways and off the middle; once backing, go on
        until the car points along the track again (at most REVERSE_MAX_S): a car that drives
        forward still sideways hits the same wall again (dirt-3 hit it six times in a row)."""
        p = self.params
        if self.reversing:
            self.reverse_steps += 1
            if self._reverse_done(s) or self.reverse_steps * DRIVE_STEP_S > REVERSE_MAX_S:
                self.reversing = False
                self.stuck_steps = 0
                self._backing_from_m = None
            return self.reversing
        grinding = self.grinding(s)
        sideways = s.speed_x_mps < p.speed_mps and abs(s.angle_rad) > self._stuck_angle \
            and abs(s.to_middle_m) > p.offset_m and s.angle_rad * s.to_middle_m < 0
        # turned round and pushing into something anywhere on the track (dirt-5: against a car
        # stopped behind it, boxbox took 10,000 damage at full throttle in the middle); turned
        # round alone, forward round the lock is quicker than backing (e-track-3).  At once: each
        # step costs damage (dirt-5: 1,400 in the 2 s of time_s against a car stopped there)
        turned_round = not sideways and abs(s.speed_x_mps) < p.speed_mps \
            and abs(s.angle_rad) > BACKWARDS_RAD and grinding
        self.stuck_steps = self.stuck_steps + 1 if sideways else 0
        if turned_round or self.stuck_steps * DRIVE_STEP_S > p.time_s:
            self.reversing = True
            self.reverse_steps = 0
        return self.reversing

    def _reverse_done(self, s: State) -> bool:
        """Backed out far enough: pointing along the track again, or away from a wreck; or boxed in
        (dirt-5: turned round between two stopped cars, backing from one into the other), then held
        on the brakes for BOXED_HOLD_S."""
        backing_s = self.reverse_steps * DRIVE_STEP_S
        pushing = self._backing_on_throttle and abs(s.speed_x_mps) < BOXED_MPS  # hit while waiting is not
        if self.grinding(s) and backing_s > GRINDING_S and pushing:
            self.hold_until_s = s.sim_time_s + BOXED_HOLD_S
            return True
        if self._backing_from_m is None:
            return abs(s.angle_rad) < 0.5 * self._stuck_angle
        half = 0.5 * self.track.length_m  # away from a wreck: far enough back to steer round it
        backed_m = (self._backing_from_m - s.dist_from_start_m + half) % self.track.length_m - half
        return backed_m > self._back_m
