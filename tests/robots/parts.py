"""A robot built from the parts docs/robots.md's table lists, each with its defaults: the speed
profile (`SpeedProfile.from_track(track, model)`), the steering law on the track's middle
(`steer_to_line`), the gear changing and the car model.  Full throttle under the profile's speed,
the brake in proportion above it.  tests/integration/test_parts_robot.py races it."""

from __future__ import annotations

from boxbox import Controls, Robot
from boxbox.control.carmodel import CarModel
from boxbox.control.gears import GearBox
from boxbox.control.speed import SpeedProfile
from boxbox.control.steering import steer_to_line

FULL_BRAKE_OVER_MPS = 5.0  # the brake reaches 1 this far above the profile's speed


class Parts(Robot):
    """The documented parts with their defaults, nothing tuned."""

    name = "parts"

    def on_track(self, track, car):
        super().on_track(track, car)
        self.curvature_1pm = track.curvature()
        self.wheelbase_m = car.front_axle_x_m - car.rear_axle_x_m
        self.speeds = SpeedProfile.from_track(track, CarModel.from_car(car))
        self.gears = GearBox(car)

    def drive(self, state):
        steer = steer_to_line(state.angle_rad, -state.to_middle_m, self.curvature_1pm[int(state.seg_id)],
                              state.speed_x_mps, state.yaw_rate_rps, self.wheelbase_m, self.car.steer_lock_rad)
        over_mps = state.speed_x_mps - self.speeds.speed_at(state.dist_from_start_m)  # + too fast
        return Controls(steer=steer, accel=1.0 if over_mps < 0.0 else 0.0,
                        brake=min(1.0, max(0.0, over_mps / FULL_BRAKE_OVER_MPS)), clutch=0.0,
                        gear=self.gears.select(state.gear, state.speed_x_mps))
