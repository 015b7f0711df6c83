import dataclasses
import math

import pytest

from boxbox.control.braking import (
    BrakeModel,
    brake_distance,
    brake_distance_approx,
    brake_distance_exact,
    brake_limited_speed,
    max_entry_speed,
)
from boxbox.control.carmodel import CarModel
from boxbox.model.constants import G_MPS2 as G

RACE_CAR = CarModel(mass_kg=1200.0, ca=2.92, cw=0.43, mu=1.6)
NO_AERO = CarModel(mass_kg=1000.0, ca=0.0, cw=0.0, mu=1.0)
BIG_AERO = CarModel(mass_kg=1000.0, ca=10.0, cw=1.0, mu=1.6)


def _integrated_distance(v1: float, v2: float, mu: float, model: CarModel, step_m: float = 0.01) -> float:
    """RK4 in distance of dv/ds = -(c + d v^2) / v until v reaches v2."""
    c = mu * G
    d = (model.ca * mu + model.cw) / model.mass_kg

    def f(v: float) -> float:
        return -(c + d * v * v) / v

    s, v = 0.0, v1
    while True:
        k1 = f(v)
        k2 = f(v + 0.5 * step_m * k1)
        k3 = f(v + 0.5 * step_m * k2)
        k4 = f(v + step_m * k3)
        v_next = v + step_m * (k1 + 2 * k2 + 2 * k3 + k4) / 6
        if v_next <= v2:
            return s + step_m * (v - v2) / (v - v_next)
        s, v = s + step_m, v_next


@pytest.mark.parametrize("model", [RACE_CAR, BIG_AERO])
@pytest.mark.parametrize(("v1", "v2", "mu"), [(80.0, 20.0, 1.6), (60.0, 45.0, 1.0), (95.0, 10.0, 0.8)])
def test_exact_matches_numerical_integration(model, v1, v2, mu):
    assert brake_distance_exact(v1, v2, mu, model) == pytest.approx(
        _integrated_distance(v1, v2, mu, model), rel=0.005)


def test_no_aero_by_hand():
    # v^2 / (2 mu g): 30 m/s on mu 1 -> 45.87 m
    assert brake_distance_exact(30.0, 0.0, 1.0, NO_AERO) == pytest.approx(900 / (2 * 9.81), rel=1e-12)
    assert brake_distance_approx(30.0, 0.0, 1.0, NO_AERO) == pytest.approx(900 / (2 * 9.81), rel=1e-12)


@pytest.mark.parametrize(("v1", "v2", "mu"), [(30.0, 0.0, 1.0), (80.0, 20.0, 1.6), (50.0, 49.0, 0.5)])
def test_approx_equals_exact_without_aero(v1, v2, mu):
    assert brake_distance_approx(v1, v2, mu, NO_AERO) == pytest.approx(brake_distance_exact(v1, v2, mu, NO_AERO),
                                                                       rel=1e-9)


def test_approx_overestimates_with_large_aero():
    # The approximation brakes with the deceleration at v2 (the lowest), so it is longer.
    # With x = d (v1^2 - v2^2) / (c + d v2^2) the ratio is x / ln(1 + x).
    v1, v2, mu = 90.0, 30.0, 1.6
    exact = brake_distance_exact(v1, v2, mu, BIG_AERO)
    approx = brake_distance_approx(v1, v2, mu, BIG_AERO)
    c, d = mu * G, (10.0 * mu + 1.0) / 1000.0
    x = d * (v1 * v1 - v2 * v2) / (c + d * v2 * v2)
    assert approx / exact == pytest.approx(x / math.log1p(x), rel=1e-9)
    assert approx > 2.0 * exact  # about 2.5 times the exact distance here
    # a small speed drop: nearly the same (ratio about 1 + x/2)
    small = brake_distance_approx(31.0, 30.0, mu, BIG_AERO) / brake_distance_exact(31.0, 30.0, mu, BIG_AERO)
    assert 1.0 < small < 1.03


def test_approx_on_race_car_from_high_speed():
    # car1-trb1 (CA 2.92, CW 0.43) braking from 80 to 20 m/s: the approximation is about 60% too long,
    # from 80 to 70 m/s only about 10%
    ratio = brake_distance_approx(80.0, 20.0, 1.6, RACE_CAR) / brake_distance_exact(80.0, 20.0, 1.6, RACE_CAR)
    assert 1.55 < ratio < 1.7
    ratio = brake_distance_approx(80.0, 70.0, 1.6, RACE_CAR) / brake_distance_exact(80.0, 70.0, 1.6, RACE_CAR)
    assert 1.05 < ratio < 1.15


def test_no_braking_needed_gives_zero():
    for fn in (brake_distance_exact, brake_distance_approx):
        assert fn(20.0, 20.0, 1.0, RACE_CAR) == 0.0
        assert fn(10.0, 20.0, 1.0, RACE_CAR) == 0.0


def test_small_d_tends_to_frictional_limit():
    tiny = CarModel(mass_kg=1e12, ca=1.0, cw=1.0, mu=1.0)  # d = 2e-12
    assert brake_distance_exact(40.0, 10.0, 1.0, tiny) == pytest.approx((1600 - 100) / (2 * G), rel=1e-6)
    assert max_entry_speed(10.0, 50.0, 1.0, tiny) == pytest.approx(math.sqrt(100 + 2 * G * 50), rel=1e-6)


def test_drag_alone_never_stops():
    assert brake_distance_exact(30.0, 0.0, 0.0, RACE_CAR) == math.inf
    # but slows from 30 to 15 in ln(4) / (2 d)
    d = RACE_CAR.cw / RACE_CAR.mass_kg
    assert brake_distance_exact(30.0, 15.0, 0.0, RACE_CAR) == pytest.approx(math.log(4) / (2 * d), rel=1e-12)


@pytest.mark.parametrize("model", [NO_AERO, RACE_CAR, BIG_AERO])
@pytest.mark.parametrize("v2", [0.0, 15.0, 40.0])
@pytest.mark.parametrize("dist_m", [0.5, 2.0, 50.0, 300.0])
def test_max_entry_speed_inverts_exact(model, v2, dist_m):
    v1 = max_entry_speed(v2, dist_m, 1.3, model)
    assert v1 > v2
    assert brake_distance_exact(v1, v2, 1.3, model) == pytest.approx(dist_m, rel=1e-9)
    assert max_entry_speed(v2, brake_distance_exact(v1, v2, 1.3, model), 1.3, model) == pytest.approx(v1, rel=1e-9)


def test_max_entry_speed_no_distance():
    assert max_entry_speed(12.0, 0.0, 1.0, RACE_CAR) == 12.0


def test_brake_distance_dispatch():
    exact = brake_distance_exact(70.0, 25.0, 1.2, RACE_CAR)
    approx = brake_distance_approx(70.0, 25.0, 1.2, RACE_CAR)
    assert brake_distance(70.0, 25.0, 1.2, RACE_CAR) == exact
    assert brake_distance(70.0, 25.0, 1.2, RACE_CAR, "exact") == exact
    assert brake_distance(70.0, 25.0, 1.2, RACE_CAR, BrakeModel.APPROX) == approx
    assert brake_distance(70.0, 25.0, 1.2, RACE_CAR, "approx") == approx
    with pytest.raises(ValueError):
        brake_distance(70.0, 25.0, 1.2, RACE_CAR, "euler")


def test_approx_entry_speed_inverts_the_approx_distance_and_is_lower_than_exact():
    from boxbox.control.braking import max_entry_speed_approx

    model = CarModel(mass_kg=1200.0, ca=3.0, cw=0.45, mu=1.6)
    for v2, dist in ((20.0, 100.0), (40.0, 50.0), (0.0, 30.0)):
        v1 = max_entry_speed_approx(v2, dist, 1.6, model)
        assert brake_distance_approx(v1, v2, 1.6, model) == pytest.approx(dist, rel=1e-9)
        # the approximation brakes on the lowest deceleration: it allows less entry speed
        assert v1 < max_entry_speed(v2, dist, 1.6, model)


# a car whose brakes give less than its tyres at speed (155-DTM-like: 1150 kg, 21 kN of brakes)
WEAK_BRAKES = CarModel(mass_kg=1150.0, ca=3.13, cw=0.37, mu=1.68, brake_force_n=21_000.0)


def test_brake_limited_speed_where_the_tyres_grip_as_much_as_the_brakes_give():
    mu = 1.2
    v = brake_limited_speed(mu, WEAK_BRAKES)
    assert mu * (G + WEAK_BRAKES.ca * v * v / WEAK_BRAKES.mass_kg) == pytest.approx(21_000.0 / 1150.0, rel=1e-12)
    assert brake_limited_speed(mu, RACE_CAR) == math.inf  # no brake limit given: the tyres always limit
    assert brake_limited_speed(2.0, WEAK_BRAKES) == 0.0  # the tyres alone out-grip the brakes at rest


@pytest.mark.parametrize(("v1", "v2", "mu"), [(70.0, 20.0, 1.2), (70.0, 50.0, 1.2), (40.0, 10.0, 1.2),
                                              (60.0, 0.0, 2.0)])
def test_weak_brakes_lengthen_the_distance_as_integrated(v1, v2, mu):
    exact = brake_distance_exact(v1, v2, mu, WEAK_BRAKES)
    assert exact == pytest.approx(_integrated_engine(v1, v2, mu, WEAK_BRAKES), rel=0.003)
    grip_only = brake_distance_exact(v1, v2, mu, dataclasses.replace(WEAK_BRAKES, brake_force_n=math.inf))
    assert exact >= grip_only
    v_entry = max_entry_speed(v2, exact, mu, WEAK_BRAKES)
    assert v_entry == pytest.approx(v1, rel=1e-9)
    assert brake_distance_approx(v1, v2, mu, WEAK_BRAKES) >= exact  # still the lowest deceleration


def test_weak_brakes_from_the_155_dtms_braking_zone():
    # street-1: from 68 m/s the 155-DTM decelerated at 21 m/s^2 at full brake, not the 26 its tyres
    # (braking at 0.7 of their grip) promise; the profile had it 9 m/s too fast into the hairpin
    mu = 0.7 * 1.68
    strong = dataclasses.replace(WEAK_BRAKES, brake_force_n=math.inf)
    assert max_entry_speed(25.0, 100.0, mu, WEAK_BRAKES) < max_entry_speed(25.0, 100.0, mu, strong) - 2.0


# the same car with its engine braking at zero throttle: 114 kW (the 155-DTM's at its most power)
ENGINE_BRAKED = dataclasses.replace(WEAK_BRAKES, engine_brake_w=114_000.0)


def _integrated_engine(v1: float, v2: float, mu: float, model: CarModel, step_m: float = 0.01) -> float:
    """Euler in distance with the brakes' force B + P / v (computed here independently of braking.py)."""
    s, v = 0.0, v1
    while v > v2:
        tyres = mu * (G + model.ca * v * v / model.mass_kg)
        brakes = (model.brake_force_n + model.engine_brake_w / max(v, 5.0)) / model.mass_kg
        v_next = v - step_m * (min(tyres, brakes) + model.cw * v * v / model.mass_kg) / v
        if v_next <= v2:
            return s + step_m * (v - v2) / (v - v_next)
        s, v = s + step_m, v_next
    return s


def test_brake_limited_speed_counts_the_engines_brake():
    mu = 1.2
    v = brake_limited_speed(mu, ENGINE_BRAKED)
    m = ENGINE_BRAKED.mass_kg
    assert mu * (G + ENGINE_BRAKED.ca * v * v / m) == pytest.approx((21_000.0 + 114_000.0 / v) / m, rel=1e-9)
    assert v > brake_limited_speed(mu, WEAK_BRAKES)  # the engine's brake lets the tyres limit further up
    # no downforce: the tyres' grip is constant, so the engine's P / v meets it at one speed
    flat = dataclasses.replace(ENGINE_BRAKED, ca=0.0)
    v_flat = brake_limited_speed(2.0, flat)
    assert 2.0 * G == pytest.approx((21_000.0 + 114_000.0 / v_flat) / m, rel=1e-12)


@pytest.mark.parametrize(("v1", "v2", "mu"), [(70.0, 20.0, 1.2), (70.0, 50.0, 1.2), (60.0, 0.0, 2.0),
                                              (30.0, 3.0, 2.0)])
def test_engine_braking_as_integrated(v1, v2, mu):
    exact = brake_distance_exact(v1, v2, mu, ENGINE_BRAKED)
    assert exact == pytest.approx(_integrated_engine(v1, v2, mu, ENGINE_BRAKED), rel=0.003)
    assert exact < brake_distance_exact(v1, v2, mu, WEAK_BRAKES)
    assert max_entry_speed(v2, exact, mu, ENGINE_BRAKED) == pytest.approx(v1, rel=1e-6)


def test_strong_brakes_leave_the_tyres_formulas_to_the_bit():
    # car1-trb1-like: brakes and engine out-give the tyres at every speed it brakes from, so the
    # profile is the tyres' closed form exactly (its solo times unchanged to the ms)
    strong = dataclasses.replace(RACE_CAR, brake_force_n=48_000.0, engine_brake_w=104_000.0)
    for v2, dist in ((20.0, 2.0), (50.0, 2.0), (60.0, 30.0)):
        assert max_entry_speed(v2, dist, 1.2, strong) == max_entry_speed(v2, dist, 1.2, RACE_CAR)
        assert brake_distance_exact(v2 + 30.0, v2, 1.2, strong) == brake_distance_exact(v2 + 30.0, v2, 1.2, RACE_CAR)
