"""A minimal robot: follows the track middle at a speed it can hold in every turn.

Kept as the smallest complete example of the Robot interface (see docs/robots.md).
"""

from __future__ import annotations

import math

from boxbox.model import Car, Controls, State, Track
from boxbox.model.constants import G_MPS2 as G
from boxbox.robot.base import Robot


class MiddleRobot(Robot):
    """Steers at the middle line; speed limited by sqrt(mu g r) of the segment and the next one."""

    name = "middle"

    def on_track(self, track: Track, car: Car) -> None:
        super().on_track(track, car)
        seg = track.seg
        mu = min(car.mu_fr, car.mu_fl, car.mu_rr, car.mu_rl)
        limits = []
        for i in range(track.n_segments):
            r = float(seg["radius_m"][i]) if seg["type"][i] != 3 else math.inf
            limits.append(min(60.0, math.sqrt(mu * float(seg["friction"][i]) * G * r) * 0.9))
        n = len(limits)
        # slow down early: look two segments ahead
        self.speed_limit = [min(limits[i], limits[(i + 1) % n], limits[(i + 2) % n]) for i in range(n)]
        self.redline = car.rpm_redline
        self.ratios = car.gear_ratios
        self.top_gear = car.max_gear
        self.offset = car.gear_offset
        self.wheel_radius = car.wheel_radius_rr_m
        self.steer_lock = car.steer_lock_rad

    def drive(self, s: State) -> Controls:
        steer = (s.angle_rad - s.to_middle_m / 10.0) / self.steer_lock
        steer = max(-1.0, min(1.0, steer))
        target = self.speed_limit[int(s.seg_id)]
        v = s.speed_x_mps
        accel, brake = (1.0, 0.0) if v < target else (0.0, min(1.0, (v - target) / 5.0))
        gear = int(s.gear)
        if gear <= 0:
            gear = 1
        elif gear < self.top_gear:
            if self.redline / self.ratios[gear + self.offset] * self.wheel_radius * 0.9 < v:
                gear += 1
            elif gear > 1 and self.redline / self.ratios[gear + self.offset - 1] * self.wheel_radius * 0.9 > v + 4:
                gear -= 1
        clutch = 0.5 if s.sim_time_s < 0.5 else 0.0
        return Controls(steer=steer, accel=accel, brake=brake, clutch=clutch, gear=gear)
