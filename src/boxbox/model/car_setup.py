"""The car setup a robot chooses before the car is built: wings, gears, brakes, suspension, the
differential.  SI units; None keeps the car's own value."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

# a field name -> (lowest, highest) value the car allows, in the field's units (torcs/car_setup.py
# reads them from the car's files); the gears' as gear_ratio_1, gear_ratio_2, ...
Ranges = dict[str, tuple[float, float]]
FORWARD_GEARS_MAX = 8  # forward gears TORCS 1.3.7 can have (its MAX_GEARS of 10 less reverse and neutral)
# each gear's ratio as a setting of its own (--set gear_ratio_2=2.1, a study's parameter)
GEAR_SETTINGS = tuple(f"gear_ratio_{i}" for i in range(1, FORWARD_GEARS_MAX + 1))
GEARS_EXAMPLE = "gear_ratios=3.0,2.1,1.6 (from first gear on) or gear_ratio_2=2.1 (one gear)"
# a setting's unit, by how its name ends (none of these: a ratio or a share, no unit)
UNITS = (("_rad", "rad"), ("_nspm", "N s/m"), ("_npm", "N/m"), ("_nm", "N m"), ("_pa", "Pa"), ("_m", "m"))
# a setting's group, by a word in its name (the first that matches; CarSetup's fields come in these groups)
GROUPS = (("wing", "wings"), ("gear", "gearbox"), ("final_drive", "gearbox"), ("diff", "differential"),
          ("brake", "brakes"), ("anti_roll", "anti-roll bars"), ("spring", "springs"), ("bump", "dampers"),
          ("rebound", "dampers"), ("ride_height", "ride height"))


@dataclass(frozen=True, slots=True)
class CarSetup:
    """Car parameters a robot sets once per race, before the car is built (TORCS merges them over
    the car's file, like a C++ robot's setup file).  None keeps the car's own value.  Front and rear
    values apply to both wheels of the axle."""

    front_wing_angle_rad: float | None = None
    rear_wing_angle_rad: float | None = None
    # the gearbox's forward ratios from first gear on (engine turns per turn of the gearbox's output,
    # without the final drive); fewer than the car has, or None in a gear's place, keeps the car's
    gear_ratios: tuple[float | None, ...] | None = None
    final_drive_ratio: float | None = None  # the driven differential's ratio (rear: RWD, front: FWD, central: 4WD)
    # the driven differential (limited slip): the largest share of the speed difference between
    # its two sides, and the input torque (driving, braking) at which it locks
    diff_max_slip_bias: float | None = None
    diff_locking_torque_nm: float | None = None
    diff_locking_brake_torque_nm: float | None = None
    brake_front_share: float | None = None  # the brake pressure's share on the front wheels
    brake_pressure_max_pa: float | None = None  # the pressure of a full brake
    front_spring_npm: float | None = None
    rear_spring_npm: float | None = None
    # the dampers: slow (under the threshold speed) and fast rates, bump and rebound
    front_slow_bump_nspm: float | None = None
    front_slow_rebound_nspm: float | None = None
    front_fast_bump_nspm: float | None = None
    front_fast_rebound_nspm: float | None = None
    rear_slow_bump_nspm: float | None = None
    rear_slow_rebound_nspm: float | None = None
    rear_fast_bump_nspm: float | None = None
    rear_fast_rebound_nspm: float | None = None
    front_anti_roll_npm: float | None = None  # the anti-roll bar's spring
    rear_anti_roll_npm: float | None = None
    front_ride_height_m: float | None = None
    rear_ride_height_m: float | None = None

    def values(self) -> dict[str, float]:
        """The values set, by range name (the gears as gear_ratio_1, gear_ratio_2, ...)."""
        out: dict[str, float] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "gear_ratios" and isinstance(value, tuple | list):
                out.update({f"gear_ratio_{i}": v for i, v in enumerate(value, start=1) if v is not None})
            elif value is not None:
                out[f.name] = value
        return out

    def problem(self, ranges: Ranges | None = None, car: str = "the car") -> str | None:
        """What is wrong with this setup, or None: a value that is no finite number, a wing angle
        outside 0..pi/2, and with `ranges` a value outside the car's range or one it cannot set."""
        if self.gear_ratios is not None and not isinstance(self.gear_ratios, tuple | list):
            return f"gear_ratios must be numbers from first gear on, got {self.gear_ratios!r}: {GEARS_EXAMPLE}"
        for name, value in self.values().items():
            if not isinstance(value, int | float) or isinstance(value, bool):
                return f"{name} must be a number or None, got {type(value).__name__}"
            if not math.isfinite(value):
                return f"{name}={value} must be a finite number"
            if name.endswith("_wing_angle_rad") and not 0.0 <= value <= math.pi / 2:
                return f"{name}={value} must be from 0 to pi/2"
            if ranges is None:
                continue
            if name not in ranges:
                return f"{name}: {car} has no such setting"
            lo, hi = ranges[name]
            if not lo <= value <= hi:
                return f"{name}={value:g} is outside {car}'s range {lo:g} to {hi:g}"
        return None


SCALAR_NAMES = tuple(f.name for f in dataclasses.fields(CarSetup) if f.name != "gear_ratios")
# every name of the car setup a race's settings may hold (--set, setup files, a study's parameters)
SETTING_NAMES = (*SCALAR_NAMES, "gear_ratios", *GEAR_SETTINGS)


def gear_ratios_of(value: Any) -> Any:
    """A gear_ratios setting as a tuple: from numbers separated by commas ("3.0,2.1,1.6", as --set
    gives it), a TOML array or one number; anything else as it came (CarSetup.problem names it)."""
    if isinstance(value, str):
        try:
            return tuple(float(part) for part in value.split(","))
        except ValueError:
            return value
    if isinstance(value, int | float) and not isinstance(value, bool):
        return (value,)
    return tuple(value) if isinstance(value, list | tuple) else value


def setup_from(values: dict[str, Any], base: CarSetup | None = None) -> CarSetup:
    """base (none: the car's own) with the car setup's settings of `values` set over it: the scalar
    fields, gear_ratios (all the gears from first gear on, in place of base's), then each
    gear_ratio_N (that gear alone, over the others)."""
    setup = base or CarSetup()
    changes: dict[str, Any] = {k: v for k, v in values.items() if k in SCALAR_NAMES}
    ratios = gear_ratios_of(values["gear_ratios"]) if "gear_ratios" in values else setup.gear_ratios
    gears = {GEAR_SETTINGS.index(k): v for k, v in values.items() if k in GEAR_SETTINGS}
    if gears and (ratios is None or isinstance(ratios, tuple | list)):  # a robot's answer may hold a list
        merged = list(ratios or ()) + [None] * (max(gears) + 1 - len(ratios or ()))
        for index, value in gears.items():
            merged[index] = value
        ratios = tuple(merged)
    if ratios is not setup.gear_ratios:
        changes["gear_ratios"] = ratios
    return dataclasses.replace(setup, **changes)


def unit_of(name: str) -> str:
    """The unit of setting `name` (CarSetup's field or a gear_ratio_N), "" for a ratio or a share."""
    return next((unit for end, unit in UNITS if name.endswith(end)), "")


def group_of(name: str) -> str:
    """What part of the car setting `name` sets (wings, gearbox, ..., ride height)."""
    return next(group for word, group in GROUPS if word in name)
