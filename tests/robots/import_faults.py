"""A robot file whose import misbehaves as $IMPORT_FAULT says: exit0 (os._exit(0)), kill (SIGKILL
of itself), hang, or daemon (forks a child that lives on for 20 s); imports cleanly without it."""

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
if HOW == "daemon" and os.fork() == 0:
    time.sleep(20)
    os._exit(0)


class Mine(MiddleRobot):
    pass


class Other(MiddleRobot):
    pass
