"""boxbox: write TORCS robot drivers in Python and race them in the real TORCS.

    from boxbox import Robot, Controls

    class MyRobot(Robot):
        def drive(self, state):
            return Controls(steer=state.angle_rad / self.car.steer_lock_rad, accel=0.5, gear=1)

Race it with `boxbox race --robot my_robot.py:MyRobot`.
"""

import importlib
from typing import TYPE_CHECKING, Any

from boxbox.errors import UsageError

if TYPE_CHECKING:  # what a type checker sees; at run time each name loads when first used (below)
    from boxbox.api import RaceResult, race
    from boxbox.model import Car, CarSetup, Controls, Opponent, PitOrder, State, Track
    from boxbox.robot.base import RaceOptions, Robot
    from boxbox.robot.pit import PitEvent, PitParams, PitStops
    from boxbox.robot.unstuck import Unstuck, UnstuckParams

__version__ = "0.1.0"
__all__ = ["Car", "CarSetup", "Controls", "Opponent", "PitEvent", "PitOrder", "PitParams", "PitStops", "RaceOptions",
           "RaceResult", "Robot", "State", "Track", "Unstuck", "UnstuckParams", "UsageError", "race"]
# each public name's module: `import boxbox` (and so the command line, `boxbox --help`) loads none
# of them, nor numpy under them (about 0.5 s); `from boxbox import Robot` loads what Robot needs
_HOMES = {**dict.fromkeys(("Car", "CarSetup", "Controls", "Opponent", "PitOrder", "State", "Track"), "boxbox.model"),
          "RaceOptions": "boxbox.robot.base", "Robot": "boxbox.robot.base", "race": "boxbox.api",
          "RaceResult": "boxbox.api", **dict.fromkeys(("PitEvent", "PitParams", "PitStops"), "boxbox.robot.pit"),
          **dict.fromkeys(("Unstuck", "UnstuckParams"), "boxbox.robot.unstuck")}


def __getattr__(name: str) -> Any:
    if name in _HOMES:
        value = getattr(importlib.import_module(_HOMES[name]), name)
        globals()[name] = value  # found here from now on, without this call
        return value
    raise AttributeError(f"module 'boxbox' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
