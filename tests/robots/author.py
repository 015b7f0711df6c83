"""Robots that make a robot author's mistakes, one each, for tests/integration/test_robot_faults.py."""

from __future__ import annotations

import os
import sys
import time

from boxbox.robot.simple import MiddleRobot

BIG_LINE = "x" * 100_000  # 100 kB


class ForksInOnTrack(MiddleRobot):
    """os.fork() in on_track, the child left running on as the robot host's copy."""

    def on_track(self, track, car):
        super().on_track(track, car)
        os.fork()


class ForksAWorker(MiddleRobot):
    """os.fork() in on_track, the child working (sleeping) for a minute."""

    def on_track(self, track, car):
        super().on_track(track, car)
        if os.fork() == 0:
            time.sleep(60)
            os._exit(0)


class FillsTheTank(MiddleRobot):
    def initial_fuel_l(self, track, car):
        return 1e9


class NeverStops(MiddleRobot):
    """Ignores --pit-laps: never asks TORCS for a stop."""


class PrintsALot(MiddleRobot):
    """Prints 100 kB every step of its first simulated second (on stdout, on stderr and straight to
    the file descriptor), and a last line at the end."""

    def drive(self, state):
        if 0.0 < state.sim_time_s < 1.0:
            print("step", BIG_LINE)
            print("err", BIG_LINE, file=sys.stderr)
            os.write(1, b"fd " + BIG_LINE.encode() + b"\n")
        return super().drive(state)

    def on_race_end(self, state):
        print("last words of the robot", flush=True)
