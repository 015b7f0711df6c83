"""The env's teacher: a robot driving in its head on the learner's car, for imitation and residual learning.

    env = gymnasium.make("boxbox/TORCS-v0", teacher="boxbox")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(info["teacher_action"])

With `teacher` (a robot as `boxbox race --robot` takes it: "boxbox", "path/file.py:Class",
"module:Class" or a boxbox.Robot subclass), the env runs that robot in its own process: a fresh
robot each episode (constructed, `initial_fuel_l`, `car_setup` and `on_track` on the episode's track
and car, as a race calls them), then its `drive()` on the very State each observation is made of
(at the reset and after each step), its controls put in `info["teacher_action"]` in the env's own
action columns (`teacher_action`).  The robot's controls never reach the car: the learner's action
drives it.  Its car setup and start fuel are asked for (a robot may keep what it chose) but not
applied, the car is the env's.  The robot decides once per step (every `action_repeat` drive steps),
as the learner does: fed back as the action, its controls are held as long as the learner's are.
A robot that raises, exits or returns invalid controls is a RaceError with the line `boxbox race`
gives (torcs/host.py's checks).  It runs in the env's process, as the learner's own code does: a
robot that hangs hangs the env (an opponent, gym/hosted.py, has a process of its own).
"""

from __future__ import annotations

import copy

import numpy as np

from boxbox import validate
from boxbox.errors import RaceError
from boxbox.model import Car, Controls, State, Track
from boxbox.robot.base import RaceOptions, Robot
from boxbox.robot.loader import load_robot_class, spec_for_class
from boxbox.torcs.faults import Fault, RobotCall
from boxbox.torcs.host import RobotFault, robot_call, robot_drive


def controls_action(c: Controls, names: tuple[str, ...]) -> np.ndarray:
    """A robot's controls in the env's action columns `names`: the one pedal is the throttle when it
    is pressed, else minus the brake (a robot pressing both is accelerating: its traction control
    trims the throttle while its brake balances a slide); pit is 1 for a pit request, else 0."""
    values = {"steer": c.steer, "throttle": c.accel, "brake": c.brake, "clutch": c.clutch, "gear": float(c.gear),
              "pit": 1.0 if c.pit_request else 0.0, "pedal": c.accel if c.accel > 0.0 else -c.brake}
    return np.array([values[n] for n in names], dtype=np.float32)


def teacher_spec(teacher) -> str | None:
    """The teacher option as a robot spec (None: no teacher), checked as --robot is."""
    if teacher is None:
        return None
    specs = validate.robot_list(teacher, name="teacher")
    if len(specs) != 1:
        validate.fail(f"{teacher!r:.60}: the teacher is one robot; {validate.ROBOT_HINT}.", "teacher")
    spec = specs[0]
    return spec_for_class(spec) if isinstance(spec, type) else spec


class Teacher:
    """One robot, driving in its head on the learner's car (see the module's docstring)."""

    def __init__(self, spec: str, actions: tuple[str, ...], laps: int) -> None:
        self.spec, self.actions, self.laps = spec, actions, laps
        self.cls: type[Robot] = load_robot_class(spec)  # a bad spec or a robot that fails to import: UsageError
        self.robot: Robot | None = None
        self.max_gear = 6
        self.step = 0

    def new_race(self, track: Track, car: Car) -> None:
        """A fresh robot for the episode, told its track and car as a race tells it."""
        self.robot, self.step = None, 0
        car = copy.copy(car)  # the robot may change its copy (its setup); the env's stays
        self.max_gear = car.max_gear
        where: RobotCall = "__init__"
        try:
            robot = robot_call("creating the robot", self.cls, RaceOptions(laps=self.laps))
            where = "initial_fuel_l"  # (car_setup's fault is told as the host tells it: with the start fuel's)
            robot_call("initial_fuel_l", robot.initial_fuel_l, track, car)
            robot_call("car_setup", robot.car_setup, track, car)
            where = "on_track"
            robot_call("on_track", robot.on_track, track, car)
        except RobotFault as fault:
            raise self._error(fault, where) from None
        self.robot = robot

    def action(self, state: State) -> np.ndarray:
        """The robot's controls for `state`, in the env's action columns."""
        assert self.robot is not None, "new_race() first"
        self.step += 1
        try:
            c = robot_drive(self.robot, state, self.step, self.max_gear)
        except RobotFault as fault:
            raise self._error(fault, "drive", state) from None
        return controls_action(c, self.actions)

    def _error(self, fault: RobotFault, where: RobotCall, state: State | None = None) -> RaceError:
        """The fault's line as `boxbox race` prints it, the robot's traceback below it."""
        record = Fault(kind=fault.kind, message=fault.message, where=where, robot=self.spec, name="teacher",
                       step=self.step, sim_time_s=state.sim_time_s if state is not None else 0.0, traceback=fault.tb)
        return RaceError(record.line())
