"""The whole car setup without TORCS: each setting's place and range read from a car's files (here
a car written for the tests: its category's file and its own, merged as TORCS merges them), a value
outside the range refused in one line naming it (before TORCS starts for --set and setup files), the
values the bridge writes, the ranges a study searches.  tests/integration/test_car_setup.py reads
the installed cars and races."""

from __future__ import annotations

import math

import pytest

from boxbox.model import CarSetup
from boxbox.model.car import FWD, RWD
from boxbox.robot.base import race_options
from boxbox.torcs import catalog, wire
from boxbox.torcs.car_setup import SLOTS, apply_setup, car_settings, checked_setup, slot_values
from boxbox.torcs.messages import fuel_reply
from helpers import run_boxbox
from trackdata import load

CATEGORY = """<params name="testcat" type="param">
  <section name="Rear Wing"><attnum name="angle" unit="deg" min="0" max="20" val="10"/></section>
  <section name="Drivetrain"><attstr name="type" val="RWD"/></section>
</params>"""
SUSPENSION = '<attnum name="spring" unit="lbs/in" min="{lo}" max="{hi}" val="5500"/>'
CAR = f"""<params name="test-car" type="param">
  <section name="Car"><attstr name="category" val="testcat"/></section>
  <section name="Rear Wing"><attnum name="angle" unit="deg" min="5" max="30" val="12"/></section>
  <section name="Gearbox"><section name="gears">
    <section name="1"><attnum name="ratio" min="0.5" max="5" val="3.0"/></section>
    <section name="2"><attnum name="ratio" min="0" max="5" val="1.9"/></section>
  </section></section>
  <section name="Rear Differential"><attnum name="ratio" min="1" max="10" val="4.5"/></section>
  <section name="Front Right Suspension">{SUSPENSION.format(lo=500, hi=10000)}</section>
  <section name="Front Left Suspension">{SUSPENSION.format(lo=1000, hi=9000)}</section>
  <section name="Front Right Wheel"><attnum name="ride height" unit="mm" min="70" max="120" val="90"/></section>
  <section name="Front Left Wheel"><attnum name="ride height" unit="mm" min="70" max="120" val="90"/></section>
  <section name="Front Anti-Roll Bar"><attnum name="spring" unit="lbs/in" val="0"/></section>
  <section name="Brake System"><attnum name="max pressure" unit="kPa" min="5000" max="40000.0.0" val="29000"/></section>
</params>"""
LBS_PER_IN = 0.45359237 / 0.0254  # N/m: TORCS's pound is a mass


@pytest.fixture(autouse=True)
def test_car(tmp_path, monkeypatch):
    """The installed TORCS: a car `test-car` of the category `testcat`."""
    data = tmp_path / "torcs"
    (data / "cars" / "test-car").mkdir(parents=True)
    (data / "categories").mkdir()
    (data / "cars" / "test-car" / "test-car.xml").write_text(CAR)
    (data / "categories" / "testcat.xml").write_text(CATEGORY)
    monkeypatch.setenv("BOXBOX_TORCS_DATA", str(data))
    car_settings.cache_clear()
    catalog.cars.cache_clear()
    yield data
    car_settings.cache_clear()
    catalog.cars.cache_clear()


def test_each_setting_is_read_in_si_with_the_range_both_files_and_all_its_wheels_allow():
    settings = car_settings("test-car").settings
    wing = settings["rear_wing_angle_rad"]  # the car's 5..30 deg within the category's 0..20
    assert (wing.value, wing.lo, wing.hi) == pytest.approx((math.radians(12), math.radians(5), math.radians(20)))
    spring = settings["front_spring_npm"]  # the left wheel's 1000..9000 lbs/in within the right's
    assert (spring.value, spring.lo, spring.hi) == pytest.approx((5500 * LBS_PER_IN, 1000 * LBS_PER_IN,
                                                                 9000 * LBS_PER_IN))
    assert settings["front_ride_height_m"].lo == pytest.approx(0.07)
    assert settings["brake_pressure_max_pa"].hi == 40000e3  # "40000.0.0" read as TORCS's strtod does
    assert settings["front_anti_roll_npm"].lo == settings["front_anti_roll_npm"].hi == 0.0  # no range: fixed
    assert (settings["gear_ratio_1"].value, settings["final_drive_ratio"].value) == (3.0, 4.5)
    assert "gear_ratio_3" not in settings and "rear_spring_npm" not in settings  # not in its files


def test_a_value_outside_the_cars_range_is_one_line_naming_the_range():
    car = car_settings("test-car")
    assert car.problem(CarSetup(final_drive_ratio=4.0, front_spring_npm=60000.0, gear_ratios=(2.8, 1.8))) is None
    assert car.problem(CarSetup(final_drive_ratio=12.0)) == "final_drive_ratio=12 is outside test-car's range 1 to 10"
    assert car.problem(CarSetup(front_ride_height_m=0.05)) == \
        "front_ride_height_m=0.05 is outside test-car's range 0.07 to 0.12"
    assert car.problem(CarSetup(gear_ratios=(3.0,) * 3)) == "gear_ratio_3: test-car has no such setting"
    stiff = CarSetup(front_spring_npm="stiff")  # type: ignore[arg-type]
    assert car.problem(stiff) == "front_spring_npm must be a number or None, got str"
    assert car.problem(CarSetup(final_drive_ratio=math.nan)) == "final_drive_ratio=nan must be a finite number"
    assert car.problem(CarSetup(front_anti_roll_npm=100.0)) == \
        "front_anti_roll_npm=100 is outside test-car's range 0 to 0"


def test_the_settings_of_a_race_set_the_car_over_the_robots_answer():
    options = race_options({"final_drive_ratio": 4.2, "mu_scale": 0.9, "front_spring_npm": 70000.0})
    assert options.robot_args == {"set": {"mu_scale": 0.9}}  # the robot's parameters
    assert options.car_setup == {"final_drive_ratio": 4.2, "front_spring_npm": 70000.0}
    setup, problem = checked_setup(CarSetup(rear_wing_angle_rad=0.2, final_drive_ratio=5.0), options.car_setup,
                                   "test-car")
    assert problem is None
    assert setup == CarSetup(rear_wing_angle_rad=0.2, final_drive_ratio=4.2, front_spring_npm=70000.0)
    assert checked_setup("fast", {}, "test-car")[1] == "returned str, not CarSetup or None"
    assert checked_setup(CarSetup(rear_wing_angle_rad=0.05), {}, "test-car")[1] == \
        "rear_wing_angle_rad=0.05 is outside test-car's range 0.0872665 to 0.349066"
    _, car = load("e-track-2")
    apply_setup(car, setup)
    assert (car.rear_wing_angle_rad, car.spring_fr_npm, car.spring_fl_npm) == (0.2, 70000.0, 70000.0)


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


def test_a_setting_out_of_range_stops_the_race_before_torcs_starts(tmp_path, test_car):
    setup = tmp_path / "setup.toml"
    setup.write_text("final_drive_ratio = 3.6\nfront_spring_npm = 1e6\n")
    proc = run_boxbox("race", "--setup", str(setup), "--car", "test-car", "--laps", "1", "--run-dir",
                      str(tmp_path / "run"), env={"BOXBOX_TORCS_DATA": str(test_car)})
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "front_spring_npm=1e+06 is outside test-car's range 17858 to 160722" in proc.stderr
    assert not (tmp_path / "run").exists()


def test_a_study_searches_setup_settings_over_the_cars_ranges():
    from boxbox.robot.tutorial import TutorialRobot
    from boxbox.tune.space import defaults_in_space, distributions, tune_space

    space = tune_space(TutorialRobot, "test-car")
    dists = distributions(space, ["final_drive_ratio", "front_spring_npm", "mu_scale"])
    assert (dists["final_drive_ratio"].low, dists["final_drive_ratio"].high) == (1.0, 10.0)
    assert dists["front_spring_npm"].high == pytest.approx(9000 * LBS_PER_IN)
    assert defaults_in_space(space, dists)["final_drive_ratio"] == 4.5  # the car's own: the first trial
    assert "front_anti_roll_npm" not in space.searchable_names()  # fixed in its file


def test_gear_ratios_are_settings_whole_or_one_gear_at_a_time_over_the_robots_answer():
    from boxbox.model.car_setup import setup_from

    options = race_options({"gear_ratios": "2.8,1.8", "gear_ratio_4": 1.1, "mu_scale": 0.9})
    assert options.car_setup == {"gear_ratios": "2.8,1.8", "gear_ratio_4": 1.1}  # --set's text, as parse_set gives it
    assert setup_from(options.car_setup).gear_ratios == (2.8, 1.8, None, 1.1)  # gear 3: the car's own
    robots = CarSetup(gear_ratios=(2.5, 1.7, 1.3))
    assert setup_from({"gear_ratio_2": 1.9}, robots).gear_ratios == (2.5, 1.9, 1.3)  # one gear over the robot's
    listed = CarSetup(gear_ratios=[2.5, 1.7])  # type: ignore[arg-type]
    assert setup_from({"gear_ratio_2": 1.9}, listed).gear_ratios == (2.5, 1.9)
    assert setup_from({"gear_ratios": [3.0]}, robots).gear_ratios == (3.0,)  # all of them in place of the robot's
    assert setup_from({"gear_ratios": 3}).gear_ratios == (3,)
    assert setup_from({}, robots) == robots
    values = dict(zip(SLOTS, slot_values(setup_from({"gear_ratio_2": 1.6}), RWD), strict=True))
    assert values[("Gearbox/gears/2", "ratio")] == 1.6 and math.isnan(values[("Gearbox/gears/1", "ratio")])
    car = car_settings("test-car")
    assert car.problem(setup_from({"gear_ratios": "2.8, 1.8"})) is None
    assert car.problem(setup_from({"gear_ratio_2": 6.0})) == "gear_ratio_2=6 is outside test-car's range 0 to 5"
    assert car.problem(setup_from({"gear_ratio_3": 1.0})) == "gear_ratio_3: test-car has no such setting"
    assert car.problem(setup_from({"gear_ratios": "2.8;1.8"})) == (
        "gear_ratios must be numbers from first gear on, got '2.8;1.8': gear_ratios=3.0,2.1,1.6 (from first gear "
        "on) or gear_ratio_2=2.1 (one gear)")


@pytest.mark.parametrize("given", [["--set", "gear_ratios=2.8,6.5"], ["--set", "gear_ratio_2=6.5"],
                                   ["--setup", "FILE"]])
def test_a_gear_ratio_out_of_range_stops_the_race_before_torcs_starts(tmp_path, test_car, given):
    setup = tmp_path / "setup.toml"
    setup.write_text("gear_ratios = [2.8, 6.5]\n")
    args = [str(setup) if a == "FILE" else a for a in given]
    proc = run_boxbox("race", *args, "--car", "test-car", "--laps", "1", "--run-dir", str(tmp_path / "run"),
                      env={"BOXBOX_TORCS_DATA": str(test_car)})
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "gear_ratio_2=6.5 is outside test-car's range 0 to 5" in proc.stderr
    assert not (tmp_path / "run").exists()


def test_a_study_searches_each_gear_as_a_parameter_of_its_own():
    from boxbox.robot.tutorial import TutorialRobot
    from boxbox.tune.space import distributions, tune_space

    dists = distributions(tune_space(TutorialRobot, "test-car"), ["gear_ratio_1", "gear_ratio_2"])
    assert (dists["gear_ratio_1"].low, dists["gear_ratio_1"].high) == (0.5, 5.0)
    options = race_options({"gear_ratio_2": 1.7, "mu_scale": 1.0})  # a trial's values
    assert options.car_setup == {"gear_ratio_2": 1.7} and options.robot_args == {"set": {"mu_scale": 1.0}}


def test_a_studys_unknown_name_is_a_short_line_with_the_nearest_of_the_cars_and_the_robots():
    from boxbox.errors import UsageError
    from boxbox.robot.tutorial import TutorialRobot
    from boxbox.tune.space import tune_space

    with pytest.raises(UsageError) as info:
        tune_space(TutorialRobot, "test-car", "boxbox").pick(["gear_ratio"])
    assert str(info.value) == ("--params: 'gear_ratio' is not a parameter of robot boxbox (did you mean gear_ratio_2, "
                               "gear_ratio_1 or learn_gain?); `boxbox params --car test-car` lists every one, with its "
                               "range")
    with pytest.raises(UsageError, match=r"mean final_drive_ratio\?\); `boxbox params --robot my.py:Mine --car"):
        tune_space(TutorialRobot, "test-car", "my.py:Mine").pick(["final_drive"])


def test_params_lists_the_cars_settings_by_part_with_unit_range_and_value(test_car):
    from click.testing import CliRunner

    from boxbox.cli import main_group
    from boxbox.model.car_setup import SCALAR_NAMES

    result = CliRunner().invoke(main_group, ["params", "--car", "test-car", "--set", "gear_ratios=2.8",
                                             "--set", "final_drive_ratio=4.2"], standalone_mode=False,
                                terminal_width=200)
    assert result.exception is None, result.output
    table = result.output[result.output.index("car setup: test-car"):]
    rows = {cells[1]: cells for line in table.splitlines()
            if len(cells := [c.strip() for c in line.split("│")[1:-1]]) == 6}
    assert rows["gear_ratio_1"] == ["gearbox", "gear_ratio_1", "2.8", "", "0.5 to 5", "--set"]
    assert rows["gear_ratio_2"] == ["", "gear_ratio_2", "1.9", "", "0 to 5", "car"]
    assert rows["final_drive_ratio"][2:] == ["4.2", "", "1 to 10", "--set"]
    assert rows["front_wing_angle_rad"] == ["wings", "front_wing_angle_rad", "-", "rad", "not in the car's files", ""]
    assert rows["rear_wing_angle_rad"][2:] == ["0.20944", "rad", "0.0872665 to 0.349066", "car"]
    assert rows["front_spring_npm"][2:] == ["98218.8", "N/m", "17858 to 160722", "car"]
    assert rows["front_anti_roll_npm"][4] == "fixed"
    assert set(SCALAR_NAMES) < set(rows)  # every field of CarSetup
    assert "mu_scale" in result.output  # and the robot's parameters, above
    bad = CliRunner().invoke(main_group, ["params", "--car", "test-car", "--set", "gear_ratio_1=9"],
                             standalone_mode=False)
    assert "gear_ratio_1=9 is outside test-car's range 0.5 to 5" in str(bad.exception)
