"""The traffic prediction (control/prediction.py) and the local planner (control/frenet_planner.py) on
plain numbers and constructed scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from boxbox.control.frenet_planner import Cars, Planner, PlannerParams, Scene, blend_bases
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


def test_the_quintic_bases_end_with_zero_rate():
    t = np.linspace(0.0, 2.0, 201)
    h, g = blend_bases(t, 1.5)
    assert h[0] == 0.0 and h[-1] == pytest.approx(1.0) and g[-1] == pytest.approx(0.0)
    assert np.gradient(h, t)[0] == pytest.approx(0.0, abs=1e-3) and np.gradient(g, t)[0] == pytest.approx(1.0 / 1.5,
                                                                                                            abs=1e-2)


# --- the planner on constructed scenes: a straight road 7 m each side of the middle, line in the middle


def _scene(v=40.0, d=0.0, offset=0.0, left=6.0, right=-6.0, profile=45.0):
    ahead = np.linspace(0.0, 200.0, 24)
    return Scene(v, d, offset, 0.0, 4.5, 2.0, np.full(24, profile), np.zeros(24), np.full(24, left),
                 np.full(24, right), ahead)


def _cars(*cars, t=None):
    """cars: (dist ahead m, to_middle m, speed m/s, index) each, on a straight line, never seen before."""
    planner_t = Planner().t_s if t is None else t
    dist = np.array([c[0] for c in cars])
    unseen = np.full((len(cars), STEPS), np.nan)
    pr = predict(np.array([500.0 + c[0] for c in cars]), np.array([c[1] for c in cars]),
                 np.array([c[2] for c in cars]), unseen, unseen, LAP_M, planner_t)
    return Cars(dist, np.full(len(cars), 2.0), np.full(len(cars), 4.5), np.array([c[3] for c in cars]), pr)


def test_alone_the_planner_keeps_the_line_at_full_speed():
    plan = Planner().plan(_scene(), _cars())
    assert plan.end_offset_m == pytest.approx(0.0) and plan.speed_scale == 1.0 and plan.risk == 0.0


def test_a_slower_car_ahead_on_the_line_is_passed_on_the_side_with_room():
    # the road's right is narrow (2.5 m of room from the line): the pass goes left
    plan = Planner().plan(_scene(right=-2.5), _cars((20.0, 0.0, 25.0, 3)))
    assert plan.end_offset_m > 2.5 and plan.speed_scale == 1.0 and plan.risk < 0.1
    assert plan.committed == -1  # 4 lengths ahead: the pass is not under way yet
    plan = Planner().plan(_scene(right=-2.5), _cars((12.0, 0.0, 25.0, 3)))
    assert plan.end_offset_m > 2.5 and plan.committed == 3 and plan.side == 1.0


def test_a_car_alongside_is_not_moved_into():
    planner = Planner()
    # a car 3 m to our left alongside at our speed, a slower car ahead in our lane: the pass goes right
    plan = planner.plan(_scene(), _cars((0.0, 3.0, 40.0, 1), (25.0, 0.0, 28.0, 2)))
    assert plan.end_offset_m < -2.0
    # with no room on the right, the plan stays in its lane (the brakes keep the gap to the car ahead)
    # rather than moving left into the car alongside, and knows the risk it is left with
    plan = Planner().plan(_scene(right=-0.5), _cars((0.0, 3.0, 40.0, 1), (25.0, 0.0, 28.0, 2)))
    assert plan.end_offset_m < 0.1 and plan.risk > 0.3


def test_a_lapped_car_is_passed_without_contact():
    # a car far slower (a lap down) on the line 40 m ahead: passed aside, clear of it over the horizon
    plan = Planner().plan(_scene(), _cars((40.0, 0.5, 15.0, 4)))
    assert abs(plan.end_offset_m - 0.5) > 2.5 + 1.0 and plan.risk < 0.05 and plan.speed_scale == 1.0


def test_a_pass_once_started_keeps_its_side():
    """Started on the right of a car 12 m ahead; it then drifts right, towards us: the left is
    clearer now, and without the commitment (switch_m 0) the plan swerves across its nose."""
    def second_plan(switch_m):
        planner = Planner(PlannerParams(switch_m=switch_m))
        first = planner.plan(_scene(left=7.0, right=-7.0), _cars((12.0, 0.3, 25.0, 3)))
        assert first.end_offset_m < -2.0 and first.committed == 3 and first.side == -1.0
        return planner.plan(_scene(offset=-1.0, d=-1.0, left=7.0, right=-7.0), _cars((12.0, -1.5, 25.0, 3)))

    kept, free = second_plan(20.0), second_plan(0.0)
    assert kept.end_offset_m < -2.0 and kept.committed == 3 and kept.side == -1.0
    assert free.end_offset_m > 2.0
