"""Gear selection by speed thresholds (the tutorial's gear-changing rule), precomputed per car."""

from __future__ import annotations

import math

from boxbox.model.car import Car

DEFAULT_SHIFT = 0.9  # shift at this fraction of the redline
DEFAULT_SHIFT_MARGIN_MPS = 4.0  # hysteresis so up- and down-shifts do not oscillate


class GearBox:
    """Speeds at which to leave each forward gear; `select` is two list lookups.

    The speed of gear g at the shift point is redline / ratio(g) * wheel radius * shift, with the
    rear wheel radius (the tutorial uses wheel 2, rear right). Ratios include the final drive.
    """

    def __init__(self, car: Car, shift: float = DEFAULT_SHIFT, shift_margin_mps: float = DEFAULT_SHIFT_MARGIN_MPS):
        self.top_gear = car.max_gear
        self.shift = shift
        self.shift_margin_mps = shift_margin_mps
        wheel_radius_m = car.wheel_radius_rr_m
        # index = gear; index 0 (neutral) is unused
        self.upshift_speed_mps: list[float] = [0.0] * (self.top_gear + 1)
        for gear in range(1, self.top_gear + 1):
            ratio = car.gear_ratio(gear)
            self.upshift_speed_mps[gear] = car.rpm_redline / ratio * wheel_radius_m * shift
        # shift down from gear g when the speed is below this (g - 1's shift speed minus the margin);
        # never from first gear to neutral
        self.downshift_speed_mps: list[float] = [-math.inf] * (self.top_gear + 1)
        for gear in range(2, self.top_gear + 1):
            self.downshift_speed_mps[gear] = self.upshift_speed_mps[gear - 1] - shift_margin_mps

    def select(self, gear: int, speed_mps: float) -> int:
        """The gear to use now, given the current gear (State.gear as it comes) and speed (m/s, along the car)."""
        gear = int(gear)
        if gear <= 0:  # neutral or reverse: start in first
            return 1
        if gear > self.top_gear:
            gear = self.top_gear
        if speed_mps > self.upshift_speed_mps[gear]:
            return gear + 1 if gear < self.top_gear else gear
        if speed_mps < self.downshift_speed_mps[gear]:
            return gear - 1
        return gear
