"""The car setup in the installed TORCS: each setting's value in the car's files is what a race
gives the car, and its ranges are the car's (car1-trb3's rear wing is fixed).  It reaches TORCS: a
robot's first gear (its car_setup), a second gear and a final drive from --set build a car with
those ratios (the gears TORCS gives the robot), whose engine turns at the speed they make in the race (the
telemetry's rpm at its speed); a robot's value outside the car's range stops the race before the
start, in one line naming the range."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from boxbox.model import CarSetup
from boxbox.torcs.car_setup import car_settings
from boxbox.torcs.telemetry import load_telemetry
from helpers import ROBOTS, read_json, run_boxbox
from trackdata import load

ROBOT = f"{ROBOTS / 'gear_recorder.py'}:ShortFirstGear"
FINAL_DRIVE = 3.0  # car1-trb1's own: 4.5
SECOND_GEAR = 1.7  # car1-trb1's own: 1.9


def test_the_installed_car_files_give_each_setting_the_value_a_race_gave_the_car():
    _, raced = load("e-track-2")  # car1-trb1 as TORCS gave it to a race (HANDLE and CAR records)
    own = {name: s.value for name, s in car_settings("car1-trb1").settings.items()}
    assert own["front_spring_npm"] == pytest.approx(raced.spring_fr_npm, rel=1e-6)  # 5500 lbs/in
    assert own["rear_slow_bump_nspm"] == pytest.approx(raced.slow_bump_rr_nspm, rel=1e-6)
    assert own["front_fast_rebound_nspm"] == pytest.approx(raced.fast_rebound_fl_nspm, rel=1e-6)
    assert own["rear_ride_height_m"] == pytest.approx(raced.ride_height_rl_m, rel=1e-6)
    assert own["brake_pressure_max_pa"] == pytest.approx(raced.brake_pressure_max, rel=1e-6)
    assert own["brake_front_share"] == pytest.approx(raced.brake_front_rear, rel=1e-6)
    assert own["rear_wing_angle_rad"] == pytest.approx(raced.rear_wing_angle_rad, rel=1e-6)
    overall = [own[f"gear_ratio_{i}"] * own["final_drive_ratio"] for i in range(1, 7)]
    assert overall == pytest.approx(raced.gear_ratios[2:8], rel=1e-6)  # TORCS: gear x final drive
    assert car_settings("car1-trb1").ranges()["final_drive_ratio"] == (1.0, 10.0)
    assert "range 0.261799 to 0.261799" in car_settings("car1-trb3").problem(CarSetup(rear_wing_angle_rad=0.1))



def test_gears_and_final_drive_set_build_the_car_that_races(tmp_path, overlay):
    run = tmp_path / "run"
    proc = run_boxbox("race", "--robot", ROBOT, "--track", "g-track-1", "--laps", "1", "--set",
                      f"final_drive_ratio={FINAL_DRIVE}", "--set", f"gear_ratio_2={SECOND_GEAR}", "--step-budget-ms",
                      "5000", "--run-dir", str(run), "--quiet", timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert read_json(run / "result.json")["drivers"][0]["laps"] == 1
    ratios = json.loads((run / "gears.json").read_text())["ratios"]
    # TORCS's overall ratios, gear x final drive: first gear the robot's 2.5, second --set's, third the car's 1.4
    assert ratios[2:5] == pytest.approx([2.5 * FINAL_DRIVE, SECOND_GEAR * FINAL_DRIVE, 1.4 * FINAL_DRIVE],
                                        rel=1e-6)  # TORCS's floats
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
