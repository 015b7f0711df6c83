"""boxbox.testing against a real race: the track and car `load_track`/`load_car` give and the states
`recorded_states` reads back are what the race gave the robot, so a deterministic robot replayed
offline over them answers every step with exactly the controls it raced with."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from boxbox.errors import UsageError
from boxbox.testing import load_car, load_track, recorded_states
from boxbox.torcs.telemetry import load_telemetry
from helpers import read_json, run_boxbox, template_robot


def test_a_robot_replayed_over_its_recorded_race_answers_as_it_raced(tmp_path, overlay):
    run, robot_file = tmp_path / "run", template_robot(tmp_path)
    proc = run_boxbox("race", "--robot", f"{robot_file}:Parts", "--track", "g-track-1", "--laps", "1",
                      "--step-budget-ms", "5000", "--run-dir", str(run), "--quiet", timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert read_json(run / "result.json")["drivers"][0]["laps"] == 1
    spec = importlib.util.spec_from_file_location("parts", robot_file)
    assert spec is not None and spec.loader is not None
    parts = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(parts)
    robot = parts.Parts()
    robot.on_track(load_track("g-track-1"), load_car("car1-trb1", track="g-track-1"))
    states = list(recorded_states(run))
    raced = load_telemetry(run / "telemetry.parquet").columns
    assert len(states) == len(raced["time_s"]) > 2000  # a lap of g-track-1: about 2,050 drive steps
    assert [s.sim_time_s for s in states] == raced["time_s"].tolist()
    controls = [robot.drive(s) for s in states]
    for name in ("steer", "accel", "brake"):
        assert np.array_equal([getattr(c, name) for c in controls], raced[name]), name


def test_an_unknown_track_or_car_is_one_line_naming_the_nearest(overlay):
    with pytest.raises(UsageError, match="g-track-1"):
        load_track("g-trak-1")
    with pytest.raises(UsageError, match="car1-trb1"):
        load_car("car1-trb")
