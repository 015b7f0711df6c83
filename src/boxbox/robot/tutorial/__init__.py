"""The default boxbox robot, `TutorialRobot`: the TORCS tutorial robot rebuilt from boxbox's
controllers, a file per concern (like bt's robot):

- `robot.py`: the robot, its hooks and its `drive` chain (steer, speed, the pit stop, then each
  filter in turn);
- `plan.py`: the plan of a track (racing line, speed profile, caps, car setup, start fuel, pit part);
- `traffic.py`: other cars near (the overtaking offset, the brakes for a car ahead, wrecks);
- `slip.py`: wheel slip (ABS, traction control, the throttle guards);
- getting unstuck is the part any robot can use: `Unstuck` (robot/unstuck.py).
"""

from boxbox.robot.tutorial.robot import TutorialRobot
from boxbox.robot.tutorial.traffic import OFFSET_ROOM_AHEAD_M, PIT_PHASE_CODES

__all__ = ["OFFSET_ROOM_AHEAD_M", "PIT_PHASE_CODES", "TutorialRobot"]
