"""Steering laws (boxbox.control.steering): hand-computed values and a kinematic bicycle model."""

import math

import pytest

from boxbox.control.steering import steer_to_line, steer_to_point, wrap_angle

WHEELBASE_M = 2.7
LOCK_RAD = 0.366  # car1-trb1's steer lock (21 deg)


# --- wrap_angle ---------------------------------------------------------------------------------

@pytest.mark.parametrize("a, expected", [
    (0.0, 0.0),
    (0.3, 0.3),
    (-0.3, -0.3),
    (0.3 + 4 * math.pi, 0.3),
    (-0.3 - 6 * math.pi, -0.3),
    (1.5 * math.pi, -0.5 * math.pi),
    (-1.5 * math.pi, 0.5 * math.pi),
    (math.pi - 0.01, math.pi - 0.01),
    (-math.pi + 0.01, -math.pi + 0.01),
    (2 * math.pi, 0.0),
])
def test_wrap_angle_values(a, expected):
    assert wrap_angle(a) == pytest.approx(expected, abs=1e-12)


def test_wrap_angle_range_and_equivalence():
    for k in range(-400, 401):
        a = k * 0.0731
        w = wrap_angle(a)
        assert -math.pi <= w <= math.pi
        # same direction
        assert math.cos(w) == pytest.approx(math.cos(a), abs=1e-12)
        assert math.sin(w) == pytest.approx(math.sin(a), abs=1e-12)
    assert abs(wrap_angle(math.pi)) == pytest.approx(math.pi)


# --- steer_to_point -----------------------------------------------------------------------------

def test_steer_to_point_straight_ahead_is_zero():
    assert steer_to_point(0.0, 0.0, 0.0, 20.0, 0.0, LOCK_RAD) == pytest.approx(0.0, abs=1e-15)
    # also with a heading and an offset position
    yaw = 2.0
    assert steer_to_point(5.0, -3.0, yaw, 5.0 + 20 * math.cos(yaw), -3.0 + 20 * math.sin(yaw),
                          LOCK_RAD) == pytest.approx(0.0, abs=1e-12)


def test_steer_to_point_is_angle_over_lock():
    # target 0.1 rad to the left of the car's axis, lock 0.4 -> 0.25
    assert steer_to_point(0.0, 0.0, 0.0, 10.0, 10.0 * math.tan(0.1), 0.4) == pytest.approx(0.25, rel=1e-12)
    # 45 deg left with a lock of 1 rad
    assert steer_to_point(0.0, 0.0, 0.0, 10.0, 10.0, 1.0) == pytest.approx(math.pi / 4, rel=1e-12)
    # the distance to the target does not matter, only the angle
    assert steer_to_point(0.0, 0.0, 0.0, 100.0, 100.0 * math.tan(0.1), 0.4) == pytest.approx(0.25, rel=1e-12)


def test_steer_to_point_left_is_positive():
    assert steer_to_point(0.0, 0.0, 0.0, 10.0, 1.0, LOCK_RAD) > 0.0
    assert steer_to_point(0.0, 0.0, 0.0, 10.0, -1.0, LOCK_RAD) < 0.0
    # heading north (yaw pi/2): west (negative x) is to the left
    assert steer_to_point(0.0, 0.0, math.pi / 2, -1.0, 10.0, LOCK_RAD) > 0.0
    assert steer_to_point(0.0, 0.0, math.pi / 2, 1.0, 10.0, LOCK_RAD) < 0.0
    # symmetric
    left = steer_to_point(0.0, 0.0, 0.0, 10.0, 0.5, LOCK_RAD)
    right = steer_to_point(0.0, 0.0, 0.0, 10.0, -0.5, LOCK_RAD)
    assert left == pytest.approx(-right, rel=1e-12)


def test_steer_to_point_relative_to_car_position_and_yaw():
    # car at (100, 50) heading 30 deg; target 0.05 rad to the left of that heading
    yaw = math.radians(30.0)
    tx = 100.0 + 40.0 * math.cos(yaw + 0.05)
    ty = 50.0 + 40.0 * math.sin(yaw + 0.05)
    assert steer_to_point(100.0, 50.0, yaw, tx, ty, 0.5) == pytest.approx(0.1, rel=1e-9)


def test_steer_to_point_wraps_across_pi():
    # yaw 3.0 rad, target direction -3.0 rad: 0.283 rad to the LEFT (not 6 rad to the right)
    d = -3.0
    s = steer_to_point(0.0, 0.0, 3.0, 10 * math.cos(d), 10 * math.sin(d), 0.5)
    assert s == pytest.approx((2 * math.pi - 6.0) / 0.5, rel=1e-9)
    # and the mirror case
    s = steer_to_point(0.0, 0.0, -3.0, 10 * math.cos(3.0), 10 * math.sin(3.0), 0.5)
    assert s == pytest.approx(-(2 * math.pi - 6.0) / 0.5, rel=1e-9)


def test_steer_to_point_clamps_to_full_lock():
    assert steer_to_point(0.0, 0.0, 0.0, 1.0, 10.0, LOCK_RAD) == 1.0  # far left
    assert steer_to_point(0.0, 0.0, 0.0, 1.0, -10.0, LOCK_RAD) == -1.0  # far right
    assert steer_to_point(0.0, 0.0, 0.0, -10.0, 0.1, LOCK_RAD) == 1.0  # behind, slightly left
    assert steer_to_point(0.0, 0.0, 0.0, -10.0, -0.1, LOCK_RAD) == -1.0


# --- steer_to_line: each term by hand -------------------------------------------------------------

def _line(he=0.0, e=0.0, k=0.0, v=30.0, yr=None, wheelbase=WHEELBASE_M, lock=LOCK_RAD, **kw):
    """yr defaults to v * k: the yaw rate the line needs, so the damping term is zero."""
    return steer_to_line(he, e, k, v, v * k if yr is None else yr, wheelbase, lock, **kw)


def test_steer_to_line_zero_when_on_a_straight_line():
    assert _line() == 0.0


def test_steer_to_line_feed_forward_is_atan_of_wheelbase_times_curvature():
    # a tight turn (R = 5 m) so atan(L k) differs clearly from L k: atan(0.54) = 0.4951
    k = 0.2
    assert _line(k=k, lock=0.6) == pytest.approx(math.atan(WHEELBASE_M * k) / 0.6, rel=1e-12)
    assert _line(k=-k, lock=0.6) == pytest.approx(-math.atan(WHEELBASE_M * k) / 0.6, rel=1e-12)
    # a gentle turn: left turn -> steer left; depends on the wheelbase
    assert _line(k=0.01) == pytest.approx(math.atan(0.027) / LOCK_RAD, rel=1e-12)
    assert _line(k=0.01, wheelbase=4.0) == pytest.approx(math.atan(0.04) / LOCK_RAD, rel=1e-12)
    # the feed-forward does not depend on speed (kinematic steady state)
    assert _line(k=0.01, v=10.0) == pytest.approx(_line(k=0.01, v=70.0), rel=1e-12)


def test_steer_to_line_heading_error_is_added_in_radians():
    assert _line(he=0.1, lock=0.5) == pytest.approx(0.2, rel=1e-12)
    assert _line(he=-0.1, lock=0.5) == pytest.approx(-0.2, rel=1e-12)
    # line heading to the left of the car (he > 0) -> steer left
    assert _line(he=0.02) > 0.0


def test_steer_to_line_lateral_correction_sign_and_value():
    # line 1 m to the LEFT of the car -> steer LEFT
    assert _line(e=1.0) > 0.0
    assert _line(e=-1.0) < 0.0
    # Stanley-type: atan(gain * e / (|v| + soft))
    assert _line(e=1.0, v=15.0, lock=0.5) == pytest.approx(math.atan(2.0 * 1.0 / 20.0) / 0.5, rel=1e-12)
    assert _line(e=-3.0, v=45.0, lock=0.5) == pytest.approx(math.atan(2.0 * -3.0 / 50.0) / 0.5, rel=1e-12)
    assert _line(e=1.0, v=15.0, lock=0.5, lateral_gain=4.0) == pytest.approx(math.atan(0.2) / 0.5, rel=1e-12)
    assert _line(e=1.0, v=15.0, lock=0.5, soft_speed_mps=1.0) == pytest.approx(math.atan(2.0 / 16.0) / 0.5,
                                                                                   rel=1e-12)
    # standing still: soft speed only; reversing: |v|
    assert _line(e=1.0, v=0.0, lock=0.5) == pytest.approx(math.atan(2.0 / 5.0) / 0.5, rel=1e-12)
    assert _line(e=1.0, v=-15.0, yr=0.0, lock=0.5) == pytest.approx(math.atan(2.0 / 20.0) / 0.5, rel=1e-12)
    # weaker at high speed (same distance to converge, not the same time)
    assert _line(e=1.0, v=80.0) < _line(e=1.0, v=20.0)


def test_steer_to_line_yaw_damping_sign_and_value():
    # turning left faster than the (straight) line needs -> steer back to the right
    s = _line(yr=0.5, lock=0.5)
    assert s == pytest.approx(0.05 * (0.0 - 0.5) / 0.5, rel=1e-12)
    assert s < 0.0
    assert _line(yr=-0.5) > 0.0
    # on a left turn (needs v k = 0.3 rad/s) turning too slowly -> steer more to the left
    k, v = 0.01, 30.0
    base = math.atan(WHEELBASE_M * k)
    assert _line(k=k, v=v, yr=0.1, lock=0.5) == pytest.approx((base + 0.05 * (0.3 - 0.1)) / 0.5, rel=1e-12)
    assert _line(k=k, v=v, yr=0.1) > _line(k=k, v=v)
    # the damping constant is used
    assert _line(yr=0.5, lock=0.5, yaw_damping_s=0.2) == pytest.approx(0.2 * -0.5 / 0.5, rel=1e-12)
    assert _line(yr=0.5, yaw_damping_s=0.0) == 0.0


def test_steer_to_line_terms_add_up():
    he, e, k, v, yr = 0.03, -0.7, 0.004, 40.0, 0.2
    expected = (math.atan(WHEELBASE_M * k) + he + math.atan(2.0 * e / (v + 5.0)) + 0.05 * (v * k - yr)) / LOCK_RAD
    assert _line(he=he, e=e, k=k, v=v, yr=yr) == pytest.approx(expected, rel=1e-12)


def test_steer_to_line_clamps():
    assert _line(he=1.0) == 1.0
    assert _line(he=-1.0) == -1.0
    assert _line(e=100.0, v=0.0) == 1.0
    assert _line(e=-100.0, v=0.0) == -1.0
    assert _line(k=1.0) == 1.0  # R = 1 m: beyond the lock
    for he in (-3.0, -0.5, 0.0, 0.5, 3.0):
        for e in (-20.0, 0.0, 20.0):
            assert -1.0 <= _line(he=he, e=e, k=0.05, yr=-2.0) <= 1.0


def test_steer_to_line_understeer_term_is_u_v2_k():
    """Extra steer for the tyres' slip angles: understeer gradient times the lateral acceleration v^2 k."""
    u = 0.002
    assert _line(k=0.0, v=60.0, understeer_rad_per_mps2=u) == 0.0  # a straight asks no lateral acceleration
    # 30 m/s on R = 100 m: 9 m/s^2 -> 0.018 rad on top of atan(0.027)
    assert _line(k=0.01, v=30.0, lock=0.5, understeer_rad_per_mps2=u) == pytest.approx(
        (math.atan(WHEELBASE_M * 0.01) + 0.018) / 0.5, rel=1e-12)
    extra = [_line(k=k, v=v, understeer_rad_per_mps2=u) - _line(k=k, v=v) for k, v in
             ((0.005, 20.0), (0.005, 40.0), (-0.005, 20.0))]
    assert extra[0] > 0.0 and extra[2] < 0.0  # towards the turn: left turn left, right turn right
    assert extra[1] == pytest.approx(4.0 * extra[0], rel=1e-9)  # twice the speed, four times the term
    assert extra[2] == pytest.approx(-extra[0], rel=1e-12)
    # 80 m/s on R = 33 m: 0.384 rad + atan(0.081) = 0.465 rad, beyond the 0.366 rad lock (0.85 without the term)
    assert _line(k=0.03, v=80.0) < 1.0
    assert _line(k=0.03, v=80.0, understeer_rad_per_mps2=u) == 1.0
    assert _line(k=-0.03, v=80.0, understeer_rad_per_mps2=u) == -1.0


# --- steer_to_line closing the loop: a kinematic bicycle model ------------------------------------

DT_S = 0.02


def _straight_line(x, y, yaw):
    """The line y = 2 (the car starts at y = 0): lateral error, heading error, curvature."""
    return 2.0 - y, wrap_angle(0.0 - yaw), 0.0


def _circle(radius_m, left=True):
    """A circle through the origin heading +x, turning left (centre (0, R)) or right (centre (0, -R))."""
    cy = radius_m if left else -radius_m

    def path(x, y, yaw):
        dx, dy = x, y - cy
        r = math.hypot(dx, dy)
        radial = math.atan2(dy, dx)
        if left:  # counter-clockwise: the line's heading is the radial + 90 deg; the centre is to the left
            heading, lateral = radial + math.pi / 2, r - radius_m
        else:
            heading, lateral = radial - math.pi / 2, radius_m - r
        return lateral, wrap_angle(heading - yaw), (1.0 if left else -1.0) / radius_m

    return path


def _simulate(path, speed_mps, y0_m, distance_m=1000.0):
    """Kinematic bicycle: the steer command sets the yaw rate v tan(steer lock) / L at once."""
    x, y, yaw, yaw_rate = 0.0, y0_m, 0.0, 0.0
    travelled, trace = 0.0, []
    while travelled < distance_m:
        lateral, heading_error, k = path(x, y, yaw)
        trace.append((travelled, lateral))
        steer = steer_to_line(heading_error, lateral, k, speed_mps, yaw_rate, WHEELBASE_M, LOCK_RAD)
        assert -1.0 <= steer <= 1.0
        yaw_rate = speed_mps * math.tan(steer * LOCK_RAD) / WHEELBASE_M
        x += speed_mps * math.cos(yaw) * DT_S
        y += speed_mps * math.sin(yaw) * DT_S
        yaw += yaw_rate * DT_S
        travelled += speed_mps * DT_S
    return trace


def _assert_converges(trace, start_error_m):
    assert trace[0][1] == pytest.approx(start_error_m, abs=1e-9)
    converged_at = next(s for s, e in trace if abs(e) < 0.2)
    assert converged_at < 150.0
    # once there, it stays there: no overshoot beyond 0.2 m and no growing oscillation
    after = [abs(e) for s, e in trace if s >= 150.0]
    assert max(after) < 0.2
    early = max(abs(e) for s, e in trace if 150.0 <= s < 400.0)
    late = max(abs(e) for s, e in trace if s >= 800.0)
    assert late <= early + 1e-6
    # overshoot past the line is small (well damped)
    overshoot = max(-e * math.copysign(1.0, start_error_m) for s, e in trace)
    assert overshoot < 0.2


def test_bicycle_follows_a_straight_line_offset_by_2_m():
    trace = _simulate(_straight_line, 30.0, 0.0)
    _assert_converges(trace, 2.0)
    assert abs(trace[-1][1]) < 0.01  # a straight line is tracked exactly in the end


def test_bicycle_follows_a_straight_line_from_the_other_side():
    trace = _simulate(lambda x, y, yaw: (-2.0 - y, wrap_angle(-yaw), 0.0), 30.0, 0.0)
    _assert_converges(trace, -2.0)


@pytest.mark.parametrize("left", [True, False])
@pytest.mark.parametrize("start_offset_m", [2.0, -2.0])  # the line 2 m to the car's left / right
def test_bicycle_follows_a_circle_of_100_m(left, start_offset_m):
    # start 2 m from the circle (outside a left turn, inside a right turn for +2 m), tangent to it
    trace = _simulate(_circle(100.0, left), 30.0, -start_offset_m)
    _assert_converges(trace, start_offset_m)
    # steady state: the feed-forward holds the circle, the corrections stay small
    assert max(abs(e) for s, e in trace if s > 600.0) < 0.1


def test_bicycle_on_the_circle_stays_on_it():
    trace = _simulate(_circle(100.0), 30.0, 0.0, distance_m=700.0)
    assert max(abs(e) for s, e in trace) < 0.1


def test_bicycle_without_feed_forward_would_miss_the_circle():
    """Sanity check of the model: the feed-forward term is what holds a circle at speed."""
    path = _circle(100.0)
    x, y, yaw, yaw_rate = 0.0, 0.0, 0.0, 0.0
    worst = 0.0
    for _ in range(1000):
        lateral, he, k = path(x, y, yaw)
        worst = max(worst, abs(lateral))
        steer = steer_to_line(he, lateral, 0.0, 30.0, yaw_rate, WHEELBASE_M, LOCK_RAD, yaw_damping_s=0.0)
        yaw_rate = 30.0 * math.tan(steer * LOCK_RAD) / WHEELBASE_M
        x += 30.0 * math.cos(yaw) * DT_S
        y += 30.0 * math.sin(yaw) * DT_S
        yaw += yaw_rate * DT_S
    assert worst > 0.5  # steady-state error without feed-forward
