"""The lap simulation on made-up lines with plain physics."""

import math

import numpy as np
import pytest

from boxbox.control.lapsim import PointMassCar, corner_speed_mps, drive_force_n, lap_speeds_mps, lap_time_s
from boxbox.model.constants import G_MPS2

CAR = PointMassCar(mass_kg=1000.0, ca_n_per_mps2=1.0, cw_n_per_mps2=0.5, mu=1.5, wheel_radius_m=0.3,
                   gear_ratios=(12.0, 8.0, 6.0, 4.8, 4.0), torque_curve_radps=(0.0, 500.0, 1000.0),
                   torque_curve_nm=(300.0, 400.0, 300.0), limiter_radps=950.0)


def test_steady_circle_runs_at_the_friction_limit():
    k = 1.0 / 80.0
    n = 400
    ds = np.full(n, 2 * math.pi * 80.0 / n)
    v = lap_speeds_mps(ds, np.full(n, k), np.full(n, CAR.mu), CAR)
    expected = math.sqrt(CAR.mu * G_MPS2 / (k - CAR.mu * CAR.ca_n_per_mps2 / CAR.mass_kg))
    # at the lateral limit nothing is left to hold the speed against drag: a hair below it
    assert np.all(v <= expected + 1e-9)
    assert v == pytest.approx(np.full(n, expected), rel=2e-3)
    assert lap_time_s(ds, v) == pytest.approx(2 * math.pi * 80.0 / expected, rel=2e-3)


def test_top_speed_where_drive_meets_drag():
    n = 5000
    v = lap_speeds_mps(np.full(n, 5.0), np.full(n, 1e-6), np.full(n, CAR.mu), CAR)
    speeds = np.linspace(50, 100, 50001)
    balance = speeds[np.argmin(np.abs(drive_force_n(speeds, CAR) - CAR.cw_n_per_mps2 * speeds ** 2))]
    assert v.max() == pytest.approx(balance, abs=0.1)


def test_braking_into_a_hairpin_uses_grip_and_drag():
    # 1 km straight, then a 20 m radius hairpin (samples every 2 m)
    k = np.zeros(600)
    k[500:531] = 1.0 / 20.0
    ds = np.full(600, 2.0)
    v = lap_speeds_mps(ds, k, np.full(600, CAR.mu), CAR)
    v_turn = corner_speed_mps(np.array([1 / 20.0]), np.array([CAR.mu]), CAR)[0]
    assert np.all(v[500:531] <= v_turn + 1e-9)
    assert v[500:531] == pytest.approx(np.full(31, v_turn), rel=2e-3)
    # 100 m before the turn the car can be no faster than braking with all its grip (and drag) allows
    v2 = v[450] ** 2
    a_max = CAR.mu * (G_MPS2 + v2 * CAR.ca_n_per_mps2 / CAR.mass_kg) + CAR.cw_n_per_mps2 / CAR.mass_kg * v2
    assert v[450] ** 2 <= v_turn ** 2 + 2 * 100.0 * a_max + 1e-6
    assert v[450] > v_turn + 10  # and it does brake late, not early


def test_the_drive_force_picks_the_best_gear_below_the_limiter():
    f = drive_force_n(np.array([5.0, 20.0]), CAR)
    first = np.interp(5.0 * 12.0 / 0.3, CAR.torque_curve_radps, CAR.torque_curve_nm) * 12.0 / 0.3
    assert f[0] == pytest.approx(first)
    assert drive_force_n(np.array([200.0]), CAR)[0] == 0.0  # beyond every gear's limiter


@pytest.mark.parametrize("bad", [dict(mass_kg=-1.0), dict(mu=math.nan), dict(gear_ratios=()),
                                 dict(torque_curve_nm=(1.0,))])
def test_bad_car(bad):
    fields = {f: getattr(CAR, f) for f in CAR.__dataclass_fields__} | bad
    with pytest.raises(ValueError):
        PointMassCar(**fields)


def test_bad_line():
    with pytest.raises(ValueError):
        lap_speeds_mps(np.array([1.0, -1.0, 1.0]), np.zeros(3), np.ones(3), CAR)
    with pytest.raises(ValueError):
        lap_speeds_mps(np.ones(3), np.zeros(4), np.ones(3), CAR)


NO_AERO = PointMassCar(mass_kg=1000.0, ca_n_per_mps2=0.0, cw_n_per_mps2=0.0, mu=1.0, wheel_radius_m=0.3,
                       gear_ratios=(12.0, 8.0), torque_curve_radps=(0.0, 1000.0), torque_curve_nm=(300.0, 300.0),
                       limiter_radps=950.0)


@pytest.mark.parametrize("bank_rad", [-0.3, -0.1, 0.0, 0.1])
def test_banking_on_a_left_turn_follows_the_textbook_formula(bank_rad):
    # TORCS's bank is + where the left side is higher: a left turn is helped by a negative bank,
    # v^2 = g R (mu + tan b) / (1 - mu tan b) with b = -bank the slope down towards the centre
    radius, b = 100.0, -bank_rad
    v = corner_speed_mps(np.array([1.0 / radius]), np.array([1.0]), NO_AERO, bank_rad=bank_rad)[0]
    expected = math.sqrt(G_MPS2 * radius * (1.0 + math.tan(b)) / (1.0 - math.tan(b)))
    assert v == pytest.approx(expected, rel=1e-6)
    right = corner_speed_mps(np.array([-1.0 / radius]), np.array([1.0]), NO_AERO, bank_rad=-bank_rad)[0]
    assert right == pytest.approx(v, rel=1e-9)  # a right turn, mirrored


def test_load_sensitivity_costs_grip_under_downforce():
    sensitive = PointMassCar(**{**CAR.__dict__, "load_factor_max": 1.6, "load_factor_min": 0.8})
    # at 1.2 x the static load the factor is exactly 1 (simuv2's operating load)
    assert sensitive.load_factor_at(1.2 * G_MPS2) == pytest.approx(1.0)
    assert sensitive.load_factor_at(0.0) == pytest.approx(1.6)
    assert sensitive.load_factor_at(100 * G_MPS2) == pytest.approx(0.8, abs=1e-6)
    slow, fast = np.array([1.0 / 30.0]), np.array([1.0 / 2000.0])
    assert corner_speed_mps(slow, np.array([1.5]), sensitive)[0] > corner_speed_mps(slow, np.array([1.5]), CAR)[0]
    with pytest.raises(ValueError):
        PointMassCar(**{**CAR.__dict__, "load_factor_max": 0.9, "load_factor_min": 0.8})
    assert np.isfinite(corner_speed_mps(fast, np.array([1.5]), sensitive)[0])


def test_uphill_is_slower_and_downhill_faster():
    n = 1000
    ds, k, mu = np.full(n, 2.0), np.full(n, 1e-6), np.full(n, 1.0)
    k[0:20] = 1.0 / 30.0  # one slow corner so the lap has an exit to accelerate from
    flat = lap_time_s(ds, lap_speeds_mps(ds, k, mu, CAR))
    up = lap_time_s(ds, lap_speeds_mps(ds, k, mu, CAR, grade=np.full(n, 0.05)))
    down = lap_time_s(ds, lap_speeds_mps(ds, k, mu, CAR, grade=np.full(n, -0.05)))
    assert down < flat < up
    with pytest.raises(ValueError):
        lap_speeds_mps(ds, k, mu, CAR, bank_rad=np.full(n, 2.0))
