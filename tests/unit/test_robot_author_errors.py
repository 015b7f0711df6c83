"""A robot author's mistakes, each said in one line that says what to do (issue 48, items 4 and 8)."""

from __future__ import annotations

import pytest

from boxbox.errors import UsageError
from boxbox.robot.loader import load_robot_class
from boxbox.robot.tunable import param_space
from helpers import run_boxbox


def robot_file(tmp_path, body: str, name: str = "bot.py"):
    path = tmp_path / name
    path.write_text("from boxbox import Controls, Robot\n" + body)
    return path


@pytest.mark.parametrize("body,said", [
    ("import sys\nsys.exit(0)\n", "sys.exit(0)"),
    ("import sys\nsys.exit()\n", "sys.exit()"),
    ("import os\nos.getcwd()\nraise ValueError('bad')\n", "ValueError: bad"),
])
def test_a_robot_file_that_exits_or_raises_at_import_is_a_usage_error(tmp_path, body, said):
    path = robot_file(tmp_path, body)
    with pytest.raises(UsageError, match="failed to import") as e:
        load_robot_class(f"{path}:Bot")
    assert said in str(e.value) and "\n" not in str(e.value)


def test_the_command_line_and_the_api_say_it_in_one_line(tmp_path):
    path = robot_file(tmp_path, "import sys\nsys.exit(0)\n")
    proc = run_boxbox("race", "--robot", f"{path}:Bot", "--quiet", "--run-dir", str(tmp_path / "run"))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("boxbox: error:") and "sys.exit(0)" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    import boxbox

    with pytest.raises(UsageError, match=r"sys\.exit\(0\)"):
        boxbox.race("g-track-1", robots=[f"{path}:Bot"])


def test_a_module_spec_beside_a_file_of_that_name_suggests_the_file(tmp_path, monkeypatch):
    robot_file(tmp_path, "class MidBot(Robot):\n    def drive(self, s):\n        return None\n", "midbot.py")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(UsageError, match=r"did you mean midbot\.py:MidBot"):
        load_robot_class("midbot:MidBot")


def test_a_robot_without_drive_is_refused_naming_the_method(tmp_path):
    path = robot_file(tmp_path, "class NoDrive(Robot):\n    pass\n")
    with pytest.raises(UsageError, match=r"NoDrive.*does not define drive\(self, state\)"):
        load_robot_class(f"{path}:NoDrive")


def test_no_tunable_parameters_says_the_class_once(tmp_path):
    path = robot_file(tmp_path, "class Plain(Robot):\n    def drive(self, s):\n        return None\n")
    with pytest.raises(UsageError) as e:
        param_space(load_robot_class(f"{path}:Plain"))
    assert "robot robot" not in str(e.value) and "Plain" in str(e.value)


def test_a_setup_file_says_how_to_race_the_robot_it_is_for(tmp_path):
    from boxbox.robot.tunable import read_setup, write_setup

    mine, default = tmp_path / "mine.toml", tmp_path / "default.toml"
    write_setup(mine, {"speed": 1.5}, ["tuned"], robot="my robot.py:MyRobot")
    write_setup(default, {"mu_scale": 0.9}, ["tuned"], robot="boxbox")
    assert f"# race with it: boxbox race --robot 'my robot.py:MyRobot' --setup {mine}\n" in mine.read_text()
    assert f"# race with it: boxbox race --setup {default}\n" in default.read_text()
    assert read_setup(mine) == {"speed": 1.5}
