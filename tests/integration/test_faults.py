"""A robot that fails in any way stops the race cleanly: one-line cause, traceback, exit 4,
no process left behind, and the lap times so far kept."""

from __future__ import annotations

import time

import pytest
from helpers import ROBOTS, processes_mentioning, read_json, run_boxbox

FAULTY = ROBOTS / "faulty.py"

CASES = {
    # robot class: (text in the one-line cause, text in the traceback or None)
    "RaisesInDrive": ("ValueError: deliberate failure in drive", 'in drive\n    raise ValueError'),
    "RaisesInOnTrack": ("RuntimeError: deliberate failure in on_track", "raise RuntimeError"),
    "RaisesInInit": ("RuntimeError: deliberate failure in __init__", "raise RuntimeError"),
    "HangsForever": ("did not answer within its step budget of 200 ms", "faulty.py"),
    "SleepsOnce": ("did not answer within its step budget of 200 ms", "faulty.py"),
    "KillsItself": ("robot process was killed by SIGKILL", None),
    "ReturnsNaN": ("steer is nan", None),
    "ReturnsInfinity": ("accel is inf", None),
    "ReturnsOutOfRange": ("brake=1.5 is outside [0, 1]", None),
    "ReturnsWrongType": ("drive() returned dict, not Controls", None),
}


@pytest.mark.parametrize("robot", sorted(CASES))
def test_robot_fault_stops_the_race_cleanly(robot, tmp_path, overlay):
    cause, tb = CASES[robot]
    run_dir = tmp_path / "run"
    out = tmp_path / "r.json"
    started = time.monotonic()
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--robot", f"{FAULTY}:{robot}",
                      "--step-budget-ms", "200", "--run-dir", str(run_dir), "--json", str(out), "--quiet", timeout=60)
    elapsed = time.monotonic() - started
    assert proc.returncode == 4, proc.stderr
    error_lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]
    assert len(error_lines) == 1, proc.stderr
    assert cause in error_lines[0], proc.stderr
    assert robot in error_lines[0]
    if tb:
        assert "Traceback" in proc.stderr or "where the robot was stuck" in proc.stderr, proc.stderr
        assert tb in proc.stderr, proc.stderr
    assert elapsed < 30
    assert processes_mentioning(str(run_dir)) == []
    # results so far are kept: the JSON lists the car and says why the race stopped
    r = read_json(out)
    assert r["error"] and cause in r["error"]
    assert [d["module"] for d in r["drivers"]] == ["boxbox"]


def test_lap_times_before_a_fault_are_kept(tmp_path, overlay):
    """A robot failing in lap 2 keeps its lap 1 time in the JSON."""
    robot_file = tmp_path / "late.py"
    robot_file.write_text(
        "from boxbox.robot.simple import MiddleRobot\n"
        "class FailsInLapTwo(MiddleRobot):\n"
        "    def drive(self, s):\n"
        "        if s.laps >= 2 and s.cur_lap_time_s > 2: raise RuntimeError('late failure')\n"
        "        return super().drive(s)\n")
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "michigan", "--laps", "3", "--robot", f"{robot_file}:FailsInLapTwo",
                      "--json", str(out), "--quiet")
    assert proc.returncode == 4
    [me] = read_json(out)["drivers"]
    assert len(me["lap_times"]) == 1 and me["lap_times"][0] > 20
