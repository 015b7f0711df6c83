"""The default boxbox robot, `TutorialRobot`: the TORCS tutorial robot rebuilt from boxbox's
controllers, a file per concern (like bt's robot):

- `robot.py`: the robot, its hooks and its `drive` chain (steer, speed, the pit stop, then each
  filter in turn);
- `plan.py`: the plan of a track (racing line, speed profile, caps, car setup, start fuel, pit part);
- `traffic.py`: other cars near (the overtaking offset, the brakes for a car ahead, wrecks);
- `unstuck.py`: getting unstuck (backing out, boxed in, blind);
- `slip.py`: wheel slip (ABS, traction control, the throttle guards).
"""

from boxbox.robot.tutorial.robot import TutorialRobot
from boxbox.robot.tutorial.traffic import OFFSET_ROOM_AHEAD_M, PIT_PHASE_CODES
from boxbox.robot.tutorial.unstuck import BOXED_HOLD_S

__all__ = ["BOXED_HOLD_S", "OFFSET_ROOM_AHEAD_M", "PIT_PHASE_CODES", "TutorialRobot"]
