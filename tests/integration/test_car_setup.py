"""The car setup reaches TORCS: a robot's first gear (its car_setup) and a final drive from --set
build a car with those ratios (the gears TORCS gives the robot), whose engine turns at the speed
they make in the race (the telemetry's rpm at its speed); a robot's value outside the car's range
stops the race before the start, in one line naming the range."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from boxbox.torcs.telemetry import load_telemetry
from helpers import ROBOTS, read_json, run_boxbox

ROBOT = f"{ROBOTS / 'gear_recorder.py'}:ShortFirstGear"
FINAL_DRIVE = 3.0  # car1-trb1's own: 4.5


def test_gears_and_final_drive_set_build_the_car_that_races(tmp_path, overlay):
    run = tmp_path / "run"
    proc = run_boxbox("race", "--robot", ROBOT, "--track", "g-track-1", "--laps", "1", "--set",
                      f"final_drive_ratio={FINAL_DRIVE}", "--step-budget-ms", "5000", "--run-dir", str(run), "--quiet",
                      timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert read_json(run / "result.json")["drivers"][0]["laps"] == 1
    ratios = json.loads((run / "gears.json").read_text())["ratios"]
    # TORCS's overall ratios, gear x final drive: first gear the robot's 2.5, second the car's own 1.9
    assert ratios[2:4] == [2.5 * FINAL_DRIVE, 1.9 * FINAL_DRIVE] != [3.0 * 4.5, 1.9 * 4.5]
    wheel_m = json.loads((run / "car.json").read_text())["wheel_radius_rr_m"]
    t = load_telemetry(run / "telemetry.parquet").columns
    second = (np.asarray(t["gear"]) == 2) & (np.asarray(t["speed_mps"]) > 15.0)
    assert second.sum() > 20
    engine_rpm = np.asarray(t["speed_mps"])[second] / wheel_m * ratios[3] * 60.0 / (2.0 * math.pi)
    assert np.median(np.asarray(t["rpm"])[second] / engine_rpm) == pytest.approx(1.0, abs=0.05)


def test_a_robots_setup_outside_the_cars_range_is_one_line_before_the_start(tmp_path, overlay):
    proc = run_boxbox("race", "--robot", ROBOT, "--track", "g-track-1", "--laps", "1", "--json",
                      str(tmp_path / "r.json"), "--quiet", env={"FIRST_GEAR": "7.5"}, timeout=300)
    assert proc.returncode != 0
    assert "car_setup(): gear_ratio_1=7.5 is outside car1-trb1's range 0.5 to 5" in proc.stderr, proc.stderr
    assert read_json(tmp_path / "r.json")["drivers"][0]["laps"] == 0
