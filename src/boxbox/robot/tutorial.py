"""The default boxbox robot (the TORCS tutorial robot); for now the middle-line robot."""

from boxbox.robot.simple import MiddleRobot


class TutorialRobot(MiddleRobot):
    name = "boxbox"
