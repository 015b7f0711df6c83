"""The whole car setup without a race: each setting's place and range read from the installed car
files (the car's own values as TORCS gave them to a race), a value outside the range refused in one
line naming it (before TORCS starts for --set and setup files), the values the bridge writes."""

from __future__ import annotations

import math

import pytest

from boxbox.model import CarSetup
from boxbox.model.car import FWD, RWD
from boxbox.robot.base import race_options
from boxbox.torcs import wire
from boxbox.torcs.car_setup import SLOTS, apply_setup, car_settings, checked_setup, slot_values
from boxbox.torcs.messages import fuel_reply
from helpers import run_boxbox
from trackdata import load


def test_the_car_files_give_each_setting_the_value_a_race_gave_the_car():
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


def test_a_value_outside_the_cars_range_is_one_line_naming_the_range():
    trb1 = car_settings("car1-trb1")
    assert trb1.ranges()["final_drive_ratio"] == (1.0, 10.0)
    assert trb1.problem(CarSetup(final_drive_ratio=4.0, rear_spring_npm=60000.0, gear_ratios=(2.8, 1.8))) is None
    assert trb1.problem(CarSetup(final_drive_ratio=12.0)) == \
        "final_drive_ratio=12 is outside car1-trb1's range 1 to 10"
    lo, hi = trb1.ranges()["front_ride_height_m"]  # 70 to 120 mm
    assert (lo, hi) == pytest.approx((0.07, 0.12))
    assert "front_ride_height_m=0.05 is outside car1-trb1's range 0.07 to 0.12" == \
        trb1.problem(CarSetup(front_ride_height_m=0.05))
    assert trb1.problem(CarSetup(gear_ratios=(3.0,) * 7)) == "gear_ratio_7: car1-trb1 has no such setting"
    assert trb1.problem(CarSetup(rear_spring_npm="stiff")) == "rear_spring_npm must be a number or None, got str"  # type: ignore[arg-type]
    assert trb1.problem(CarSetup(brake_front_share=math.nan)) == "brake_front_share=nan must be a finite number"
    # car1-trb3's rear wing is fixed at 15 deg in its file
    assert "range 0.261799 to 0.261799" in car_settings("car1-trb3").problem(CarSetup(rear_wing_angle_rad=0.1))


def test_the_settings_of_a_race_set_the_car_over_the_robots_answer():
    options = race_options({"final_drive_ratio": 4.2, "mu_scale": 0.9, "rear_spring_npm": 70000.0})
    assert options.robot_args == {"set": {"mu_scale": 0.9}}  # the robot's parameters
    assert options.car_setup == {"final_drive_ratio": 4.2, "rear_spring_npm": 70000.0}
    setup, problem = checked_setup(CarSetup(rear_wing_angle_rad=0.2, final_drive_ratio=5.0), options.car_setup,
                                   "car1-trb1")
    assert problem is None
    assert setup == CarSetup(rear_wing_angle_rad=0.2, final_drive_ratio=4.2, rear_spring_npm=70000.0)
    assert checked_setup("fast", {}, "car1-trb1")[1] == "returned str, not CarSetup or None"
    _, car = load("e-track-2")
    apply_setup(car, setup)
    assert (car.rear_wing_angle_rad, car.spring_rr_npm, car.spring_rl_npm) == (0.2, 70000.0, 70000.0)


def test_the_bridge_gets_each_value_at_its_place_in_the_car_file():
    setup = CarSetup(final_drive_ratio=4.2, front_ride_height_m=0.08, gear_ratios=(2.9,))
    values = dict(zip(SLOTS, slot_values(setup, RWD), strict=True))
    assert values[("Rear Differential", "ratio")] == 4.2 and math.isnan(values[("Front Differential", "ratio")])
    assert values[("Front Right Wheel", "ride height")] == values[("Front Left Wheel", "ride height")] == 0.08
    assert values[("Gearbox/gears/1", "ratio")] == 2.9 and math.isnan(values[("Gearbox/gears/2", "ratio")])
    assert sum(not math.isnan(v) for v in values.values()) == 4
    assert dict(zip(SLOTS, slot_values(setup, FWD), strict=True))[("Front Differential", "ratio")] == 4.2
    reply = fuel_reply(None, setup)
    assert len(reply) == len(wire.FUEL_FIELDS) and reply[0] == -1.0
    assert '{"Rear Differential", "ratio"}' in wire.c_header()


def test_a_setting_out_of_range_stops_the_race_before_torcs_starts(tmp_path):
    setup = tmp_path / "setup.toml"
    setup.write_text("final_drive_ratio = 3.6\nrear_spring_npm = 1e6\n")
    proc = run_boxbox("race", "--setup", str(setup), "--laps", "1", "--run-dir", str(tmp_path / "run"))
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "rear_spring_npm=1e+06 is outside car1-trb1's range 8928.98 to 178580" in proc.stderr
    assert not (tmp_path / "run").exists()


def test_a_study_searches_setup_settings_over_the_cars_ranges():
    from boxbox.robot.tutorial import TutorialRobot
    from boxbox.tune.space import defaults_in_space, distributions, tune_space

    space = tune_space(TutorialRobot, "car1-trb1")
    dists = distributions(space, ["final_drive_ratio", "rear_spring_npm", "mu_scale"])
    assert (dists["final_drive_ratio"].low, dists["final_drive_ratio"].high) == (1.0, 10.0)
    assert dists["rear_spring_npm"].high == pytest.approx(178580, rel=1e-5)
    assert defaults_in_space(space, dists)["final_drive_ratio"] == 4.5  # the car's own: the first trial
    assert "rear_wing_angle_rad" not in tune_space(TutorialRobot, "car1-trb3").searchable_names()  # fixed at 15 deg
