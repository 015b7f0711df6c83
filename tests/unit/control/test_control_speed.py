import math

import numpy as np
import pytest

from boxbox.control.braking import brake_distance_exact, max_entry_speed
from boxbox.control.carmodel import CarModel
from boxbox.control.speed import (
    MIDDLE_LINE_MU_SCALE,
    QUARTER_TURN_RAD,
    SpeedProfile,
    allowed_speed,
    bump_speed,
    crest_speed,
    segment_speed_limits,
)
from boxbox.model.constants import G_MPS2 as G
from boxbox.model.track import LEFT, RIGHT, STRAIGHT, Track
from trackdata import TRACKS, load

NO_AERO = CarModel(mass_kg=1000.0, ca=0.0, cw=0.0, mu=1.0)
AERO = CarModel(mass_kg=1000.0, ca=2.0, cw=0.5, mu=1.5)


def _track(segments: list[tuple[int, float, float]], width_m: float = 10.0, friction: float = 1.0) -> Track:
    """segments: (type, length_m for straights or arc_rad for turns, radius_m)."""
    types, lengths, radii, arcs = [], [], [], []
    for kind, size, radius in segments:
        types.append(kind)
        radii.append(radius if kind != STRAIGHT else 0.0)
        arcs.append(size if kind != STRAIGHT else 0.0)
        lengths.append(size * radius if kind != STRAIGHT else size)
    lengths_a = np.array(lengths)
    n = len(types)
    seg = {
        "type": np.array(types), "length_m": lengths_a, "radius_m": np.array(radii), "arc_rad": np.array(arcs),
        "start_dist_m": np.concatenate([[0.0], np.cumsum(lengths_a)[:-1]]),
        "width_m": np.full(n, width_m), "friction": np.full(n, friction),
    }
    return Track(name="test", category="road", length_m=float(lengths_a.sum()), width_m=width_m, seg=seg, pit=None)


# --- allowed_speed -------------------------------------------------------------------------------

def test_allowed_speed_without_aero_by_hand():
    assert allowed_speed(100.0, 1.0, NO_AERO) == pytest.approx(math.sqrt(981.0), rel=1e-12)  # 31.32 m/s
    assert allowed_speed(25.0, 1.6, NO_AERO) == pytest.approx(math.sqrt(1.6 * 9.81 * 25), rel=1e-12)


def test_allowed_speed_with_downforce_by_hand():
    # r CA mu / m = 100 * 2 * 1.5 / 1000 = 0.3 -> sqrt(1.5 * 9.81 * 100 / 0.7) = 45.85 m/s
    assert allowed_speed(100.0, 1.5, AERO) == pytest.approx(math.sqrt(1.5 * 9.81 * 100 / 0.7), rel=1e-12)
    assert allowed_speed(100.0, 1.5, AERO) == pytest.approx(45.849, abs=1e-3)


def test_allowed_speed_unlimited_above_critical_radius():
    # m / (CA mu) = 333.3 m: from there downforce grows as fast as the needed side force
    assert allowed_speed(334.0, 1.5, AERO) == 100.0
    assert allowed_speed(334.0, 1.5, AERO, max_speed_mps=math.inf) == math.inf
    assert allowed_speed(math.inf, 1.5, AERO) == 100.0
    assert allowed_speed(300.0, 1.5, AERO, max_speed_mps=math.inf) == pytest.approx(
        math.sqrt(1.5 * G * 300 / (1 - 0.9)), rel=1e-12)


def test_allowed_speed_is_capped():
    assert allowed_speed(1000.0, 1.0, NO_AERO) == pytest.approx(math.sqrt(9810.0))  # 99.05 < 100
    assert allowed_speed(2000.0, 1.0, NO_AERO) == 100.0
    assert allowed_speed(2000.0, 1.0, NO_AERO, max_speed_mps=150.0) == pytest.approx(math.sqrt(19620.0))


def test_allowed_speed_vertical_curvature_zero_is_unchanged():
    for r, mu, model in ((100.0, 1.0, NO_AERO), (100.0, 1.5, AERO), (25.0, 1.6, NO_AERO)):
        assert allowed_speed(r, mu, model, vertical_curvature_1pm=0.0) == allowed_speed(r, mu, model)


@pytest.mark.parametrize("model, mu", [(NO_AERO, 1.0), (AERO, 1.5)])
@pytest.mark.parametrize("kv", [0.002, -0.002, -0.02])
def test_allowed_speed_with_vertical_curvature_balances_side_force(model, mu, kv):
    """At the limit the side force v^2 / r equals the grip mu (g + v^2 (CA/m + kv)) per kg."""
    r = 100.0
    v = allowed_speed(r, mu, model, vertical_curvature_1pm=kv)
    assert v ** 2 / r == pytest.approx(mu * (G + v ** 2 * (model.ca / model.mass_kg + kv)), rel=1e-9)
    flat = allowed_speed(r, mu, model)
    assert (v > flat) if kv > 0 else (v < flat)  # a dip loads the tyres, a crest unloads them


def test_allowed_speed_vertical_curvature_no_aero_by_hand():
    # r mu kv = 100 * 1 * 0.002 = 0.2: v^2 = 981 / 0.8 in a dip, 981 / 1.2 over a crest
    assert allowed_speed(100.0, 1.0, NO_AERO, vertical_curvature_1pm=0.002) == pytest.approx(math.sqrt(1226.25))
    assert allowed_speed(100.0, 1.0, NO_AERO, vertical_curvature_1pm=-0.002) == pytest.approx(math.sqrt(817.5))


def test_allowed_speed_strong_dip_is_unlimited():
    # r mu kv >= 1: the extra load grows as fast as the needed side force
    assert allowed_speed(100.0, 1.0, NO_AERO, vertical_curvature_1pm=0.01) == 100.0
    assert allowed_speed(100.0, 1.0, NO_AERO, max_speed_mps=70.0, vertical_curvature_1pm=0.02) == 70.0
    # just below: finite, v^2 = 981 / 0.01
    assert allowed_speed(100.0, 1.0, NO_AERO, math.inf, vertical_curvature_1pm=0.0099) == pytest.approx(
        math.sqrt(98100.0))


# --- crest_speed ---------------------------------------------------------------------------------

def test_crest_speed_flat_and_dip_are_unlimited():
    for kv in (0.0, 0.001, 0.05):
        assert crest_speed(kv, NO_AERO) == 100.0
        assert crest_speed(kv, AERO, max_speed_mps=80.0) == 80.0
    assert crest_speed(-0.001, AERO) == 100.0  # downforce (CA/m = 0.002) outweighs a gentle crest


def test_crest_speed_no_aero_take_off_and_half_load():
    """Load per kg g + v^2 kv: zero at take-off (v^2 = g / |kv|), half the weight at v^2 = g / 2|kv|."""
    assert crest_speed(-0.01, NO_AERO, load_share=0.0) == pytest.approx(math.sqrt(G / 0.01))  # 31.3 m/s
    assert crest_speed(-0.01, NO_AERO, load_share=0.5) == pytest.approx(math.sqrt(0.5 * G / 0.01))
    assert crest_speed(-0.01, NO_AERO, load_share=1.0) == pytest.approx(0.0, abs=1e-9)
    assert crest_speed(-1e-5, NO_AERO) == 100.0  # 700 m/s, capped


def test_crest_speed_downforce_raises_it():
    v = crest_speed(-0.01, AERO, load_share=0.5)
    assert v > crest_speed(-0.01, NO_AERO, load_share=0.5)
    assert G + v ** 2 * (AERO.ca / AERO.mass_kg - 0.01) == pytest.approx(0.5 * G)  # exactly half the weight


def test_bump_speed_by_hand():
    """v^2 |kv| = bump_accel: 4 m/s^2 over a washboard of 0.04 1/m is 10 m/s; smooth road is free."""
    assert bump_speed(0.04, 4.0) == pytest.approx(10.0)
    assert bump_speed(0.01, 4.0) == pytest.approx(20.0)
    assert bump_speed(0.0, 4.0) == 100.0
    assert bump_speed(1e-6, 4.0, max_speed_mps=80.0) == 80.0


# --- segment_speed_limits ------------------------------------------------------------------------

def test_segment_limits_short_turn_gets_enlarged_radius():
    track = _track([
        (STRAIGHT, 100.0, 0), (LEFT, math.pi / 8, 50.0), (LEFT, math.pi / 8, 50.0),  # 45 deg left
        (STRAIGHT, 100.0, 0), (RIGHT, math.pi / 2, 50.0), (RIGHT, math.pi / 2, 50.0),  # 180 deg right
        (STRAIGHT, 100.0, 0),
    ])
    lim = segment_speed_limits(track, NO_AERO, mu_scale=1.0, full_arc_rad=QUARTER_TURN_RAD)
    assert lim[0] == lim[3] == lim[6] == 100.0
    # half a quarter turn: radius / 0.5
    assert lim[1] == lim[2] == pytest.approx(allowed_speed(100.0, 1.0, NO_AERO), rel=1e-12)
    # long turn keeps its radius
    assert lim[4] == lim[5] == pytest.approx(allowed_speed(50.0, 1.0, NO_AERO), rel=1e-12)
    # the exponent softens the enlargement: 50 / sqrt(0.5)
    soft = segment_speed_limits(track, NO_AERO, mu_scale=1.0, full_arc_rad=QUARTER_TURN_RAD, short_turn_exponent=0.5)
    assert soft[1] == pytest.approx(allowed_speed(50.0 / math.sqrt(0.5), 1.0, NO_AERO), rel=1e-12)
    # half the width added to the radius (the shipped robot's choice)
    wide = segment_speed_limits(track, NO_AERO, mu_scale=1.0, full_arc_rad=QUARTER_TURN_RAD, width_fraction=0.5)
    assert wide[4] == pytest.approx(allowed_speed(55.0, 1.0, NO_AERO), rel=1e-12)
    assert wide[1] == pytest.approx(allowed_speed(110.0, 1.0, NO_AERO), rel=1e-12)


def test_segment_limits_default_to_the_middle_line_at_70_percent_grip():
    """The defaults fit a car on the middle line (steer_to_line on it, docs/robots.md): no turn is
    taken as cut (with a quarter turn's rule, e-track-2 wrecked such a car), 70% of the grip."""
    track = _track([(STRAIGHT, 100.0, 0), (LEFT, math.pi / 8, 50.0), (LEFT, math.pi / 8, 50.0),
                    (STRAIGHT, 100.0, 0), (RIGHT, math.pi, 50.0)])
    lim = segment_speed_limits(track, NO_AERO)
    assert lim[1] == lim[2] == lim[4] == pytest.approx(allowed_speed(50.0, MIDDLE_LINE_MU_SCALE, NO_AERO), rel=1e-12)
    assert MIDDLE_LINE_MU_SCALE == 0.7


def test_segment_limits_turn_across_start_line_is_one_turn():
    # a 60 deg right turn split by the start line: 30 deg at the end of the lap, 30 deg at the start
    track = _track([
        (RIGHT, math.pi / 6, 40.0), (STRAIGHT, 200.0, 0), (LEFT, math.pi, 40.0), (STRAIGHT, 200.0, 0),
        (RIGHT, math.pi / 6, 40.0),
    ])
    lim = segment_speed_limits(track, NO_AERO, mu_scale=1.0, full_arc_rad=QUARTER_TURN_RAD)
    expected = allowed_speed(40.0 / (2 / 3), 1.0, NO_AERO)
    assert lim[0] == pytest.approx(expected, rel=1e-12)
    assert lim[4] == pytest.approx(expected, rel=1e-12)
    assert lim[2] == pytest.approx(allowed_speed(40.0, 1.0, NO_AERO), rel=1e-12)


def test_segment_limits_use_surface_and_tyre_friction():
    track = _track([(STRAIGHT, 100.0, 0), (LEFT, math.pi, 60.0)], friction=0.8)
    model = CarModel(mass_kg=1000.0, ca=0.0, cw=0.0, mu=1.5)
    lim = segment_speed_limits(track, model, mu_scale=0.9)
    assert lim[1] == pytest.approx(math.sqrt(0.8 * 1.5 * 0.9 * G * 60.0), rel=1e-12)


# --- SpeedProfile --------------------------------------------------------------------------------

def _assert_consistent(profile: SpeedProfile) -> None:
    v = profile.target_speeds
    assert np.all(np.isfinite(v))
    assert np.all(v <= profile.limits_mps + 1e-12)
    n = len(v)
    for i in range(n):
        reachable = max_entry_speed(float(v[(i + 1) % n]), profile.step_m, float(profile.mu[i]), profile.model)
        assert v[i] <= reachable * (1 + 1e-12)
        # the profile is the fastest such: each sample is at its limit or on a braking curve
        assert v[i] == pytest.approx(min(profile.limits_mps[i], reachable), rel=1e-12)


def test_profile_constant_limits_unchanged():
    p = SpeedProfile([50.0] * 100, 1.0, AERO)
    assert np.all(p.target_speeds == 50.0)
    assert p.length_m == 200.0


def test_profile_brakes_before_slow_section():
    limit = [80.0] * 500
    limit[300:310] = [20.0] * 10
    p = SpeedProfile(limit, 1.2, AERO, step_m=2.0)
    _assert_consistent(p)
    v = p.target_speeds
    assert v[300] == 20.0
    # the braking zone is as long as the exact braking distance from 80 to 20 m/s
    first_braking = int(np.argmax(v < 80.0))
    zone_m = (300 - first_braking) * 2.0
    assert zone_m == pytest.approx(brake_distance_exact(80.0, 20.0, 1.2, AERO), abs=2.0)
    assert np.all(np.diff(v[first_braking:301]) <= 0)
    # after the slow section the profile is not limited by acceleration (braking only)
    assert v[310] == 80.0


def test_profile_wraps_around_start_line():
    # a slow turn 10 m after the start line forces braking at the end of the lap
    limit = [90.0] * 1000
    limit[5:20] = [15.0] * 15
    p = SpeedProfile(limit, 1.0, AERO, step_m=2.0)
    _assert_consistent(p)
    v = p.target_speeds
    assert v[-1] < 30.0
    assert v[0] < v[-1] < v[-2]
    braking_m = brake_distance_exact(90.0, 15.0, 1.0, AERO)
    assert braking_m > 100.0
    assert v[1000 - int(braking_m / 2.0) + 10] < 90.0
    assert v[1000 - int(braking_m / 2.0) - 10] == 90.0


def test_profile_lower_friction_brakes_earlier():
    limit = [80.0] * 400
    limit[200] = 20.0
    grippy = SpeedProfile(limit, 1.6, AERO).target_speeds
    slippery = SpeedProfile(limit, 0.8, AERO).target_speeds
    assert np.all(slippery <= grippy)
    assert np.sum(slippery < 80.0) > np.sum(grippy < 80.0)


def test_profile_per_sample_friction():
    limit = [80.0] * 400
    limit[200] = 20.0
    mu = np.full(400, 1.0)
    mu[150:200] = 0.3  # ice just before the turn
    p = SpeedProfile(limit, mu, AERO)
    _assert_consistent(p)
    assert p.target_speeds[150] < SpeedProfile(limit, 1.0, AERO).target_speeds[150]


def test_speed_at_lookup_and_interpolation():
    limit = [80.0] * 100
    limit[50] = 20.0
    p = SpeedProfile(limit, 1.0, AERO, step_m=2.0)
    v = p.target_speeds
    assert p.speed_at(100.0) == v[50] == 20.0
    assert p.speed_at(98.0) == pytest.approx(v[49])
    assert p.speed_at(99.0) == pytest.approx((v[49] + v[50]) / 2)
    assert p.speed_at(100.0 + 200.0) == 20.0  # next lap
    assert p.speed_at(-100.0) == 20.0  # before the start line
    assert p.speed_at(199.0) == pytest.approx((v[99] + v[0]) / 2)  # between last sample and start
    assert type(p.speed_at(123.4)) is float
    assert p.distances_m[-1] == 198.0


def test_profile_from_curvature():
    k = np.zeros(200)
    k[100:120] = -0.02  # right turn, radius 50 m
    p = SpeedProfile.from_curvature(k, 1.5, AERO, step_m=2.0)
    assert p.limits_mps[0] == 100.0
    assert p.limits_mps[110] == pytest.approx(allowed_speed(50.0, 1.5, AERO))
    _assert_consistent(p)


def test_profile_from_track_samples_segment_limits():
    track = _track([(STRAIGHT, 301.0, 0), (LEFT, math.pi, 30.0), (STRAIGHT, 300.0, 0)])
    p = SpeedProfile.from_track(track, NO_AERO, step_m=2.0, mu_scale=1.0)
    assert p.length_m == pytest.approx(track.length_m)
    assert p.step_m == pytest.approx(track.length_m / round(track.length_m / 2.0))
    turn = allowed_speed(30.0, 1.0, NO_AERO)
    # the sample whose step reaches into the turn (which starts at 301 m) is already limited
    i = int(301.0 / p.step_m)
    assert p.limits_mps[i] == pytest.approx(turn)
    assert p.limits_mps[i - 1] == 100.0
    assert p.speed_at(301.0) <= turn + 1e-9
    assert p.speed_at(301.0 + 30 * math.pi - 0.5) <= turn + 1e-9
    _assert_consistent(p)


@pytest.mark.parametrize("name", TRACKS)
def test_profile_on_recorded_track_is_plausible(name):
    track, car = load(name)
    model = CarModel.from_car(car, fuel_l=car.initial_fuel_l)
    p = SpeedProfile.from_track(track, model)
    v = p.target_speeds
    assert np.all(np.isfinite(v))
    assert np.all((v >= 5.0) & (v <= 100.0))
    assert v.min() == pytest.approx(segment_speed_limits(track, model).min())
    assert v.max() > 50.0  # some straight is long enough to get fast
    _assert_consistent(p)
    assert 0.0 < p.speed_at(track.length_m / 3) <= 100.0
    # speed_at between samples never exceeds the limit of the segment at that distance
    seg_limits = segment_speed_limits(track, model)
    for dist_m in np.arange(0.0, track.length_m, 0.5).tolist():
        assert p.speed_at(dist_m) <= seg_limits[track.segment_at(dist_m)] + 1e-9


def test_profile_from_track_turn_across_start_line():
    track = _track([(LEFT, math.pi / 4, 40.0), (STRAIGHT, 500.0, 0), (LEFT, math.pi / 4, 40.0)])
    p = SpeedProfile.from_track(track, NO_AERO, mu_scale=1.0, full_arc_rad=QUARTER_TURN_RAD)
    turn = allowed_speed(40.0, 1.0, NO_AERO)  # 90 deg in total: no enlargement
    assert p.speed_at(0.0) == pytest.approx(turn)
    assert p.speed_at(track.length_m - 1.0) == pytest.approx(turn)
    assert p.speed_at(10 * math.pi + 2.5) > turn  # after the turn, limited only by the straight
    _assert_consistent(p)


# --- SpeedProfile over crests and dips -------------------------------------------------------------

def _slow_after_straight(kv_value: float, model: CarModel = NO_AERO) -> tuple[SpeedProfile, np.ndarray]:
    """60 m/s everywhere, 20 m/s at 800-820 m; vertical curvature kv_value over the 800 m before it."""
    limit = [60.0] * 1000
    limit[400:410] = [20.0] * 10
    kv = np.zeros(1000)
    kv[:400] = kv_value
    return SpeedProfile(limit, 1.0, model, step_m=2.0, vertical_curvature_1pm=kv), kv


def _assert_feasible_no_aero(p: SpeedProfile, kv: np.ndarray) -> None:
    """Each step: v_i^2 <= v_(i+1)^2 + 2 s mu (g + kv v_(i+1)^2) (load at the step's end, at least 0.1 g),
    and the profile is the fastest such."""
    v = p.target_speeds
    n = len(v)
    assert np.all(np.isfinite(v)) and np.all(v <= p.limits_mps + 1e-12)
    for i in range(n):
        v2 = float(v[(i + 1) % n])
        decel = p.mu[i] * max(0.1 * G, G + kv[i] * v2 * v2)
        reachable = math.sqrt(v2 * v2 + 2.0 * p.step_m * decel)
        assert v[i] <= reachable * (1 + 1e-12)
        assert v[i] == pytest.approx(min(p.limits_mps[i], reachable), rel=1e-12)


@pytest.mark.parametrize("model", [NO_AERO, AERO])
def test_profile_brakes_earlier_over_a_crest_later_in_a_dip(model):
    """Braking grip follows the load g + v^2 (CA/m + kv): less over a crest, more in a dip."""
    flat = SpeedProfile([60.0] * 400 + [20.0] * 10 + [60.0] * 590, 1.0, model).target_speeds
    crest = _slow_after_straight(-0.002, model)[0].target_speeds
    dip = _slow_after_straight(0.002, model)[0].target_speeds
    approach = slice(200, 400)
    assert np.all(crest[approach] <= flat[approach]) and np.any(crest[approach] < flat[approach] - 1.0)
    assert np.all(dip[approach] >= flat[approach]) and np.any(dip[approach] > flat[approach] + 1.0)
    assert np.sum(crest < 60.0) > np.sum(flat < 60.0) > np.sum(dip < 60.0)
    assert crest[400] == flat[400] == dip[400] == 20.0


@pytest.mark.parametrize("kv_value", [0.0, -0.002, 0.002])
def test_profile_braking_zone_over_constant_vertical_curvature_by_hand(kv_value):
    """No aero, constant kv: dv^2/ds = -2 mu (g + kv v^2), so s = ln((g + kv v1^2) / (g + kv v2^2)) / (2 mu kv)."""
    p, kv = _slow_after_straight(kv_value)
    _assert_feasible_no_aero(p, kv)
    v = p.target_speeds
    zone_m = (400 - int(np.argmax(v < 60.0))) * 2.0
    if kv_value == 0.0:
        expected = (60.0 ** 2 - 20.0 ** 2) / (2 * G)  # 163 m
    else:
        expected = math.log((G + kv_value * 3600.0) / (G + kv_value * 400.0)) / (2 * kv_value)  # 310 m / 118 m
    assert zone_m == pytest.approx(expected, abs=4.0)


@pytest.mark.parametrize("bank_deg", [-5.0, 0.0, 6.6, 12.0])
def test_allowed_speed_on_a_banked_turn_balances_side_force_and_grip(bank_deg: float) -> None:
    """At the returned speed the side force beyond what gravity gives along the bank is mu times
    the load of gravity across it and of the downforce (the turn's own push into the bank left out)."""
    model = CarModel(mass_kg=1150.0, ca=3.0, cw=0.4, mu=1.1)
    radius_m, b = 300.0, math.radians(bank_deg)
    v = allowed_speed(radius_m, model.mu, model, max_speed_mps=math.inf, bank_rad=b)
    side = v * v / radius_m - G * math.sin(b)
    load = G * math.cos(b) + v * v * model.ca / model.mass_kg
    assert side == pytest.approx(model.mu * load, rel=1e-9)


def test_banking_into_the_turn_is_faster_and_away_from_it_slower() -> None:
    model = CarModel(mass_kg=1150.0, ca=3.0, cw=0.4, mu=1.1)
    flat = allowed_speed(100.0, 1.1, model, math.inf)
    assert allowed_speed(100.0, 1.1, model, math.inf, bank_rad=math.radians(6.6)) > 1.04 * flat
    assert allowed_speed(100.0, 1.1, model, math.inf, bank_rad=math.radians(-3.0)) < flat


def test_cap_lowers_the_profile_to_a_ceiling_and_nothing_else():
    profile = SpeedProfile([30.0, 20.0, 40.0, 50.0], 1.0, NO_AERO, step_m=10.0)
    before = profile.target_speeds.copy()
    ceiling = np.array([math.inf, math.inf, 25.0, math.inf])
    profile.cap(ceiling)
    assert profile.target_speeds.tolist() == [before[0], before[1], 25.0, before[3]]
    assert profile.speed_at(20.0) == 25.0 and profile.speed_at(25.0) == pytest.approx(0.5 * (25.0 + before[3]))
    with pytest.raises(ValueError, match="4 samples"):
        profile.cap(np.array([1.0, 2.0]))
