"""`boxbox new-robot NAME`: the two files, written only when both are new and the name can be a
robot's module; the robot as written drives (no TORCS here: tests/integration/test_docs.py races it
and runs its tests, docs/robots.md "Starting a robot")."""

from __future__ import annotations

import importlib.util
import math

import pytest

from boxbox.robot.template import class_name, robot_files
from boxbox.testing import make_state
from helpers import run_boxbox
from trackdata import load


def test_it_writes_the_robot_and_its_tests_and_refuses_to_write_over_them(tmp_path):
    proc = run_boxbox("new-robot", "fast_one", "--dir", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fast_one.py", "test_fast_one.py"]
    assert "class FastOne(Robot):" in (tmp_path / "fast_one.py").read_text()
    assert "from fast_one import FastOne" in (tmp_path / "test_fast_one.py").read_text()
    (tmp_path / "fast_one.py").unlink()
    (tmp_path / "test_fast_one.py").write_text("mine")
    proc = run_boxbox("new-robot", "fast_one", "--dir", str(tmp_path))
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "test_fast_one.py already exists" in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["test_fast_one.py"]  # neither file written
    assert (tmp_path / "test_fast_one.py").read_text() == "mine"


@pytest.mark.parametrize(("name", "why"), [("My-Robot", "lower-case letters"), ("2fast", "starting with a letter"),
                                           ("class", "keyword"), ("json", "already installed"),
                                           ("numpy", "already installed"), ("test_mine", "pytest")])
def test_a_bad_name_is_one_line_and_writes_nothing(tmp_path, name, why):
    proc = run_boxbox("new-robot", name, "--dir", str(tmp_path))
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and why in proc.stderr, proc.stderr
    assert not list(tmp_path.iterdir())


def test_a_missing_folder_is_one_line(tmp_path):
    proc = run_boxbox("new-robot", "mine", "--dir", str(tmp_path / "nowhere"))
    assert proc.returncode == 2 and "no such folder" in proc.stderr and proc.stderr.count("\n") == 1


def test_the_robot_as_written_drives(tmp_path):
    assert class_name("my_fast_robot") == "MyFastRobot"
    path = tmp_path / "my_fast_robot.py"
    path.write_text(robot_files("my_fast_robot")["my_fast_robot.py"])
    spec = importlib.util.spec_from_file_location("my_fast_robot", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    robot = module.MyFastRobot()
    track, car = load("e-track-2")
    robot.on_track(track, car)
    assert robot.name == "my_fast_robot" and robot.telemetry_fields() == ("target_speed_mps",)
    start = robot.drive(make_state())
    assert start.accel == 1.0 and start.brake == 0.0 and start.gear == 1 and not start.pit_request
    assert robot.drive(make_state(to_middle_m=3.0, speed_x_mps=20.0)).steer < 0
    top_mps = robot.telemetry(make_state())[0]
    assert math.isfinite(top_mps) and robot.drive(make_state(speed_x_mps=top_mps + 10.0, gear=5)).brake == 1.0
