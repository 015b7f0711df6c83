"""The env's teacher without TORCS: a robot's controls in the env's action columns, the option's
checks, and a robot that fails told in the line `boxbox race` gives."""

from __future__ import annotations

import numpy as np
import pytest

from boxbox.errors import RaceError, UsageError
from boxbox.gym.teacher import Teacher, controls_action, teacher_spec
from boxbox.model import Controls, State
from boxbox.robot.simple import MiddleRobot
from robots.faulty import RaisesInDrive, RaisesInOnTrack
from trackdata import load

S0 = State(*([0.0] * 42))


def state(**fields) -> State:
    return S0._replace(to_left_m=5.0, to_right_m=5.0, **fields)


def test_controls_are_the_env_action_columns_one_pedal_throttle_else_minus_brake():
    throttle = Controls(steer=-0.25, accel=0.75, brake=0.0, clutch=0.5, gear=3, pit_request=True)
    braking = Controls(steer=0.5, accel=0.0, brake=0.4, gear=2)
    both = Controls(steer=0.0, accel=0.3, brake=0.2)  # traction control and a slide's brake: accelerating
    assert controls_action(throttle, ("steer", "pedal")).tolist() == [-0.25, 0.75]
    assert controls_action(braking, ("steer", "pedal")).tolist() == pytest.approx([0.5, -0.4])
    assert controls_action(both, ("pedal",)).tolist() == pytest.approx([0.3])
    assert controls_action(throttle, ("throttle", "brake", "steer", "gear", "clutch", "pit")).tolist() == \
        [0.75, 0.0, -0.25, 3.0, 0.5, 1.0]
    assert controls_action(braking, ("pit", "brake")).tolist() == pytest.approx([0.0, 0.4])
    assert controls_action(braking, ("steer", "pedal")).dtype == np.float32


def test_the_teacher_option_is_one_robot_as_robot_takes_it():
    assert teacher_spec(None) is None
    assert teacher_spec("boxbox") == "boxbox"
    assert teacher_spec(MiddleRobot) == "boxbox.robot.simple:MiddleRobot"
    for bad in (["boxbox", "middle"], 3, "", []):
        with pytest.raises(UsageError, match="teacher"):
            teacher_spec(bad)
    with pytest.raises(UsageError, match="unknown robot 'boxbx'"):
        Teacher("boxbx", ("steer", "pedal"), laps=1)


def test_the_teacher_drives_the_state_in_the_env_columns_and_a_fault_is_the_race_line():
    track, car = load("g-track-1")
    teacher = Teacher("boxbox.robot.simple:MiddleRobot", ("steer", "pedal"), laps=1)
    teacher.new_race(track, car)
    action = teacher.action(state(sim_time_s=0.5, speed_x_mps=10.0, to_middle_m=2.0))
    assert action.shape == (2,) and -1 <= action[0] < 0 < action[1]  # left of the middle: steers right, drives
    raises = Teacher("robots.faulty:RaisesInDrive", ("steer", "pedal"), laps=1)
    raises.new_race(track, car)
    raises.action(state(sim_time_s=0.5))
    with pytest.raises(RaceError) as failed:
        raises.action(state(sim_time_s=1.5))
    line = str(failed.value).splitlines()[0]
    assert line == ("robot 'robots.faulty:RaisesInDrive' (teacher) failed: ValueError: deliberate failure in drive "
                    "(in drive, step 2, t=1.50 s)")
    assert "Traceback" in str(failed.value)  # below the line, as `boxbox race` prints it
    with pytest.raises(RaceError, match=r"\(teacher\) failed: RuntimeError: deliberate failure in on_track"):
        Teacher("robots.faulty:RaisesInOnTrack", ("steer",), laps=1).new_race(track, car)
    assert RaisesInDrive and RaisesInOnTrack  # imported by spec above


def test_an_opponent_is_a_python_robot_unless_it_is_a_torcs_module_and_a_number():
    from boxbox.gym.hosted import split_opponents

    python = ["boxbox", "my_robot.py:Fast", "robots.faulty:RaisesInDrive", "middle", "a/b.py:C"]
    assert split_opponents(["bt:2", *python[:3], " berniw:3 ", *python[3:]]) == (["bt:2", " berniw:3 "], python)
    from boxbox.gym import parallel_env

    with pytest.raises(UsageError, match="'boxbox': the parallel env races TORCS robots only"):
        parallel_env(opponents=["bt:1", "boxbox"])
