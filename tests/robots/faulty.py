"""Robots that misbehave on purpose, one way each, for the fault tests."""

import os
import signal
import time
from pathlib import Path

from boxbox import Controls, PitOrder, Robot
from boxbox.robot.simple import MiddleRobot
from boxbox.robot.tutorial import TutorialRobot

FAULT_STEP = 100  # 2 s into the race


class RaisesInDrive(MiddleRobot):
    def drive(self, state):
        if state.sim_time_s > 1.0:
            raise ValueError("deliberate failure in drive")
        return super().drive(state)


class RaisesAHugeMessage(MiddleRobot):
    """A 20 MB exception message (a robot dumping its state into one): bounded wherever it is said."""

    def drive(self, state):
        if state.sim_time_s > 1.0:
            print("the robot's last words", flush=True)
            raise ValueError("x" * 20_000_000)
        return super().drive(state)


class ClosesItsDescriptors(MiddleRobot):
    """Closes every file descriptor it did not open, the bridge's socket among them."""

    def drive(self, state):
        if state.sim_time_s > 1.0:
            os.closerange(3, 4096)
        return super().drive(state)


class RaisesInOnTrack(MiddleRobot):
    def on_track(self, track, car):
        raise RuntimeError("deliberate failure in on_track")


class RaisesInInit(MiddleRobot):
    def __init__(self, options=None):
        raise RuntimeError("deliberate failure in __init__")


class RaisesInPitStop(MiddleRobot):
    """Asks for a stop right away; fails when TORCS calls pit_stop."""

    def drive(self, state):
        c = super().drive(state)
        c.pit_request = True
        return c

    def pit_stop(self, state):
        raise KeyError("deliberate failure in pit_stop")


class HangsForever(MiddleRobot):
    def drive(self, state):
        if state.sim_time_s > 1.0:
            while True:
                time.sleep(1)
        return super().drive(state)


class SleepsOnce(MiddleRobot):
    slept = False

    def drive(self, state):
        if state.sim_time_s > 1.0 and not self.slept:
            self.slept = True
            time.sleep(1.0)
        return super().drive(state)


class KillsItself(MiddleRobot):
    def drive(self, state):
        if state.sim_time_s > 1.0:
            os.kill(os.getpid(), signal.SIGKILL)
        return super().drive(state)


class ReturnsNaN(MiddleRobot):
    def drive(self, state):
        c = super().drive(state)
        if state.sim_time_s > 1.0:
            c.steer = float("nan")
        return c


class ReturnsInfinity(MiddleRobot):
    def drive(self, state):
        c = super().drive(state)
        if state.sim_time_s > 1.0:
            c.accel = float("inf")
        return c


class ReturnsOutOfRange(MiddleRobot):
    def drive(self, state):
        c = super().drive(state)
        if state.sim_time_s > 1.0:
            c.brake = 1.5
        return c


class ReturnsWrongType(MiddleRobot):
    def drive(self, state):
        if state.sim_time_s > 1.0:
            return {"steer": 0.0}
        return super().drive(state)


class ReturnsBadPitOrder(RaisesInPitStop):
    def pit_stop(self, state):
        return PitOrder(fuel_l=float("nan"))


class NotARobot:
    pass


class Plain(Robot):
    """The smallest robot: straight ahead in first gear."""

    def drive(self, state):
        return Controls(steer=0.0, accel=0.3, brake=0.0, clutch=0.0, gear=1)


class TutorialRaisesInPitStop(TutorialRobot):
    """The tutorial robot, stopping as asked (--pit-laps), but failing when TORCS calls pit_stop."""

    def pit_stop(self, state):
        raise KeyError("deliberate failure in pit_stop")


class TutorialBadPitOrder(TutorialRobot):
    def pit_stop(self, state):
        return PitOrder(fuel_l=float("nan"))


class OvershootsTheBoxOnce(TutorialRobot):
    """Stands in for a car pushed past its box: on the first stop attempt it keeps rolling at
    8 m/s through the box as if shoved, so the pit brake filter must give up and retry next lap."""

    pushed = False
    pushing = False

    def drive(self, state):
        c = super().drive(state)
        path = self.pits.path
        if path is not None and not self.pushed:
            rel = path.signed_coord(state.dist_from_start_m) - path.box_m
            if self.pits.wanted and -10.0 < rel < 15.0 and not state.in_pit:
                self.pushing = True
                return Controls(steer=c.steer, accel=0.3 if state.speed_x_mps < 8.0 else 0.0, brake=0.0,
                                clutch=0.0, gear=max(1, c.gear), pit_request=True)
            self.pushed = self.pushing
        return c


class HangsInOnTrack(MiddleRobot):
    def on_track(self, track, car):
        while True:
            time.sleep(1)


def torcs_pid() -> int:
    """The TORCS process of this race: the host is its sibling and names the race's folder in
    BOXBOX_RUN_DIR; TORCS runs `-r RUN_DIR/race.xml`."""
    race_file = str(Path(os.environ["BOXBOX_RUN_DIR"]) / "race.xml")
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            args = Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace").split("\0")
        except OSError:
            continue
        if race_file in args and any(a.endswith("torcs-bin") for a in args):
            return int(pid)
    raise RuntimeError(f"no TORCS process found for {race_file}")


class KillsTorcs(MiddleRobot):
    """Kills TORCS once, found before the race starts (contract.py's KillsTorcs says why)."""

    sent = False

    def on_track(self, track, car):
        super().on_track(track, car)
        self.torcs_pid = torcs_pid()

    def drive(self, state):
        if state.sim_time_s > 1.0 and not self.sent:
            self.sent = True
            os.kill(self.torcs_pid, signal.SIGKILL)
        return super().drive(state)


class LateFault(MiddleRobot):
    """Drives lap 1, then fails 2 s into lap 2 in the way its subclass says."""

    def drive(self, state):
        if state.laps >= 2 and state.cur_lap_time_s > 2.0:
            return self.fail(state) or super().drive(state)
        return super().drive(state)

    def fail(self, state):
        raise NotImplementedError


class RaisesInLapTwo(LateFault):
    def fail(self, state):
        raise RuntimeError("late failure")


class HangsInLapTwo(LateFault):
    def fail(self, state):
        while True:
            time.sleep(1)


class KillsItselfInLapTwo(LateFault):
    def fail(self, state):
        os.kill(os.getpid(), signal.SIGKILL)


class KillsTorcsInLapTwo(LateFault):
    killed = False

    def on_track(self, track, car):
        super().on_track(track, car)
        self.torcs_pid = torcs_pid()  # before the race: in a step it could overrun the step budget

    def fail(self, state):
        if not self.killed:
            self.killed = True
            os.kill(self.torcs_pid, signal.SIGKILL)


class Slow(MiddleRobot):
    """Well within its step budget, but slow enough (1 ms a step) that a race lasts a while."""

    def drive(self, state):
        time.sleep(0.001)
        return super().drive(state)
