"""The robot `boxbox new-robot NAME` starts from: NAME.py, a robot of the documented parts whose
defaults suit each other (docs/robots.md: the car model, the speed profile, `steer_to_line` on the
track's middle, the gear changing, the pit part, getting unstuck), and test_NAME.py, offline tests
of its `drive()` with `boxbox.testing`.  The figures in its docstring are measured on the six public
tracks (docs/robots.md, "Starting a robot").  The tests race it too (as `parts`, `template_robot` in
tests/helpers.py)."""

from __future__ import annotations

import importlib.util
import keyword
import re
import sys

from boxbox.errors import UsageError

NAME_PATTERN = re.compile(r"[a-z][a-z0-9_]*")

ROBOT = '''"""{name}: a robot of boxbox's documented parts, each with its defaults (docs/robots.md): the car
model, the speed profile (every turn at 70% of the grip at its middle radius), the steering law on
the track's middle, the gear changing, the pit part and getting unstuck.  As written it finishes the
six public tracks with damage under 10 (docs/robots.md).  Race it:

    boxbox race --robot {name}.py:{cls} --track g-track-1 --laps 1

and test it without TORCS: pytest test_{name}.py
"""

from boxbox import Controls, PitStops, Robot, Unstuck
from boxbox.control.carmodel import CarModel
from boxbox.control.gears import GearBox
from boxbox.control.speed import SpeedProfile
from boxbox.control.steering import steer_to_line

FULL_BRAKE_OVER_MPS = 5.0  # the brake reaches 1 this far above the profile's speed


class {cls}(Robot):
    name = "{name}"  # its cars are "{name} 1", "{name} 2", ...

    def on_track(self, track, car):
        super().on_track(track, car)
        self.curvature_1pm = track.curvature()  # per segment, + left
        self.wheelbase_m = car.front_axle_x_m - car.rear_axle_x_m
        self.speeds = SpeedProfile.from_track(track, CarModel.from_car(car))
        self.gears = GearBox(car)
        self.pits = PitStops(track, car, self.options)  # the stops --pit-laps asks for
        self.unstuck = Unstuck(track, car)  # backing out when stuck against a wall

    def drive(self, state):
        backing = self.unstuck.step(state)  # None: not stuck, drive on
        if backing is not None:
            return backing
        steer = steer_to_line(state.angle_rad, -state.to_middle_m, self.curvature_1pm[int(state.seg_id)],
                              state.speed_x_mps, state.yaw_rate_rps, self.wheelbase_m, self.car.steer_lock_rad)
        over_mps = state.speed_x_mps - self.speeds.speed_at(state.dist_from_start_m)  # + too fast
        controls = Controls(steer=steer, accel=1.0 if over_mps < 0.0 else 0.0,
                            brake=min(1.0, max(0.0, over_mps / FULL_BRAKE_OVER_MPS)), clutch=0.0,
                            gear=self.gears.select(state.gear, state.speed_x_mps))
        return self.pits.filter(state, controls)  # in and out of the box when a stop is due

    def pit_stop(self, state):
        return self.pits.pit_stop(state)

    def race_report(self):
        return self.pits.report()

    def telemetry_fields(self):
        return ("target_speed_mps",)  # drawn by the race report (boxbox race --report DIR)

    def telemetry(self, state):
        return (self.speeds.speed_at(state.dist_from_start_m),)
'''

TESTS = '''"""Tests of {name}.py without a race (boxbox.testing): run them with `pytest test_{name}.py`.

The track and car come from the installed TORCS the first time (under a second each), then from
boxbox's cache.  With RUN_DIR set to a race's run dir (`boxbox race --robot {name}.py:{cls}
--run-dir DIR`), the last test drives the robot over every step of that race.
"""

import os

import pytest

from boxbox.testing import load_car, load_track, make_state, recorded_states
from {name} import {cls}

TRACK = "g-track-1"


@pytest.fixture
def robot():
    robot = {cls}()
    robot.on_track(load_track(TRACK), load_car(track=TRACK))
    return robot


def refused(robot, controls):
    """Why a race would refuse these controls (a robot fault), or None."""
    return controls.problem(max_gear=robot.car.gear_count - 1)


def test_it_pulls_away_from_the_start(robot):
    controls = robot.drive(make_state())
    assert controls.accel > 0 and controls.brake == 0 and controls.gear == 1


def test_it_brakes_well_over_its_speed(robot):
    controls = robot.drive(make_state(speed_x_mps=robot.speeds.speed_at(0.0) + 20.0, gear=5))
    assert controls.brake == 1 and controls.accel == 0


def test_it_steers_back_to_the_middle(robot):
    left_of_it = robot.drive(make_state(to_middle_m=3.0, speed_x_mps=20.0))
    right_of_it = robot.drive(make_state(to_middle_m=-3.0, speed_x_mps=20.0))
    assert left_of_it.steer < 0 < right_of_it.steer


def test_it_backs_out_when_stuck_against_a_wall(robot):
    against_wall = make_state(speed_x_mps=1.0, to_middle_m=4.0, angle_rad=-0.8)  # sideways, at the left edge
    gears = [robot.drive(against_wall._replace(sim_time_s=0.02 * i)).gear for i in range(150)]
    assert gears[50] == 1 and gears[-1] == -1  # after 2 s of it: reverse


def test_every_segment_at_the_profile_speed_gives_valid_controls(robot):
    for seg_id, dist_m in enumerate(robot.track.seg["start_dist_m"]):
        state = make_state(seg_id=seg_id, dist_from_start_m=dist_m, speed_x_mps=robot.speeds.speed_at(dist_m), gear=3)
        controls = robot.drive(state)
        assert refused(robot, controls) is None, f"segment {{seg_id}}: {{controls}}"


@pytest.mark.skipif(not os.environ.get("RUN_DIR"), reason="RUN_DIR names no race to replay")
def test_a_recorded_race_replays_with_valid_controls(robot):
    steps = 0
    for state in recorded_states(os.environ["RUN_DIR"]):
        controls = robot.drive(state)
        assert refused(robot, controls) is None, f"at {{state.sim_time_s:.2f}} s: {{controls}}"
        steps += 1
    assert steps > 0
'''


def class_name(name: str) -> str:
    """The robot's class: NAME in CamelCase (my_robot -> MyRobot)."""
    return "".join(part[:1].upper() + part[1:] for part in name.split("_"))


def check_robot_name(name: str) -> None:
    """A one-line UsageError unless NAME can be a robot's module and name: lower case, a Python
    identifier, no keyword, no module Python would import instead (or that pytest takes for tests)."""
    why = None
    if not NAME_PATTERN.fullmatch(name) or name.endswith("_"):
        why = "use lower-case letters, digits and _ , starting with a letter, e.g. my_robot"
    elif keyword.iskeyword(name) or name.startswith("test"):
        why = "a Python keyword" if keyword.iskeyword(name) else "pytest would take the robot's file for tests"
    elif name in sys.stdlib_module_names or name == "boxbox" or importlib.util.find_spec(name) is not None:
        why = "a module of that name is already installed, and an import would find it instead"
    if why:
        raise UsageError(f"bad robot name {name!r}: {why}")


def robot_files(name: str) -> dict[str, str]:
    """File name -> text of the robot NAME and its tests (the name checked)."""
    check_robot_name(name)
    cls = class_name(name)
    return {f"{name}.py": ROBOT.format(name=name, cls=cls), f"test_{name}.py": TESTS.format(name=name, cls=cls)}
