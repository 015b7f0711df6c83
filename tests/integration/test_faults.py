"""A robot that fails in any way, or TORCS dying under it, stops the race cleanly: within a
bounded time, a one-line cause (and the robot's traceback where there is one), exit 4, no process
left behind, and the lap times so far kept.  See docs/reliability.md for the table."""

from __future__ import annotations

import time

import pytest

from helpers import ROBOTS, processes_mentioning, read_json, run_boxbox

FAULTY = ROBOTS / "faulty.py"

CASES = {
    # robot class: (text in the one-line cause, text in the traceback or None[, extra race arguments])
    "RaisesInDrive": ("ValueError: deliberate failure in drive", 'in drive\n    raise ValueError'),
    "RaisesInOnTrack": ("RuntimeError: deliberate failure in on_track", "raise RuntimeError"),
    "TutorialRaisesInPitStop": ("KeyError: 'deliberate failure in pit_stop'", "raise KeyError",
                                ["--pit-laps", "1", "--learning", "off"]),
    "HangsInOnTrack": ("did not answer within its set-up budget of 2 s (in on_track)", "faulty.py",
                       ["--setup-budget-s", "2"]),
    "KillsTorcs": ("TORCS was killed by SIGKILL", None),
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
    cause, tb, *extra = CASES[robot]
    run_dir = tmp_path / "run"
    out = tmp_path / "r.json"
    started = time.monotonic()
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--robot", f"{FAULTY}:{robot}",
                      "--step-budget-ms", "200", "--run-dir", str(run_dir), "--json", str(out), "--quiet",
                      *(extra[0] if extra else []), timeout=60)
    elapsed = time.monotonic() - started
    assert proc.returncode == 4, proc.stderr
    error_lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]
    assert len(error_lines) == 1, proc.stderr
    assert cause in error_lines[0], proc.stderr
    assert error_lines[0].endswith(f"(run dir {run_dir})"), error_lines[0]  # the race's files are named
    if "TORCS" not in cause:  # a robot's fault names the robot
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


LATE = {
    # a robot failing 2 s into lap 2: the cause; its lap 1 time must survive in every case (a host
    # that is killed or stuck cannot write host.json: it saves its lap times at every lap)
    "RaisesInLapTwo": "RuntimeError: late failure",
    "HangsInLapTwo": "did not answer within its step budget",
    "KillsItselfInLapTwo": "the robot process was killed by SIGKILL",
    "KillsTorcsInLapTwo": "TORCS was killed by SIGKILL",
}


@pytest.mark.parametrize("robot", sorted(LATE))
def test_lap_times_before_a_fault_are_kept(robot, tmp_path, overlay):
    run_dir = tmp_path / "run"
    out = tmp_path / "r.json"
    started = time.monotonic()
    proc = run_boxbox("race", "--track", "michigan", "--laps", "3", "--robot", f"{FAULTY}:{robot}",
                      "--run-dir", str(run_dir), "--json", str(out), "--quiet", timeout=60)
    assert time.monotonic() - started < 30
    assert proc.returncode == 4, proc.stderr
    [line] = [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]
    assert LATE[robot] in line, proc.stderr
    r = read_json(out)
    assert r["error"].startswith(line.removeprefix("boxbox: error: "))
    [me] = r["drivers"]
    assert len(me["lap_times"]) == 1 and me["lap_times"][0] > 20, me
    assert me["laps"] >= 1
    assert read_json(run_dir / "result.json")["drivers"][0]["lap_times"] == me["lap_times"]
    assert processes_mentioning(str(run_dir)) == []
