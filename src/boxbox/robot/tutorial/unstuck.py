"""Getting unstuck: backing out when slow, sideways and off the middle, turned round and grinding,
or boxed in; braking blind while TORCS has lost the car's place."""

from __future__ import annotations

import math
from collections.abc import Callable

from boxbox.model import Controls, State
from boxbox.model.constants import DRIVE_STEP_S
from boxbox.robot.base import Robot
from boxbox.robot.opponents import nearby
from boxbox.robot.params import TutorialParams
from boxbox.robot.racecraft import Racecraft

REVERSE_MAX_S = 4.0  # longest time backing out in one go
REVERSE_MAX_MPS = 4.0  # no throttle in reverse beyond this speed
BACKWARDS_RAD = 0.5 * math.pi  # pointing further than this from the track's direction: turned round
GRINDING_S = 0.5  # damage this recent: still pushing into something
BOXED_MPS = 1.0  # backing out slower than this and grinding: boxed in (cars stopped front and back)
BOXED_HOLD_S = 1.0  # boxed in: held on the brakes this long before trying again
REVERSE_CLEAR_S = 3.0  # no backing while a car coming from behind would reach us within this


class Unstuck(Robot):
    """Backing out of a stuck position, boxed in, blind."""

    params: TutorialParams
    reversing: bool  # backing out now
    reverse_steps: int  # drive steps backed out so far
    _damage_seen: float  # the damage _grinding last saw
    _inv_lock: float  # 1 / the steering lock (rad)
    _stuck_angle: float  # TutorialParams.stuck_angle_deg in rad
    _heading_at: Callable[[float], float]  # the track's direction by distance (traffic.py)
    _backing_from_m: float | None  # where backing away from a wreck began (traffic.py)
    craft: Racecraft  # racecraft's wreck parameters (traffic.py)

    def _blind(self, s: State) -> Controls:
        """No place on the track to drive by: brake in the gear the car is in until TORCS finds it."""
        gear = int(s.gear) if s.gear == s.gear and 1 <= s.gear <= self.car.max_gear else 1
        return Controls(steer=0.0, accel=0.0, brake=1.0, clutch=0.0, gear=gear)

    def _back_out(self, s: State, v: float) -> Controls:
        """Reverse, steering the nose back towards the track's direction; held on the brakes while
        a car comes up from behind (the backing car is in its way)."""
        steer = max(-1.0, min(1.0, -s.angle_rad * self._inv_lock))
        self._backing_on_throttle = False
        if s.opponents and self._coming_from_behind(s):
            self.reverse_steps -= 1  # waiting is no time spent backing
            return Controls(steer=steer, accel=0.0, brake=1.0, clutch=0.0, gear=-1)
        # backing out is for turning round, not for speed: off the track it slid into walls at 11 m/s
        accel = 0.6 if v > -REVERSE_MAX_MPS else 0.0
        self._backing_on_throttle = accel > 0.0
        return Controls(steer=steer, accel=accel, brake=0.0, clutch=0.0, gear=-1)

    def _coming_from_behind(self, s: State) -> bool:
        """A moving car behind us that reaches us within REVERSE_CLEAR_S (e-track-2, 10 laps: boxbox
        backed off the grass at 3000 m into bt:2 and berniw:3 coming by, 242 damage)."""
        cars = nearby(s, self.car.length_m, self.track.length_m, self.params.back_range_m, 0.0, self._heading_at)
        return any(c.dist_m < 0.0 and c.speed_mps > REVERSE_MAX_MPS
                   and -c.dist_m < (c.speed_mps + REVERSE_MAX_MPS) * REVERSE_CLEAR_S for c in cars)

    def _stuck(self, s: State) -> bool:
        """Reverse out after stuck_time_s of being slow, sideways and off the middle; once backing,
        go on until the car points along the track again (at most REVERSE_MAX_S): a car that drives
        forward still sideways hits the same wall again (dirt-3 hit it six times in a row)."""
        p = self.params
        if self.reversing:
            self.reverse_steps += 1
            if self._reverse_done(s) or self.reverse_steps * DRIVE_STEP_S > REVERSE_MAX_S:
                self.reversing = False
                self.stuck_steps = 0
                self._backing_from_m = None
            return self.reversing
        grinding = self._grinding(s)
        sideways = s.speed_x_mps < p.stuck_speed_mps and abs(s.angle_rad) > self._stuck_angle \
            and abs(s.to_middle_m) > p.stuck_offset_m and s.angle_rad * s.to_middle_m < 0
        # turned round and pushing into something anywhere on the track (dirt-5: against a car
        # stopped behind it, boxbox took 10,000 damage at full throttle in the middle); turned
        # round alone, forward round the lock is quicker than backing (e-track-3).  At once: each
        # step costs damage (dirt-5: 1,400 in the 2 s of stuck_time_s against a car stopped there)
        turned_round = not sideways and abs(s.speed_x_mps) < p.stuck_speed_mps \
            and abs(s.angle_rad) > BACKWARDS_RAD and grinding
        self.stuck_steps = self.stuck_steps + 1 if sideways else 0
        if turned_round or self.stuck_steps * DRIVE_STEP_S > p.stuck_time_s:
            self.reversing = True
            self.reverse_steps = 0
        return self.reversing

    def _reverse_done(self, s: State) -> bool:
        """Backed out far enough: pointing along the track again, or away from a wreck; or boxed in
        (dirt-5: turned round between two stopped cars, backing from one into the other), then held
        on the brakes for BOXED_HOLD_S."""
        backing_s = self.reverse_steps * DRIVE_STEP_S
        pushing = self._backing_on_throttle and abs(s.speed_x_mps) < BOXED_MPS  # hit while waiting is not
        if self._grinding(s) and backing_s > GRINDING_S and pushing:
            self._hold_until_s = s.sim_time_s + BOXED_HOLD_S
            return True
        if self._backing_from_m is None:
            return abs(s.angle_rad) < 0.5 * self._stuck_angle
        half = 0.5 * self.track.length_m  # away from a wreck: far enough back to steer round it
        backed_m = (self._backing_from_m - s.dist_from_start_m + half) % self.track.length_m - half
        return backed_m > self.craft.p.blocked_back_lengths * self.car.length_m

    def _grinding(self, s: State) -> bool:
        """Whether the car took damage within the last GRINDING_S (called every step, so damage
        taken long ago is never new)."""
        if s.damage > self._damage_seen:
            self._damage_seen, self._grinding_until_s = s.damage, s.sim_time_s + GRINDING_S
        return s.sim_time_s < self._grinding_until_s
