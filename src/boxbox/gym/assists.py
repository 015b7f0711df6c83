"""Driving assists: the shipped robot's pieces applied to the learner's controls.

`gears`: the gear chosen by speed (control/gears.py); `abs` and `tcl`: brake and throttle cut
by wheel slip (control/traction.py).  Applied every drive step, also within an action repeat.
"""

from __future__ import annotations

from boxbox.control.gears import GearBox
from boxbox.control.traction import abs_filter, tcl_filter
from boxbox.errors import UsageError
from boxbox.model import Car, State

ASSISTS = ("gears", "abs", "tcl")


def check_assists(assists: tuple[str, ...], actions: tuple[str, ...]) -> None:
    unknown = [a for a in assists if a not in ASSISTS]
    if unknown:
        raise UsageError(f"unknown assist {unknown[0]!r}; choose from {', '.join(ASSISTS)}")
    if "gears" in assists and "gear" in actions:
        raise UsageError("the gear is either an action or the 'gears' assist, not both")
    if "gears" not in assists and "gear" not in actions:
        raise UsageError("the car needs a gear: add 'gear' to actions or 'gears' to assists")


class Assists:
    def __init__(self, names: tuple[str, ...], car: Car) -> None:
        self.gearbox = GearBox(car) if "gears" in names else None
        self.abs = "abs" in names
        self.tcl = "tcl" in names
        self.radii = (car.wheel_radius_fr_m, car.wheel_radius_fl_m, car.wheel_radius_rr_m, car.wheel_radius_rl_m)
        self.drivetrain = car.drivetrain
        self.top_gear = car.max_gear

    def apply(self, s: State, throttle: float, brake: float, gear: int) -> tuple[float, float, int]:
        """(throttle, brake, gear) after the assists."""
        v = s.speed_x_mps
        if self.gearbox is not None:
            gear = self.gearbox.select(int(s.gear), v)
        elif gear > self.top_gear:
            gear = self.top_gear
        if self.abs or self.tcl:
            spins = (s.spin_fr_rps, s.spin_fl_rps, s.spin_rr_rps, s.spin_rl_rps)
            if self.abs and brake > 0.0:
                brake = abs_filter(brake, v, spins, self.radii)
            if self.tcl and throttle > 0.0:
                throttle = tcl_filter(throttle, v, spins, self.radii, self.drivetrain)
        return throttle, brake, gear
