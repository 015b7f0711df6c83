"""boxbox: write TORCS robot drivers in Python and race them in the real TORCS.

    from boxbox import Robot, Controls

    class MyRobot(Robot):
        def drive(self, state):
            return Controls(steer=state.angle_rad / self.car.steer_lock_rad, accel=0.5, gear=1)

Race it with `boxbox race --robot my_robot.py:MyRobot`.
"""

from boxbox.errors import UsageError
from boxbox.model import Car, CarSetup, Controls, Opponent, PitOrder, State, Track
from boxbox.robot.base import RaceOptions, Robot

__version__ = "0.1.0"
__all__ = ["Car", "CarSetup", "Controls", "Opponent", "PitEvent", "PitOrder", "PitParams", "PitStops", "RaceOptions",
           "RaceResult", "Robot", "State", "Track", "UsageError", "race"]


def __getattr__(name: str):  # these load the racing side only when used
    if name in ("race", "RaceResult"):
        from boxbox import api

        return getattr(api, name)
    if name in ("PitStops", "PitEvent", "PitParams"):
        from boxbox.robot import pit

        return getattr(pit, name)
    raise AttributeError(f"module 'boxbox' has no attribute {name!r}")
