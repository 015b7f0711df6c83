"""The fuel model on plain numbers: simuv2 burns fuel_cons_factor x 1e-7 l per joule of engine work."""

import math

import numpy as np
import pytest

from boxbox.control.fuel import lap_fuel_l
from boxbox.robot.start_fuel import MODEL_MARGIN, NO_PIT_SPARE_LAPS, TRAFFIC_MARGIN, start_fuel_l


def test_steady_speed_burns_the_drags_work():
    # 1000 m at 50 m/s against CW 0.5: 1250 N over 1000 m = 1.25 MJ -> 0.125 l at factor 1
    steps = np.full(100, 10.0)
    litres = lap_fuel_l(steps, np.full(100, 50.0), 1000.0, 0.5, 1.0, 0.0)
    assert litres == pytest.approx(0.125)
    assert lap_fuel_l(steps, np.full(100, 50.0), 1000.0, 0.5, 1.2, 0.0) == pytest.approx(0.15)


def test_speeding_up_costs_the_kinetic_energy_and_braking_the_engine_brake():
    # a loop from 20 to 40 m/s and back, no drag: the way up costs m (40^2 - 20^2) / 2 = 600 kJ
    up = np.linspace(20.0, 40.0, 51)[:-1]
    down = np.linspace(40.0, 20.0, 51)[:-1]
    speeds = np.concatenate([up, down])
    steps = np.full(100, 5.0)
    without = lap_fuel_l(steps, speeds, 1000.0, 0.0, 1.0, 0.0)
    assert without == pytest.approx(0.06)
    braking_s = float(np.sum(steps[50:] / (0.5 * (speeds[50:] + np.roll(speeds, -1)[50:]))))
    with_brake = lap_fuel_l(steps, speeds, 1000.0, 0.0, 1.0, 50_000.0)
    assert with_brake - without == pytest.approx(50_000.0 * braking_s * 1e-7)


@pytest.mark.parametrize("bad", [
    dict(speeds=np.full(10, 0.0)), dict(speeds=np.full(10, math.nan)), dict(steps=np.full(10, -1.0)),
    dict(speeds=np.full(9, 10.0)), dict(mass=0.0), dict(cw=-1.0), dict(brake=math.inf * -1),
])
def test_lap_fuel_rejects_bad_input(bad):
    args = dict(steps=np.full(10, 1.0), speeds=np.full(10, 10.0), mass=1000.0, cw=0.5, brake=0.0)
    args.update(bad)
    with pytest.raises(ValueError):
        lap_fuel_l(args["steps"], args["speeds"], args["mass"], args["cw"], 1.0, args["brake"])


def test_start_fuel_with_a_pit_lane_is_the_race_plus_the_strategys_margin():
    # 10 laps at 2 l, tank 100: one stint of 10.3 laps at 2 x 1.05 l
    assert start_fuel_l(10, 2.0, 100.0, True, False) == pytest.approx(10.3 * 2.0 * (1.0 + MODEL_MARGIN))
    # with other cars: the traffic margin on top
    assert start_fuel_l(10, 2.0, 100.0, True, True) == pytest.approx(
        10.3 * 2.0 * (1.0 + MODEL_MARGIN) * (1.0 + TRAFFIC_MARGIN))
    # a tank too small for the race: the first stint only, never more than the tank
    assert start_fuel_l(100, 2.0, 60.0, True, False) <= 60.0


def test_start_fuel_without_a_pit_lane_carries_a_lap_and_traffic_more():
    want = (10 + NO_PIT_SPARE_LAPS) * 2.0 * (1.0 + MODEL_MARGIN) * (1.0 + TRAFFIC_MARGIN)
    assert start_fuel_l(10, 2.0, 100.0, False, False) == pytest.approx(want)
    assert start_fuel_l(10, 2.0, 100.0, False, True) == pytest.approx(want)
    assert start_fuel_l(10, 2.0, 100.0, False, False) > start_fuel_l(10, 2.0, 100.0, True, True)
    assert start_fuel_l(100, 2.0, 94.0, False, False) == 94.0


@pytest.mark.parametrize("laps, lap_l, tank", [(0, 2.0, 100.0), (10, 0.0, 100.0), (10, math.nan, 100.0),
                                               (10, 2.0, -1.0)])
def test_start_fuel_rejects_bad_input(laps, lap_l, tank):
    with pytest.raises(ValueError):
        start_fuel_l(laps, lap_l, tank, True, False)
