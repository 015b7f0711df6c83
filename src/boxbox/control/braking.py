"""Braking distances for a point-mass car with downforce and drag.

Model: the tyres give mu * (m g + CA v^2) of braking force and drag adds CW v^2, so
    dv/dt = -(c + d v^2),  c = mu g,  d = (CA mu + CW) / m.
The brakes themselves give at most CarModel.brake_force_n (their torque at full pressure, from the
car's description): above the speed where the tyres' grip reaches it, the brakes limit, and there
    c = brake_force_n / m,  d = CW / m.
`mu` everywhere here is the *total* friction: surface friction times the tyre mu (CarModel.mu).
Called per drive step, so pure floats and `math` only.
"""

from __future__ import annotations

import math
from enum import StrEnum

from boxbox.control.carmodel import CarModel
from boxbox.model.constants import G_MPS2 as G

_MAX_EXP_ARG = 700.0  # exp() overflows a float just above 709


class BrakeModel(StrEnum):
    EXACT = "exact"  # integrates the model above
    APPROX = "approx"  # the tutorial seed's formula: the lowest deceleration (at v2) over the whole way


def _coefficients(mu: float, model: CarModel) -> tuple[float, float]:
    return mu * G, (model.ca * mu + model.cw) / model.mass_kg


def _brake_coefficients(model: CarModel) -> tuple[float, float]:
    """c and d where the brakes, not the tyres, limit."""
    return model.brake_force_n / model.mass_kg, model.cw / model.mass_kg


def brake_limited_speed(mu: float, model: CarModel) -> float:
    """The speed (m/s) above which the tyres would grip more than the brakes can give (0: at every
    speed; inf: never): mu (g + CA v^2 / m) = brake_force_n / m."""
    if math.isinf(model.brake_force_n):
        return math.inf
    spare = model.brake_force_n / model.mass_kg - mu * G
    if spare <= 0.0:
        return 0.0
    per_v2 = model.ca * mu / model.mass_kg
    return math.sqrt(spare / per_v2) if per_v2 > 0.0 else math.inf


def _decel_at(v_mps: float, mu: float, model: CarModel) -> float:
    """Deceleration (m/s^2) at v: the tyres' or the brakes', whichever is less, plus drag."""
    c, d = _coefficients(mu, model)
    tyres = c + (model.ca * mu / model.mass_kg) * v_mps * v_mps
    return min(tyres, model.brake_force_n / model.mass_kg) + model.cw / model.mass_kg * v_mps * v_mps


def brake_distance_approx(v1_mps: float, v2_mps: float, mu: float, model: CarModel) -> float:
    """m (v1^2 - v2^2) / (2 (mu g m + v2^2 (CA mu + CW))); 0 when no braking is needed.

    It uses the deceleration at v2, the lowest on the way, so it is never shorter than the exact
    distance: conservative, more so the stronger the aero and the larger v1 - v2.
    """
    if v1_mps <= v2_mps:
        return 0.0
    denom = 2.0 * _decel_at(v2_mps, mu, model)
    if denom <= 0.0:
        return math.inf
    return (v1_mps * v1_mps - v2_mps * v2_mps) / denom


def brake_distance_exact(v1_mps: float, v2_mps: float, mu: float, model: CarModel) -> float:
    """Distance to slow from v1 to v2 under the model: ln((c + d v1^2)/(c + d v2^2)) / (2d).

    0 when v1 <= v2; (v1^2 - v2^2) / (2c) when d = 0; inf when nothing slows the car.
    """
    if v1_mps <= v2_mps:
        return 0.0
    limited = brake_limited_speed(mu, model)
    if limited < v1_mps:  # the brakes limit from v1 down to `limited`, the tyres below it
        c, d = _brake_coefficients(model)
        top = _distance(v1_mps, max(v2_mps, limited), c, d)
        return top + (brake_distance_exact(limited, v2_mps, mu, model) if v2_mps < limited else 0.0)
    return _distance(v1_mps, v2_mps, *_coefficients(mu, model))


def _distance(v1_mps: float, v2_mps: float, c: float, d: float) -> float:
    """Distance to slow from v1 to v2 at dv/dt = -(c + d v^2)."""
    dv_sq = v1_mps * v1_mps - v2_mps * v2_mps
    if d <= 0.0:
        return dv_sq / (2.0 * c) if c > 0.0 else math.inf
    base = c + d * v2_mps * v2_mps
    if base <= 0.0:  # no friction and v2 = 0: drag alone never stops the car
        return math.inf
    # log1p of the ratio minus one avoids cancellation when v1 is close to v2 or d is tiny
    return math.log1p(d * dv_sq / base) / (2.0 * d)


def max_entry_speed(v2_mps: float, dist_m: float, mu: float, model: CarModel) -> float:
    """Highest speed from which the car slows to v2 within dist_m (inverse of brake_distance_exact).

    v1^2 = v2^2 + (c + d v2^2) (exp(2 d s) - 1) / d, which tends to v2^2 + 2 c s as d -> 0.
    """
    if dist_m <= 0.0:
        return v2_mps
    limited = brake_limited_speed(mu, model)
    if math.isinf(limited):
        return _entry(v2_mps, dist_m, *_coefficients(mu, model))
    if v2_mps < limited:  # the tyres limit up to `limited`, the brakes above it
        below = brake_distance_exact(limited, v2_mps, mu, model)
        if dist_m <= below:
            return _entry(v2_mps, dist_m, *_coefficients(mu, model))
        return _entry(limited, dist_m - below, *_brake_coefficients(model))
    return _entry(v2_mps, dist_m, *_brake_coefficients(model))


def _entry(v2_mps: float, dist_m: float, c: float, d: float) -> float:
    """Highest speed that slows to v2 within dist_m at dv/dt = -(c + d v^2)."""
    v2_sq = v2_mps * v2_mps
    if d <= 0.0:
        return math.sqrt(v2_sq + 2.0 * max(c, 0.0) * dist_m)
    arg = 2.0 * d * dist_m
    if arg > _MAX_EXP_ARG:
        return math.inf
    return math.sqrt(v2_sq + (c + d * v2_sq) * math.expm1(arg) / d)


def max_entry_speed_approx(v2_mps: float, dist_m: float, mu: float, model: CarModel) -> float:
    """Inverse of brake_distance_approx: v1^2 = v2^2 + 2 s (c + d v2^2)."""
    if dist_m <= 0.0:
        return v2_mps
    return math.sqrt(v2_mps * v2_mps + 2.0 * dist_m * max(_decel_at(v2_mps, mu, model), 0.0))


def entry_speed_function(method: BrakeModel | str = BrakeModel.EXACT):
    """max_entry_speed for the chosen braking model (for speed profiles)."""
    method = BrakeModel(method)
    return max_entry_speed if method is BrakeModel.EXACT else max_entry_speed_approx


def brake_distance(
    v1_mps: float, v2_mps: float, mu: float, model: CarModel, method: BrakeModel | str = BrakeModel.EXACT
) -> float:
    """Braking distance with the chosen model ("exact" or "approx")."""
    if method == BrakeModel.EXACT:
        return brake_distance_exact(v1_mps, v2_mps, mu, model)
    if method == BrakeModel.APPROX:
        return brake_distance_approx(v1_mps, v2_mps, mu, model)
    raise ValueError(f"unknown brake model {method!r}, expected 'exact' or 'approx'")
