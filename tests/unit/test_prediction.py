"""The traffic prediction (control/prediction.py) on plain numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from boxbox.control.prediction import SpreadParams, horizon_times, predict

T = horizon_times(3.0, 0.2)
LAP_M = 1000.0
STEPS = 200  # 5 m a step


def _one(s0=100.0, d0=0.0, v0=40.0, line=np.nan, speed=np.nan, **kw):
    return predict(np.array([s0]), np.array([d0]), np.array([v0]), np.full((1, STEPS), line),
                   np.full((1, STEPS), speed), LAP_M, T, **kw)


def test_horizon_times_and_their_checks():
    assert horizon_times(1.0, 0.25).tolist() == [0.0, 0.25, 0.5, 0.75, 1.0]
    for bad in ((0.0, 0.1), (1.0, 2.0), (math.nan, 0.1), (1.0, -0.1)):
        with pytest.raises(ValueError):
            horizon_times(*bad)


def test_a_car_never_seen_keeps_its_speed_and_lateral_position():
    pr = _one(d0=2.0)
    assert pr.travel_m[0, -1] == pytest.approx(120.0)  # 40 m/s for 3 s
    assert np.allclose(pr.d_m, 2.0)


def test_a_car_follows_its_observed_speed_profile_scaled_to_its_speed_of_now():
    speeds = np.full((1, STEPS), 50.0)
    speeds[0, 40:] = 25.0  # from 200 m on it was seen at half the speed
    pr = predict(np.array([100.0]), np.zeros(1), np.array([40.0]), np.zeros((1, STEPS)), speeds, LAP_M, T)
    # 40 m/s now against 50 seen here: 0.8 of its profile, so 20 m/s beyond 200 m
    v_end = (pr.travel_m[0, -1] - pr.travel_m[0, -2]) / 0.2
    assert v_end == pytest.approx(20.0, abs=0.5)
    assert pr.travel_m[0, -1] == pytest.approx(100.0 + 0.5 * 20.0, abs=3.0)  # 2.5 s at 40, then 20


def test_a_car_off_its_line_comes_back_to_it():
    pr = _one(d0=3.0, line=0.0, speed=40.0, p=SpreadParams(return_s=1.0))
    assert pr.d_m[0, 0] == pytest.approx(3.0)
    assert pr.d_m[0, 5] == pytest.approx(3.0 * math.exp(-1.0))  # t = 1 s
    assert abs(pr.d_m[0, -1]) < 0.2


def test_the_spread_grows_with_time_and_more_where_the_line_is_unknown_or_the_car_varies():
    seen, unseen = _one(line=0.0, speed=40.0), _one()
    assert np.all(np.diff(seen.sigma_d_m[0]) > 0.0) and np.all(np.diff(seen.sigma_s_m[0]) > 0.0)
    assert unseen.sigma_d_m[0, -1] > seen.sigma_d_m[0, -1] + 0.5
    wide = SpreadParams(max_lateral_m=10.0)
    seen = _one(line=0.0, speed=40.0, p=wide)
    varied = _one(line=0.0, speed=40.0, lateral_var_m=np.array([1.0]), speed_var_mps=np.array([2.0]), p=wide)
    assert varied.sigma_d_m[0, -1] > seen.sigma_d_m[0, -1] + 0.9
    assert varied.sigma_s_m[0, -1] == pytest.approx(seen.sigma_s_m[0, -1] + 2.0 * 3.0)
    # a braking car: along, 0.5 brake t^2 on top
    assert seen.sigma_s_m[0, -1] == pytest.approx(0.5 + 0.5 * 3.0 + 0.5 * 1.5 * 9.0)


def test_the_lap_wraps():
    speeds = np.full((1, STEPS), 40.0)
    speeds[0, :10] = 20.0  # the first 50 m of the lap, which a car at 990 m reaches at once
    pr = predict(np.array([990.0]), np.zeros(1), np.array([40.0]), np.zeros((1, STEPS)), speeds, LAP_M, T)
    assert pr.travel_m[0, -1] < 120.0 - 10.0  # slowed at 1000 m, the start of the next lap


@pytest.mark.parametrize("change", [
    {"s0": math.nan}, {"v0": -1.0}, {"lines": np.zeros((2, STEPS))}, {"t": np.array([0.1, 0.2])},
    {"length": 0.0}, {"lat": np.array([-1.0])}])
def test_bad_input_is_a_value_error(change):
    args = dict(s0=100.0, v0=40.0, lines=np.zeros((1, STEPS)), t=T, length=LAP_M, lat=None)
    args.update(change)
    with pytest.raises(ValueError):
        predict(np.array([args["s0"]]), np.zeros(1), np.array([args["v0"]]), args["lines"], np.zeros((1, STEPS)),
                args["length"], args["t"], lateral_var_m=args["lat"])
