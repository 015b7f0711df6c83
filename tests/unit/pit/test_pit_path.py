"""robot.pitpath on recorded track data: the 7 points, smoothness, wrap-around, sides, speeds."""

from __future__ import annotations

import numpy as np
import pytest

from boxbox.control.pit_brake import PitBrakeFilter
from boxbox.robot.pitpath import PitPath
from trackdata import load

PIT_TRACKS = ["aalborg", "e-track-2", "e-track-4", "g-track-1", "michigan"]


@pytest.fixture(scope="module")
def et2() -> PitPath:
    track, car = load("e-track-2")
    return PitPath(track, car)


def test_e_track_2_wraps_around_the_start_line(et2: PitPath):
    track, car = load("e-track-2")
    st = track.seg["start_dist_m"]
    entry = float(st[1295])
    assert et2.entry_from_start_m == pytest.approx(entry)
    # box in seg 1321 (before the line), speed limit end in seg 38 and exit in seg 73 (after it)
    assert et2.limit_start_m == pytest.approx(float(st[1321]) - entry)
    assert et2.box_m == pytest.approx(track.dist_of(car.pit_seg, car.pit_to_start) - entry)
    assert et2.limit_end_m == pytest.approx(track.length_m - entry + float(st[38] + track.seg["length_m"][38]))
    assert et2.exit_m == pytest.approx(track.length_m - entry + float(st[73] + track.seg["length_m"][73]))
    assert 0.0 < et2.box_m < et2.limit_end_m < et2.exit_m < 700.0
    # coordinates across the line
    assert et2.to_spline_coord(entry) == pytest.approx(0.0)
    assert et2.to_spline_coord(10.0) == pytest.approx(track.length_m - entry + 10.0)
    assert et2.is_on_path(5200.0) and et2.is_on_path(5379.0) and et2.is_on_path(0.0) and et2.is_on_path(300.0)
    assert not et2.is_on_path(1000.0) and not et2.is_on_path(entry - 1.0)
    assert et2.signed_coord(entry - 61.5) == pytest.approx(-61.5)
    assert et2.signed_coord(300.0) == pytest.approx(et2.to_spline_coord(300.0))
    # the box offset after the line is found from distances before it
    assert et2.offset_at(track.dist_of(car.pit_seg, car.pit_to_start)) == pytest.approx(18.5, abs=1e-3)
    assert et2.offset_at(200.0) == pytest.approx(et2.lane_offset_m, abs=1e-3)  # in the lane after the line
    assert et2.offset_at(1000.0, default_m=-2.0) == -2.0


def test_passes_through_its_seven_points(et2: PitPath):
    assert len(et2.knots_m) == 7
    assert et2.knot_offsets_m == (0.0, 13.5, 13.5, 18.5, 13.5, 13.5, 0.0)
    x = np.array(et2.knots_m)
    assert np.all(np.diff(x) > 0.0)
    assert np.allclose(et2.spline(x), et2.knot_offsets_m, atol=1e-9)
    for k, y in zip(et2.knots_m, et2.knot_offsets_m, strict=False):
        assert et2.offset_at_s(k) == pytest.approx(y, abs=0.02)  # 1 m lookup grid
    # the knots are where the tutorial puts them (the lane point moved 1 m ahead of the box-length
    # point: on e-track-2 the own box is the first one, 7.5 m after the speed limit start)
    assert x[3] == pytest.approx(et2.box_m)
    assert x[2] == pytest.approx(et2.box_m - et2.box_length_m)
    assert x[4] == pytest.approx(et2.box_m + et2.box_length_m)
    assert x[1] == pytest.approx(min(et2.limit_start_m, x[2] - 1.0))
    assert x[5] == pytest.approx(et2.limit_end_m)
    assert x[0] == 0.0 and x[6] == pytest.approx(et2.exit_m)


@pytest.mark.parametrize("name", PIT_TRACKS)
def test_smooth_and_inside_the_band(name: str):
    track, car = load(name)
    p = PitPath(track, car)
    s = np.linspace(0.0, p.exit_m, 20001)
    y = p.spline(s)
    lo, hi = sorted((0.0, p.box_offset_m))
    assert y.min() >= lo - 1e-6 and y.max() <= hi + 1e-6  # never swings across the track or past the box
    # C1: the slope is continuous (checked across every knot), the bend bounded
    for k in p.knots_m[1:-1]:
        assert p.spline(k - 1e-6, 1) == pytest.approx(p.spline(k + 1e-6, 1), abs=1e-6)
    bend_max = 6.0 * 5.0 / p.box_length_m**2  # the tightest piece: the 5 m step into the box
    assert np.max(np.abs(p.spline(s, 2))) <= bend_max + 1e-9
    # no jump in slope anywhere: neighbouring slopes differ by at most the bend over the step
    assert np.max(np.abs(np.diff(p.spline(s, 1)))) <= bend_max * (s[1] - s[0]) * 1.01
    # tangential to the line at entry and exit
    assert p.spline(0.0, 1) == pytest.approx(0.0) and p.spline(p.exit_m, 1) == pytest.approx(0.0)
    # lookup grid agrees with the spline
    grid = np.array([p.offset_at_s(v) for v in s[::50]])
    assert np.max(np.abs(grid - p.spline(s[::50]))) < 0.02


def test_c2_cubic_spline_through_the_same_points_swings_across(et2: PitPath):
    """Why kind="hermite": the C2 CubicSpline through the 7 points leaves the band by metres."""
    track, car = load("e-track-2")
    cubic = PitPath(track, car, kind="cubic")
    y = cubic.spline(np.linspace(0.0, cubic.exit_m, 5001))
    assert np.allclose(cubic.spline(np.array(cubic.knots_m)), cubic.knot_offsets_m)
    assert y.min() < -5.0  # more than 5 m to the wrong side of the middle


@pytest.mark.parametrize("name", PIT_TRACKS)
def test_sides_and_plausible_offsets(name: str):
    track, car = load(name)
    p = PitPath(track, car)
    sign = 1.0 if track.pit.side == 2 else -1.0
    assert np.sign(p.box_offset_m) == sign and np.sign(p.lane_offset_m) == sign
    assert abs(p.box_offset_m) == pytest.approx(abs(car.pit_to_middle_m))
    assert abs(p.box_offset_m) - abs(p.lane_offset_m) == pytest.approx(track.pit.width_m)
    # the lane is off the track (the car fits beside the edge) and inside the box
    assert abs(p.lane_offset_m) - car.width_m / 2.0 > track.width_m / 2.0
    assert p.speed_limit_mps == pytest.approx(track.pit.speed_limit_mps - 0.5)
    assert p.box_length_m == track.pit.box_length_m
    # the box lies within the car's capture range [lmin, lmax]
    box_abs = (p.box_m + p.entry_from_start_m) % track.length_m
    assert car.pit_lmin_m <= box_abs <= car.pit_lmax_m


def test_right_side_pit_is_negative():
    track, car = load("aalborg")
    p = PitPath(track, car)
    assert p.box_offset_m == pytest.approx(-12.5) and p.lane_offset_m == pytest.approx(-7.5)
    assert p.offset_at_s(p.box_m) == pytest.approx(-12.5, abs=0.02)


def test_no_pit_lane_is_rejected():
    track, car = load("mixed-2")
    with pytest.raises(ValueError):
        PitPath(track, car)


def test_lane_friction():
    # e-track-2: main surface 1.04, the wide pit-side strip 1.0 (the 0.5 m wall strip at 0.05 is no lane)
    assert PitPath(*load("e-track-2")).surface_friction == pytest.approx(1.0)
    assert PitPath(*load("aalborg")).surface_friction == pytest.approx(1.1)
    assert PitPath(*load("michigan")).surface_friction == pytest.approx(1.05)


def test_entry_speed_constraints():
    p = PitPath(*load("g-track-1"))
    cons = p.entry_speed_constraints(1.15)
    assert all(0.0 <= s <= p.knots_m[1] for s, _ in cons)
    assert [s for s, _ in cons] == sorted(s for s, _ in cons)
    # the right-hand turn 50 m after the entry is the slowest point, slower than the path's own bends
    s_min, v_min = min(cons, key=lambda c: c[1])
    assert 40.0 < s_min < 70.0 and v_min < 35.0
    # on a straight pit entry only the path's own bend limits: v = sqrt(mu g / (6 h / L^2))
    q = PitPath(*load("e-track-2"))
    h, length = q.lane_offset_m, q.knots_m[1]
    v0 = dict(q.entry_speed_constraints(1.0))[0.0]
    assert v0 == pytest.approx((1.0 * 9.81 / (6.0 * h / length**2)) ** 0.5, rel=0.02)
    # less grip, lower speeds
    assert max(v for _, v in q.entry_speed_constraints(0.5)) < max(v for _, v in q.entry_speed_constraints(1.0))


def test_filter_on_e_track_2_geometry_stops_at_the_box():
    """PitPath + PitBrakeFilter (computed entry, surface mu, constant-decel stop) on e-track-2."""
    track, car = load("e-track-2")
    p = PitPath(track, car)
    mu = p.surface_friction

    def bd(v1: float, v2: float, m: float) -> float:
        return (v1 * v1 - v2 * v2) / (2.0 * m * 9.81)

    f = PitBrakeFilter(bd, limit_start_m=p.limit_start_m, box_m=p.box_m, limit_end_m=p.limit_end_m,
                       speed_limit_mps=p.speed_limit_mps, box_length_m=p.box_length_m,
                       pit_mu=mu, entry_constraints=p.entry_speed_constraints(mu), stop_mode="constant-decel")
    d, v = p.entry_from_start_m - 800.0, 65.0
    for _ in range(5000):
        s = p.signed_coord(d)
        r = f.filter(0.0, v, s, True, p.is_on_path(d))
        if r.phase == "hold":
            break
        if s >= p.limit_start_m:
            assert v <= p.speed_limit_mps + 0.5
        if r.brake > 0.0:
            v = max(0.0, v - r.brake * 10.0 * 0.02)
        d = (d + v * 0.02) % track.length_m
    assert abs(p.signed_coord(d) - p.box_m) < 0.5 and v < 1.0


def test_joins_the_line_with_its_slope():
    track, car = load("aalborg")
    flat = PitPath(track, car, entry_offset_m=-0.5, exit_offset_m=-3.7)
    sloped = PitPath(track, car, entry_offset_m=-0.5, exit_offset_m=-3.7, entry_slope=-0.18, exit_slope=-0.48)
    # the same offsets at the ends, the line's slope there (not the track's direction)
    for p in (flat, sloped):
        assert p.offset_at_s(0.0) == pytest.approx(-0.5) and p.offset_at_s(p.exit_m) == pytest.approx(-3.7, abs=1e-3)
    assert flat.slope_at_s(flat.exit_m - 0.01) == pytest.approx(0.0, abs=5e-3)
    assert sloped.slope_at_s(0.01) == pytest.approx(-0.18, abs=5e-3)
    assert sloped.slope_at_s(sloped.exit_m - 0.01) == pytest.approx(-0.48, abs=5e-3)
    # between the lane and the box nothing changes
    s = 0.5 * (sloped.knots_m[2] + sloped.knots_m[4])
    assert sloped.offset_at_s(s) == pytest.approx(flat.offset_at_s(s))
    with pytest.raises(ValueError):
        PitPath(track, car, exit_slope=float("nan"))


def test_exit_speed_caps_on_aalborg():
    """aalborg's exit rejoins a line that swings across the track into a right-hand turn: the
    path bends harder there than the line, so its caps sit below the line's 32-35 m/s, and each
    cap is reachable by braking at the given deceleration from the one before."""
    p = PitPath(*load("aalborg"), exit_offset_m=-4.7, exit_slope=-0.4)
    start, caps = p.exit_speed_caps(1.0, 5.0)
    assert start == pytest.approx(p.limit_end_m)
    assert len(caps) == int(p.exit_m - p.limit_end_m) + 1
    assert min(caps) < 32.0
    v = np.asarray(caps)
    assert np.all(v[:-1] ** 2 <= v[1:] ** 2 + 2.0 * 5.0 + 1e-6)  # braking ahead, never harder than 5 m/s^2
    # more grip, higher caps
    assert min(p.exit_speed_caps(1.5, 5.0)[1]) > min(caps)


@pytest.mark.parametrize("mu, decel", [(0.0, 5.0), (1.0, -1.0), (float("nan"), 5.0), (1.0, float("inf"))])
def test_exit_speed_caps_rejects_bad_input(mu, decel):
    with pytest.raises(ValueError):
        PitPath(*load("aalborg")).exit_speed_caps(mu, decel)
