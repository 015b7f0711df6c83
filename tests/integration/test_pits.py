"""Pit stops in real races: every requested stop captured by TORCS, no penalty, stops at the box."""

from __future__ import annotations

import pytest

from helpers import ROBOTS, processes_mentioning, read_json, run_boxbox

EVENT_KEYS = {"lap", "entry_time", "stop_time", "leave_time", "exit_time", "stop_error_m", "fuel", "repair", "mode"}


@pytest.mark.parametrize("mode", ["constant-decel", "bang-bang"])
def test_five_requested_stops_are_all_captured(mode, tmp_path, overlay):
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "6", "--pit-laps", "1,2,3,4,5", "--pit-mode", mode,
                      "--learning", "off", "--json", str(out), "--quiet")
    assert proc.returncode == 0, proc.stderr
    [me] = read_json(out)["drivers"]
    assert me["pit_stops"] == 5 and me["penalty_time"] == 0 and me["laps"] == 6
    events = me["pit_events"]
    assert [e["lap"] for e in events] == [1, 2, 3, 4, 5]
    for e in events:
        assert EVENT_KEYS <= set(e) and e["mode"] == mode and not e.get("gave_up")
        assert e["entry_time"] < e["stop_time"] < e["leave_time"]
        assert e["exit_time"] is None or e["leave_time"] < e["exit_time"]
        # the stop itself: 2 s plus refuelling at 8 l/s
        assert e["leave_time"] - e["stop_time"] == pytest.approx(2.0 + e["fuel"] / 8.0, abs=0.1)
        if mode == "constant-decel":
            assert abs(e["stop_error_m"]) < 0.5, e


def test_pushed_past_the_box_gives_up_and_stops_next_lap(tmp_path, overlay):
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "3", "--pit-laps", "1", "--learning", "off",
                      "--robot", f"{ROBOTS / 'faulty.py'}:OvershootsTheBoxOnce", "--json", str(out), "--quiet")
    assert proc.returncode == 0, proc.stderr
    [me] = read_json(out)["drivers"]
    first, second = me["pit_events"]
    assert first["gave_up"] and first["stop_time"] is None and first["exit_time"] is not None
    assert second["lap"] == 2 and second["stop_time"] is not None and not second.get("gave_up")
    assert me["pit_stops"] == 1 and me["laps"] == 3 and me["penalty_time"] == 0


def test_a_box_that_does_not_capture_twice_is_not_tried_a_third_time(tmp_path):
    """forza from slot 10 of 10: the car stands in its box and TORCS never captures it there (the
    box lies where the lane is too narrow for TORCS's capture rule); two stops given up, no third."""
    out = tmp_path / "r.json"
    field = "inferno:4,berniw:3,bt:2,olethros:2,lliaw:3,tita:3,damned:6,bt:3,berniw:4"
    proc = run_boxbox("race", "--track", "forza", "--laps", "4", "--pit-laps", "1", "--grid-position", "last",
                      "--opponents", field, "--learning", "off", "--json", str(out), "--quiet")
    assert proc.returncode == 0, proc.stderr
    me = next(d for d in read_json(out)["drivers"] if d["module"] == "boxbox")
    assert [m["lap"] for m in me["missed_pit_stops"]] == [1, 2], me["missed_pit_stops"]
    assert all(m["reason"] == "not captured" for m in me["missed_pit_stops"])
    assert me["pit_stops"] == 0 and me["laps"] == 4
    assert [e["lap"] for e in me["pit_events"]] == [1, 2] and all(e["gave_up"] for e in me["pit_events"])


@pytest.mark.parametrize("robot,cause", [
    ("TutorialRaisesInPitStop", "KeyError: 'deliberate failure in pit_stop'"),
    ("TutorialBadPitOrder", "fuel_l=nan must be finite"),
])
def test_a_failing_pit_stop_stops_the_race_cleanly(robot, cause, tmp_path, overlay):
    run_dir = tmp_path / "run"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--pit-laps", "1", "--learning", "off",
                      "--robot", f"{ROBOTS / 'faulty.py'}:{robot}", "--run-dir", str(run_dir), "--quiet")
    assert proc.returncode == 4, proc.stderr
    [line] = [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]
    assert cause in line and "pit_stop" in line
    assert processes_mentioning(str(run_dir)) == []
