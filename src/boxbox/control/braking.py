"""Braking distances for a point-mass car with downforce and drag.

Model: the tyres give mu * (m g + CA v^2) of braking force and drag adds CW v^2, so
    dv/dt = -(c + d v^2),  c = mu g,  d = (CA mu + CW) / m.
The brakes themselves give at most CarModel.brake_force_n (their torque at full pressure, from the
car's description), and the engine at zero throttle brakes with CarModel.engine_brake_w, a force
P / v: above the speed where the tyres' grip reaches brakes and engine, they limit, and there
    dv/dt = -(B / m + P / (m v) + CW v^2 / m),
integrated numerically (no closed form); the tyres' part keeps the closed forms.
`mu` everywhere here is the *total* friction: surface friction times the tyre mu (CarModel.mu).
Called per drive step, so pure floats and `math` only.
"""

from __future__ import annotations

import math
from enum import StrEnum

from boxbox.control.carmodel import CarModel
from boxbox.model.constants import G_MPS2 as G

_MAX_EXP_ARG = 700.0  # exp() overflows a float just above 709
MIN_ENGINE_BRAKE_SPEED_MPS = 5.0  # the engine's brake force is P / v down to this speed (no stall below)


class BrakeModel(StrEnum):
    EXACT = "exact"  # integrates the model above
    APPROX = "approx"  # the tutorial seed's formula: the lowest deceleration (at v2) over the whole way


def _coefficients(mu: float, model: CarModel) -> tuple[float, float]:
    return mu * G, (model.ca * mu + model.cw) / model.mass_kg


def brake_limited_speed(mu: float, model: CarModel) -> float:
    """The speed (m/s) above which the tyres would grip more than the brakes and the engine's brake
    give (0: at every speed; inf: never): mu (g + CA v^2 / m) = (B + P / v) / m, P the engine's
    braking power, i.e. the one positive root of mu CA v^3 + (mu g m - B) v - P (below
    MIN_ENGINE_BRAKE_SPEED_MPS the engine's brake force stays at its value there)."""
    if math.isinf(model.brake_force_n):
        return math.inf
    m = model.mass_kg
    per_v3 = model.ca * mu
    v_low = MIN_ENGINE_BRAKE_SPEED_MPS
    if _tyres(v_low, mu, model) >= _brakes(v_low, model):  # at or below v_low: a constant brake force
        spare = _brakes(v_low, model) - mu * G
        return math.sqrt(spare * m / per_v3) if spare > 0.0 else 0.0
    linear = mu * G * m - model.brake_force_n
    power = model.engine_brake_w
    if per_v3 <= 0.0:  # no downforce: the tyres grip the same at every speed
        return power / linear if linear > 0.0 else math.inf
    p, q = linear / per_v3, -power / per_v3  # v^3 + p v + q = 0, q <= 0: one root > 0
    v = math.sqrt(max(-p, 0.0)) + (-q) ** (1.0 / 3.0)  # >= the root; Newton from the right converges
    for _ in range(60):
        f = v * v * v + p * v + q
        slope = 3.0 * v * v + p
        if f <= 0.0 or slope <= 0.0:
            break
        step = f / slope
        v -= step
        if step < 1e-9 * v:
            break
    return v


def _tyres(v_mps: float, mu: float, model: CarModel) -> float:
    """Deceleration (m/s^2) the tyres' grip gives at v, drag left out."""
    return mu * (G + model.ca * v_mps * v_mps / model.mass_kg)


def _brakes(v_mps: float, model: CarModel) -> float:
    """Deceleration (m/s^2) the brakes and the engine's brake give at v, drag left out."""
    return (model.brake_force_n + model.engine_brake_w / max(v_mps, MIN_ENGINE_BRAKE_SPEED_MPS)) / model.mass_kg


def _tyres_limit(v_mps: float, mu: float, model: CarModel) -> bool:
    """True when the tyres, not the brakes, limit at every speed up to v (tyres grip more the
    faster, the brakes give no more)."""
    return math.isinf(model.brake_force_n) or _tyres(v_mps, mu, model) <= _brakes(v_mps, model)


def _brake_decel(v_mps: float, model: CarModel) -> float:
    """Deceleration (m/s^2) where the brakes limit: brakes, the engine's brake (P / v) and drag."""
    return _brakes(v_mps, model) + model.cw * v_mps * v_mps / model.mass_kg


def _decel_at(v_mps: float, mu: float, model: CarModel) -> float:
    """Deceleration (m/s^2) at v: the tyres' or the brakes', whichever is less, plus drag."""
    drag = model.cw / model.mass_kg * v_mps * v_mps
    if _tyres_limit(v_mps, mu, model):
        return _tyres(v_mps, mu, model) + drag
    return _brake_decel(v_mps, model)


def _brake_distance(v1_mps: float, v2_mps: float, model: CarModel) -> float:
    """Distance (m) to slow from v1 to v2 where the brakes limit: the integral of d(v^2) / 2a(v)
    (Simpson's rule, in v^2: smooth down to v = 0; steps of at most 100 m^2/s^2)."""
    w1, w2 = v1_mps * v1_mps, v2_mps * v2_mps
    n = 2 * max(1, math.ceil((w1 - w2) / 200.0))
    h = (w1 - w2) / n
    total = 0.0
    for i in range(n + 1):
        weight = 1.0 if i in (0, n) else (4.0 if i % 2 else 2.0)
        total += weight / _brake_decel(math.sqrt(w2 + i * h), model)
    return total * h / 6.0


def _brake_entry(v2_mps: float, dist_m: float, model: CarModel) -> float:
    """Highest speed that slows to v2 within dist_m where the brakes limit: d(v^2)/ds = 2 a(v)
    backwards from v2 (Runge-Kutta, steps of at most 2 m)."""
    n = max(1, math.ceil(dist_m / 2.0))
    h = dist_m / n
    w = v2_mps * v2_mps

    def slope(w_sq: float) -> float:
        return 2.0 * _brake_decel(math.sqrt(max(w_sq, 0.0)), model)

    for _ in range(n):
        k1 = slope(w)
        k2 = slope(w + 0.5 * h * k1)
        k3 = slope(w + 0.5 * h * k2)
        k4 = slope(w + h * k3)
        w += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
    return math.sqrt(w)


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
    if _tyres_limit(v1_mps, mu, model):
        return _distance(v1_mps, v2_mps, *_coefficients(mu, model))
    limited = brake_limited_speed(mu, model)
    if limited < v1_mps:  # the brakes limit from v1 down to `limited`, the tyres below it
        top = _brake_distance(v1_mps, max(v2_mps, limited), model)
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
    v1_mps = _entry(v2_mps, dist_m, *_coefficients(mu, model))
    if _tyres_limit(v1_mps, mu, model):
        return v1_mps
    limited = brake_limited_speed(mu, model)
    if v2_mps < limited:  # the tyres limit up to `limited`, the brakes above it
        below = brake_distance_exact(limited, v2_mps, mu, model)
        if dist_m <= below:
            return _entry(v2_mps, dist_m, *_coefficients(mu, model))
        return _brake_entry(limited, dist_m - below, model)
    return _brake_entry(v2_mps, dist_m, model)


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
