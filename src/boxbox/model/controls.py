"""What a robot answers: the driving controls each step, the pit order at a stop."""

from __future__ import annotations

import math
from dataclasses import dataclass

# a control this far outside its range is float rounding, not a robot's mistake: steer computed as
# 1 + 1e-12 from a sum of terms stopped the race; it is set to the bound, and what is further out
# is refused (the same rule for steer, accel, brake and clutch)
ROUNDING = 1e-9


@dataclass(slots=True)
class Controls:
    """One drive step's commands.  Ranges are checked by the host; out of range is a robot fault."""

    steer: float = 0.0  # [-1, 1], + turns left; 1 = full steer lock
    accel: float = 0.0  # [0, 1]
    brake: float = 0.0  # [0, 1]
    clutch: float = 0.0  # [0, 1], 1 = fully disengaged
    gear: int = 1  # -1 reverse, 0 neutral, 1.. forward
    pit_request: bool = False  # ask the race engine for a pit stop

    def problem(self, max_gear: int) -> str | None:
        """Why these controls are invalid, or None when they are fine (a value within ROUNDING of
        its range is set to the bound it passed)."""
        try:  # fast path: one chained comparison per field (NaN fails every comparison)
            if (-1.0 <= self.steer <= 1.0 and 0.0 <= self.accel <= 1.0 and 0.0 <= self.brake <= 1.0
                    and 0.0 <= self.clutch <= 1.0 and type(self.gear) is int and -1 <= self.gear <= max_gear
                    and type(self.steer) is not bool):
                return None
        except (TypeError, ValueError):
            pass
        self._plain_numbers()
        for name, lo in (("steer", -1.0), ("accel", 0.0), ("brake", 0.0), ("clutch", 0.0)):
            value = getattr(self, name)
            if type(value) in (float, int) and lo - ROUNDING <= value <= 1.0 + ROUNDING:
                value = min(max(value, lo), 1.0)  # a rounding's worth outside its range: at the bound
                setattr(self, name, value)
            if type(value) not in (float, int) or not lo <= value <= 1.0:
                if isinstance(value, (float, int)) and not isinstance(value, bool):
                    if math.isnan(value) or math.isinf(value):
                        return f"{name} is {value}"
                    return f"{name}={value} is outside [{lo:g}, 1]"
                return f"{name} must be a number, got {type(value).__name__}"
        if type(self.gear) is not int or not -1 <= self.gear <= max_gear:
            return f"gear={self.gear!r} must be a whole number in [-1, {max_gear}]"
        return None

    def _plain_numbers(self) -> None:
        """numpy scalars and 0-d arrays as Python numbers, and a whole-number float gear (as
        State.gear arrives) as an int: the off-the-fast-path cases that are still fine."""
        for name in ("steer", "accel", "brake", "clutch"):
            value = getattr(self, name)
            if type(value) not in (float, int, bool) and hasattr(value, "__float__") and getattr(value, "ndim", 0) == 0:
                try:
                    setattr(self, name, float(value))
                except (TypeError, ValueError):
                    pass
        gear = self.gear
        if type(gear) is not int and not isinstance(gear, bool) and hasattr(gear, "__float__") \
                and getattr(gear, "ndim", 0) == 0:
            try:
                number = float(gear)
            except (TypeError, ValueError):
                return
            if number.is_integer():
                self.gear = int(number)


@dataclass(slots=True)
class PitOrder:
    """What to do at a pit stop: litres to add and damage points to repair."""

    fuel_l: float = 0.0  # fuel to add
    repair: float = 0.0  # damage points to repair

    def problem(self) -> str | None:
        for name in ("fuel_l", "repair"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                return f"{name} must be a number, got {type(value).__name__}"
            if not 0.0 <= value < math.inf:
                return f"{name}={value} must be finite and >= 0"
        return None
