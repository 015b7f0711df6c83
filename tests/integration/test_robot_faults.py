"""A robot author's mistakes in real races (issue 48, items 5, 6 and 8): each said, none costing
time or disk, none losing results."""

from __future__ import annotations

import time

from helpers import ROBOTS, processes_mentioning, read_json, run_boxbox

AUTHOR = ROBOTS / "author.py"
FAULTY = ROBOTS / "faulty.py"


def race(tmp_path, robot: str, *args: str, track: str = "g-track-1", laps: str = "1"):
    tmp_path.mkdir(parents=True, exist_ok=True)
    run_dir = tmp_path / "run"
    started = time.monotonic()
    proc = run_boxbox("race", "--track", track, "--laps", laps, "--robot", robot, "--quiet", "--run-dir", str(run_dir),
                      "--json", str(tmp_path / "r.json"), *args, timeout=90)
    elapsed = time.monotonic() - started
    assert processes_mentioning(str(run_dir)) == []
    return proc, run_dir, elapsed


def error_line(proc) -> str:
    [line] = [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]
    return line


def test_a_fork_in_on_track_costs_no_time(tmp_path, overlay):
    for robot in ("ForksAWorker", "ForksInOnTrack"):
        proc, run_dir, elapsed = race(tmp_path / robot, f"{AUTHOR}:{robot}")
        assert proc.returncode == 0, proc.stderr
        assert elapsed < 8, (robot, elapsed)
        [me] = read_json(run_dir / "result.json")["drivers"]
        assert me["laps"] == 1 and len(me["lap_times"]) == 1


def test_more_start_fuel_than_the_tank_holds_is_the_robots_fault(tmp_path, overlay):
    proc, _, _ = race(tmp_path, f"{AUTHOR}:FillsTheTank")
    assert proc.returncode == 4, proc.stderr
    assert "initial_fuel_l() returned 1e+09 l, more than the tank holds" in error_line(proc)


def test_a_robot_that_never_asks_for_the_stop_the_race_asked_for_is_warned(tmp_path, overlay):
    proc, run_dir, _ = race(tmp_path, f"{AUTHOR}:NeverStops", "--pit-laps", "1", laps="2")
    assert proc.returncode == 0, proc.stderr
    assert "never asked for the pit stop --pit-laps asked for on lap 1" in proc.stderr, proc.stderr
    [me] = read_json(run_dir / "result.json")["drivers"]
    assert [m["lap"] for m in me["missed_pit_stops"]] == [1] and me["missed_pit_stops"][0]["reason"] == "not asked"


def test_a_hang_prints_the_robots_stack_once(tmp_path, overlay):
    proc, _, _ = race(tmp_path, f"{FAULTY}:HangsForever")
    assert proc.returncode == 4, proc.stderr
    assert proc.stderr.count("Stack (most recent call first)") == 1, proc.stderr


def test_the_opponents_keep_their_laps_when_the_race_is_cut_short(tmp_path, overlay):
    """A robot fault in lap 2: no TORCS results file; the host saw the TORCS robots' laps."""
    proc, run_dir, _ = race(tmp_path, f"{FAULTY}:RaisesInLapTwo", "--opponents", "bt:2,berniw:3", track="michigan",
                            laps="3")
    assert proc.returncode == 4, proc.stderr
    drivers = read_json(run_dir / "result.json")["drivers"]
    others = [d for d in drivers if d["module"] != "boxbox"]
    assert [d["module"] for d in others] == ["bt", "berniw"]
    for d in others:
        assert d["laps"] >= 1 and len(d["lap_times"]) == d["laps"] and min(d["lap_times"]) > 20, d
        assert d["car_index"] in (1, 2)


def test_the_robot_host_log_is_bounded(tmp_path, overlay):
    """100 kB a step on stdout, stderr and the bare file descriptor for 50 steps (15 MB): the log
    keeps its start and its end, and says what was cut."""
    proc, run_dir, _ = race(tmp_path, f"{AUTHOR}:PrintsALot")
    assert proc.returncode == 0, proc.stderr
    log = (run_dir / "host.log").read_bytes()
    assert len(log) < 2_200_000
    assert log.startswith(b"[middle 1] step xxx") and log.rstrip().endswith(b"[middle 1] last words of the robot")
    assert b"bytes of the log cut here" in log


def test_a_huge_exception_message_is_bounded_and_the_line_points_to_the_prints(tmp_path, overlay):
    """A 20 MB message gave 40 MB on stderr, in result.json and in fault.json: each is now a few kB,
    the cut said; the error line says where the robot's last prints are (host.log)."""
    proc, run_dir, _ = race(tmp_path, f"{FAULTY}:RaisesAHugeMessage")
    assert proc.returncode == 4, proc.stderr[-2000:]
    assert len(proc.stderr) < 50_000
    for path in (run_dir / "result.json", run_dir / "fault.json", tmp_path / "r.json"):
        assert path.stat().st_size < 50_000, path
    line = error_line(proc)
    assert "ValueError: xxx" in line and "characters of the message cut here" in line
    assert f"its prints are in {run_dir / 'host.log'}" in line
    assert "the robot's last words" in (run_dir / "host.log").read_text()


def test_a_robot_that_closes_the_bridges_socket_is_said_so(tmp_path, overlay):
    """It was reported "killed by SIGKILL" (the launcher's kill of the host at the end)."""
    proc, _, _ = race(tmp_path, f"{FAULTY}:ClosesItsDescriptors")
    assert proc.returncode == 4, proc.stderr
    line = error_line(proc)
    assert "the robot process dropped its connection to TORCS during the race" in line, line
    assert "closes file descriptors it did not open" in line and "SIGKILL" not in line
