"""A robot file whose import misbehaves as $IMPORT_FAULT says: exit0 (os._exit(0)), kill (SIGKILL
of itself) or hang; imports cleanly without it."""

import os
import signal
import time

from boxbox.robot.simple import MiddleRobot

HOW = os.environ.get("IMPORT_FAULT")
if HOW == "exit0":
    os._exit(0)
if HOW == "kill":
    os.kill(os.getpid(), signal.SIGKILL)
if HOW == "hang":
    time.sleep(600)


class Mine(MiddleRobot):
    pass


class Other(MiddleRobot):
    pass
