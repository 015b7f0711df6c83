"""One contract for robots: every callback the Robot interface promises (robot/base.py,
docs/robots.md) is called when it says, in every way a race ends: finished, Ctrl-C (SIGINT to the
launcher), a robot fault, TORCS killed.  The robots of tests/robots/contract.py write each call
down; real races, about a second each."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from helpers import ROBOTS, processes_mentioning, read_json, run_boxbox

CONTRACT = ROBOTS / "contract.py"
SET_UP = ["__init__", "initial_fuel_l", "car_setup", "on_track", "telemetry_fields", "drive", "telemetry"]
ENDED = ["on_race_end", "race_report"]


def calls(run_dir: Path) -> dict[int, list[dict]]:
    """Each robot's calls in order, by robot."""
    by_robot: dict[int, list[dict]] = {}
    for line in (run_dir / "calls.jsonl").read_text().splitlines():
        call = json.loads(line)
        by_robot.setdefault(call["robot"], []).append(call)
    return by_robot


def race(tmp_path: Path, robot: str, *args: str, cars: int = 1):
    run_dir = tmp_path / "run"
    robots = [a for _ in range(cars) for a in ("--robot", f"{CONTRACT}:{robot}")]
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", *robots, "--quiet", "--run-dir", str(run_dir),
                      "--json", str(tmp_path / "r.json"), *args, timeout=60)
    assert processes_mentioning(str(run_dir)) == []
    return proc, run_dir, read_json(tmp_path / "r.json")


def names(seq: list[dict]) -> list[str]:
    return [c["call"] for c in seq]


def test_a_finished_race_calls_every_callback_once_in_order(tmp_path, overlay):
    proc, run_dir, result = race(tmp_path, "Recorder", cars=2)
    assert proc.returncode == 0, proc.stderr
    assert len(calls(run_dir)) == 2
    drivers = {d["car_index"]: d for d in result["drivers"]}
    for seq in calls(run_dir).values():
        assert names(seq) == SET_UP + ENDED, names(seq)
        driver = drivers[seq[3]["car_index"]]
        end = seq[-2]
        # after the last drive step, with the car's state at the finish: the last lap is known
        assert end["drives"] == end["telemetries"] > 1000
        assert end["laps"] == driver["laps"] + 1
        if driver["lap_times"]:  # (the second car may be wrecked by the first: the middle robot is no racer)
            assert end["last_lap_time_s"] == pytest.approx(driver["lap_times"][-1], abs=0.001)
        assert driver["report"] == {"recorded": True}  # race_report after on_race_end
        assert end["pid"] == seq[0]["pid"]


@pytest.mark.parametrize("robot,status,why", [
    ("Faults", 4, "ValueError: deliberate failure in drive"),
    ("KillsTorcs", 4, "TORCS was killed by SIGKILL"),
    ("Hangs", 4, "did not answer within its step budget of 200 ms"),
    ("Interrupts", 4, "a robot sent SIGINT to boxbox (the robot host's parent process)"),
])
def test_a_race_that_ends_early_still_calls_on_race_end_once(robot, status, why, tmp_path, overlay):
    proc, run_dir, result = race(tmp_path, robot)
    assert proc.returncode == status, proc.stderr
    assert why in result["error"]
    [seq] = calls(run_dir).values()
    assert names(seq) == SET_UP + ENDED, names(seq)
    end = seq[-2]
    assert 1.0 < end["t"] < 2.0 and end["laps"] == 0  # the last state the robot saw (before the line)
    # every drive step before the end; the last one has no telemetry when it failed or TORCS died in it
    assert end["drives"] - 1 <= end["telemetries"] <= end["drives"]
    assert result["drivers"][0]["report"] == {"recorded": True}


def test_pit_stop_comes_between_drive_steps_and_before_the_end(tmp_path, overlay):
    proc, run_dir, result = race(tmp_path, "Stops", "--laps", "2", "--pit-laps", "1")
    assert proc.returncode == 0, proc.stderr
    [seq] = calls(run_dir).values()
    assert names(seq) == SET_UP + ["pit_stop"] + ENDED, names(seq)
    assert seq[-3]["laps"] == 1 and 0 < seq[-3]["drives"] < seq[-2]["drives"]
    assert result["drivers"][0]["pit_stops"] == 1


def test_a_failure_in_on_race_end_is_the_robots_fault_and_keeps_the_result(tmp_path, overlay):
    proc, run_dir, result = race(tmp_path, "RaisesAtTheEnd")
    assert proc.returncode == 4, proc.stderr
    assert "RuntimeError: deliberate failure in on_race_end (in on_race_end)" in result["error"]
    [seq] = calls(run_dir).values()
    assert names(seq) == SET_UP + ENDED
    [me] = result["drivers"]
    assert me["laps"] == 1 and me["rank"] == 1 and len(me["lap_times"]) == 1
