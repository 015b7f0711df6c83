"""The safety envelope on plain numbers: the closed forms by hand, and two cars stepped at the drive
step that never touch while the rear one keeps the envelope (and do without it)."""

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from boxbox.control.braking import brake_distance, max_entry_speed
from boxbox.control.carmodel import CarModel
from boxbox.control.envelope import (
    front_speeds_mps,
    lateral_room_m,
    max_safe_speed_mps,
    rss_gap_m,
    rss_lateral_gap_m,
    safe_gap_m,
)
from boxbox.model.constants import DRIVE_STEP_S

PHYSICS_STEPS = 10  # TORCS steps its physics 10 or 11 times a drive step


def brakes(b_mps2: float):
    """(brakedist, entry_speed) of a car that brakes at a constant b_mps2."""
    def brakedist(v1: float, v2: float) -> float:
        return max(0.0, v1 * v1 - v2 * v2) / (2.0 * b_mps2)

    def entry(v2: float, dist_m: float) -> float:
        return math.sqrt(v2 * v2 + 2.0 * b_mps2 * max(dist_m, 0.0))
    return brakedist, entry


# --- the closed forms --------------------------------------------------------------------------------

def test_rss_gap_by_hand():
    # 30 m/s behind 20 m/s, rho 0.5 s, a 2, b_min 5, b_max 8:
    # 15 + 0.25 + 31^2 / 10 - 400 / 16 = 15.25 + 96.1 - 25 = 86.35 m
    assert rss_gap_m(30.0, 20.0, 5.0, 8.0, reaction_s=0.5, accel_mps2=2.0) == pytest.approx(86.35)
    # equal b, no reaction: the tutorial's braking distance from 30 to 20 m/s at 5 m/s^2, 50 m
    assert rss_gap_m(30.0, 20.0, 5.0, 5.0, reaction_s=0.0) == pytest.approx(50.0)
    assert rss_gap_m(10.0, 40.0, 5.0, 5.0) == 0.0  # the car ahead is much faster: any gap


def test_front_speeds_without_record_brake_at_b_max():
    # 20 m/s at 8 m/s^2: v^2 = 400 - 16 x; stands after 25 m
    speeds = front_speeds_mps(20.0, 8.0, 5.0, 30.0)
    assert speeds.tolist() == pytest.approx([20.0, math.sqrt(320), math.sqrt(240), math.sqrt(160), math.sqrt(80), 0, 0])


def test_front_speeds_with_record():
    record = np.array([50.0, 50.0, 30.0, np.nan, 60.0])
    # its speed now 40: no faster than that; the drop to 30 is kept (at 50 m/s^2 it could be at
    # 1600 - 1000 = 600 there); no record at 30 m: from 30 it may stand; at 40 m no slower than 40
    # (its speed now); past the record it may brake from there, 1600 - 1000
    speeds = front_speeds_mps(40.0, 50.0, 10.0, 50.0, record)
    assert speeds.tolist() == pytest.approx([40.0, 40.0, 30.0, 0.0, 40.0, math.sqrt(600)])
    # at 10 m/s^2 it cannot slow from 40 at 10 m to 30 at 20 m: 1600 - 200
    assert front_speeds_mps(40.0, 10.0, 10.0, 20.0, record)[2] == pytest.approx(math.sqrt(1400))


def test_safe_gap_equals_rss_when_the_car_ahead_may_brake_harder():
    brakedist, _ = brakes(6.0)
    for rear, front in ((30.0, 20.0), (50.0, 50.0), (20.0, 35.0)):
        speeds = front_speeds_mps(front, 9.0, 0.01, 300.0)
        got = safe_gap_m(rear, speeds, 0.01, brakedist, reaction_s=0.1, accel_mps2=3.0)
        # the grid takes each 1 cm step at its slower end: at most 9 / 6 x 1 cm more
        assert rss_gap_m(rear, front, 6.0, 9.0, 0.1, 3.0) <= got <= rss_gap_m(rear, front, 6.0, 9.0, 0.1, 3.0) + 0.02


def test_safe_gap_is_the_tutorials_braking_distance_behind_a_car_that_holds_its_speed():
    # a record at its speed now and brakes that cannot slow it within the reach: brakedist(v, u) + v rho
    model = CarModel(mass_kg=1200.0, ca=2.92, cw=0.43, mu=1.6)

    def brakedist(v1: float, v2: float) -> float:
        return brake_distance(v1, v2, 1.6, model)

    speeds = front_speeds_mps(40.0, 1e-6, 10.0, 500.0, np.full(60, 40.0))
    assert safe_gap_m(70.0, speeds, 10.0, brakedist) == pytest.approx(brakedist(70.0, 40.0) + 70.0 * DRIVE_STEP_S)


def test_max_safe_speed_is_the_inverse_of_safe_gap():
    model = CarModel(mass_kg=1200.0, ca=2.92, cw=0.43, mu=1.6)
    speeds = front_speeds_mps(30.0, 14.0, 5.0, 400.0, np.concatenate([np.full(20, 30.0), np.full(60, 15.0)]))

    def brakedist(v1: float, v2: float) -> float:
        return brake_distance(v1, v2, 1.6, model)

    def entry(v2: float, dist_m: float) -> float:
        return max_entry_speed(v2, dist_m, 1.6, model)

    for gap_m in (2.0, 20.0, 80.0):
        v = max_safe_speed_mps(gap_m, speeds, 5.0, entry, accel_mps2=8.0)
        assert safe_gap_m(v, speeds, 5.0, brakedist, accel_mps2=8.0) <= gap_m + 1e-6
        assert safe_gap_m(v + 0.1, speeds, 5.0, brakedist, accel_mps2=8.0) > gap_m  # no more than a hair low


def test_rss_lateral_gap_by_hand():
    # both 1 m/s towards, rho 0.1, a 0.5, b 2, mu 0.3: each 0.1025 + 1.05^2 / 4 = 0.378125 m
    assert rss_lateral_gap_m(1.0, 1.0, 2.0, 0.3, 0.1, 0.5) == pytest.approx(0.3 + 2 * 0.378125)
    # a car moving away at 2 m/s brakes away from us: 4 / 4 = 1 m of room given back
    assert rss_lateral_gap_m(1.0, -2.0, 2.0, 0.3, 0.0) == pytest.approx(0.3)
    assert lateral_room_m(1.5, 1.0, 0.0, 2.0, 0.3, 0.0) == pytest.approx(1.5 - 0.3 - 0.25)


@pytest.mark.parametrize("call", [
    lambda: rss_gap_m(math.nan, 10.0, 5.0, 5.0),
    lambda: rss_gap_m(10.0, 10.0, 0.0, 5.0),
    lambda: front_speeds_mps(-1.0, 5.0, 1.0, 10.0),
    lambda: front_speeds_mps(10.0, 5.0, 0.0, 10.0),
    lambda: front_speeds_mps(10.0, 5.0, 1.0, 10.0, np.array([math.inf])),
    lambda: safe_gap_m(10.0, np.array([]), 1.0, brakes(5.0)[0]),
    lambda: max_safe_speed_mps(math.nan, np.array([1.0]), 1.0, brakes(5.0)[1]),
    lambda: rss_lateral_gap_m(1.0, math.inf, 2.0, 0.3),
])
def test_bad_input_is_refused(call):
    with pytest.raises(ValueError, match="must|need"):
        call()


# --- two cars in a row ---------------------------------------------------------------------------------

def advance(x_m: float, v_mps: float, a_mps2: float, dt_s: float) -> tuple[float, float]:
    """Place and speed after dt_s at a_mps2, exactly; braking stops at a standstill."""
    if a_mps2 < 0.0 and v_mps + a_mps2 * dt_s <= 0.0:
        return x_m + v_mps * v_mps / (-2.0 * a_mps2), 0.0
    return x_m + v_mps * dt_s + 0.5 * a_mps2 * dt_s * dt_s, v_mps + a_mps2 * dt_s


def proper_accel(gap_m, v, u, x_front, b_rear, b_front, a_rear, record, step_m):
    """The rear car's throttle (+) or brake (-) for the next step: up to the proper response's speed."""
    brakedist, entry = brakes(b_rear)
    reach_m = brakedist(v + a_rear * DRIVE_STEP_S, 0.0) + step_m
    recorded = None
    if record is not None:
        recorded = np.array([record(x_front + i * step_m) for i in range(int(reach_m / step_m) + 2)])
    ahead = front_speeds_mps(u, b_front, step_m, reach_m, recorded)
    safe = max_safe_speed_mps(gap_m, ahead, step_m, entry, accel_mps2=a_rear)
    return -b_rear if v > safe else min(a_rear, (safe - v) / DRIVE_STEP_S)


def run_in_line(gap_m: float, rear_mps: float, front_mps: float, b_rear: float, b_front: float, a_rear: float,
                brake_at_s: float, respond: bool, record=None, seconds: float = 12.0, step_m: float = 2.0) -> float:
    """Two cars stepped at the drive step (the physics in ten steps each): the car ahead drives its
    record (a function of distance) or holds its speed, and from brake_at_s on brakes as hard as
    its prior allows (b_front) to a standstill; the rear car wants 90 m/s at a_rear and, with
    respond, keeps to the proper response (brakes at b_rear above it).  Returns the smallest bumper gap."""
    x_front, x_rear, u, v, lowest = gap_m, 0.0, front_mps, rear_mps, gap_m
    dt = DRIVE_STEP_S / PHYSICS_STEPS
    for k in range(int(seconds / DRIVE_STEP_S)):
        if k * DRIVE_STEP_S > brake_at_s and u == 0.0 and v == 0.0:
            break
        want = a_rear
        if respond:
            want = proper_accel(x_front - x_rear, v, u, x_front, b_rear, b_front, a_rear, record, step_m)
        for _ in range(PHYSICS_STEPS):
            goal = 0.0 if k * DRIVE_STEP_S >= brake_at_s else (record(x_front) if record else front_mps)
            x_front, u = advance(x_front, u, -min(b_front, (u - goal) / dt) if u > goal else 0.0, dt)
            x_rear, v = advance(x_rear, v, want if v < 90.0 or want < 0.0 else 0.0, dt)
            lowest = min(lowest, x_front - x_rear)
    return lowest


def start_gap(rear_mps, front_mps, b_rear, b_front, extra_m):
    """A gap from which full braking now is safe (no reaction), plus extra_m."""
    return safe_gap_m(rear_mps, front_speeds_mps(front_mps, b_front, 5.0, 1000.0), 5.0, brakes(b_rear)[0], 0.0) \
        + extra_m


@settings(max_examples=25, deadline=None)
@given(rear=st.floats(0.0, 60.0), front=st.floats(0.0, 60.0), b_rear=st.floats(6.0, 15.0),
       b_front=st.floats(4.0, 20.0), a_rear=st.floats(0.0, 10.0), extra=st.floats(0.0, 40.0),
       brake_at=st.floats(0.0, 3.0))
def test_the_proper_response_never_touches_a_car_that_brakes_as_hard_as_it_can(rear, front, b_rear, b_front,
                                                                              a_rear, extra, brake_at):
    gap = start_gap(rear, front, b_rear, b_front, extra)
    lowest = run_in_line(gap, rear, front, b_rear, b_front, a_rear, brake_at, respond=True, seconds=8.0, step_m=5.0)
    assert lowest >= -1e-6


def test_without_the_response_the_same_cars_collide():
    gap = start_gap(50.0, 50.0, 10.0, 12.0, 5.0)
    assert run_in_line(gap, 50.0, 50.0, 10.0, 12.0, 5.0, 1.0, respond=True) >= 0.0
    assert run_in_line(gap, 50.0, 50.0, 10.0, 12.0, 5.0, 1.0, respond=False) < 0.0


def corner(low_mps: float = 20.0, decel_mps2: float = 12.0):
    """A recorded lap as speed by distance: 60 m/s, down to low_mps between 300 and 360 m, braking
    at decel_mps2 before it and speeding up at 5 m/s^2 after."""
    def speed_mps(x_m: float) -> float:
        if 300.0 <= x_m <= 360.0:
            return low_mps
        if x_m < 300.0:
            return min(60.0, math.sqrt(low_mps ** 2 + 2.0 * decel_mps2 * (300.0 - x_m)))
        return min(60.0, math.sqrt(low_mps ** 2 + 10.0 * (x_m - 360.0)))
    return speed_mps


def test_behind_a_car_on_its_record_the_prior_keeps_a_closer_gap_and_still_no_contact():
    # the car ahead drives its record and never brakes on the straight: the prior (its record)
    # lets us follow closer than RSS's worst case (braking at 14 m/s^2 any time), and both are clean
    kwargs = dict(gap_m=60.0, rear_mps=60.0, front_mps=60.0, b_rear=12.0, b_front=14.0, a_rear=6.0,
                  brake_at_s=math.inf, respond=True, seconds=10.0)
    with_record = run_in_line(record=corner(), **kwargs)
    worst_case = run_in_line(**kwargs)
    assert 0.0 <= with_record < worst_case / 10


@settings(max_examples=10, deadline=None)
@given(low=st.floats(5.0, 40.0), decel=st.floats(8.0, 14.0), b_rear=st.floats(6.0, 12.0),
       a_rear=st.floats(0.0, 10.0), place=st.floats(0.0, 300.0), rear=st.floats(20.0, 60.0),
       front=st.floats(20.0, 60.0), extra=st.floats(0.0, 20.0))
# following closely into a braking zone where it slows harder than we can: the tutorial's gap (our
# braking distance to its speed now) runs into it here
@example(low=5.0, decel=14.0, b_rear=6.0, a_rear=0.0, place=100.0, rear=50.0, front=50.0, extra=0.0)
def test_behind_a_car_that_brakes_to_its_record_the_proper_response_never_touches(low, decel, b_rear, a_rear, place,
                                                                                   rear, front, extra):
    lap = corner(low, decel)
    front = min(front, lap(place))  # it may be below its record (held up), not above: it brakes to it
    ahead = front_speeds_mps(front, 14.0, 5.0, 500.0, np.array([lap(place + 5.0 * i) for i in range(101)]))
    gap = safe_gap_m(rear, ahead, 5.0, brakes(b_rear)[0], reaction_s=0.0) + extra

    def record(x_m: float) -> float:  # the front car starts gap ahead of the rear one, at `place` of its lap
        return lap(x_m - gap + place)

    lowest = run_in_line(gap, rear, front, b_rear, 14.0, a_rear, math.inf, respond=True, record=record, seconds=8.0,
                         step_m=5.0)
    assert lowest >= -1e-6


# --- two cars alongside --------------------------------------------------------------------------------

def run_alongside(gap_m: float, mine_mps: float, other_mps: float, a_lat: float, b_lat: float, margin_m: float,
                  respond: bool) -> float:
    """Two cars overlapping lengthwise, stepped at the drive step: each wants to move towards the
    other (lateral speeds + towards); with respond, each keeps lateral_room_m >= 0 (else brakes its
    speed towards the other down to 0).  Returns the smallest lateral gap."""
    speeds, lowest = [mine_mps, other_mps], gap_m
    for _ in range(int(4.0 / DRIVE_STEP_S)):
        room = lateral_room_m(max(gap_m, 0.0), speeds[0], speeds[1], b_lat, margin_m, accel_lat_mps2=a_lat)
        accels = []
        for i in (0, 1):
            if respond and room < 0.0:
                accels.append(-b_lat if speeds[i] > 0.0 else 0.0)
            else:
                accels.append(a_lat)
        moved = [advance(0.0, s, a, DRIVE_STEP_S) for s, a in zip(speeds, accels, strict=True)]
        gap_m -= moved[0][0] + moved[1][0]
        speeds = [m[1] for m in moved]
        lowest = min(lowest, gap_m)
    return lowest


@settings(max_examples=100, deadline=None)
@given(mine=st.floats(-2.0, 3.0), other=st.floats(-2.0, 3.0), a_lat=st.floats(0.0, 4.0), b_lat=st.floats(2.0, 8.0),
       extra=st.floats(0.0, 3.0))
def test_alongside_the_lateral_rule_keeps_the_margin(mine, other, a_lat, b_lat, extra):
    margin = 0.3
    gap = rss_lateral_gap_m(mine, other, b_lat, margin, 0.0) + extra
    assert run_alongside(gap, mine, other, a_lat, b_lat, margin, respond=True) >= margin - 1e-9


def test_alongside_without_the_rule_they_touch():
    gap = rss_lateral_gap_m(1.0, 0.5, 4.0, 0.3, 0.0) + 0.5
    assert run_alongside(gap, 1.0, 0.5, 2.0, 4.0, 0.3, respond=True) >= 0.3
    assert run_alongside(gap, 1.0, 0.5, 2.0, 4.0, 0.3, respond=False) < 0.0
