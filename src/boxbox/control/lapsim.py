"""Quasi-steady-state lap simulation: the fastest a point-mass car can go along a given line.

The car is a point mass with a friction circle that downforce widens, aerodynamic drag and an
engine that drives through its best gear at every speed. Along the line (curvature per sample,
friction per sample, spacing in metres):

1. the corner limit: the highest v with m v^2 |k| <= mu (m g + CA v^2 + m v^2 kv) (kv: vertical
   curvature, + in a dip);
2. a backward pass from every corner: braking uses what the friction circle leaves beside the
   corner's lateral need, plus drag;
3. a forward pass: accelerating uses the smaller of the engine's best force and what the
   friction circle leaves, less drag.

The lap is closed (a flying lap: both passes run round twice so the start joins the finish).
Banking (bank_rad, TORCS's sign: + where the left side is higher) tilts the friction circle: on a
road sloping down towards the turn's centre by beta, the road carries m v^2 |k| sin(beta) + m g
cos(beta) and the tyres need only m v^2 |k| cos(beta) - m g sin(beta) across it. The grade (sine of
the slope, + uphill) takes g x grade from the engine and adds it to the brakes.
The result is an upper bound on speed only as far as the model covers the simulation: it leaves
out load transfer, the tyres' slip, rolling resistance and the drivetrain's losses, which all cost
time, and it knows the sides of the track only through the line and friction it is given.
This follows the textbook QSS method (e.g. Brayshaw and Harrison, "A quasi steady state approach
to race car lap simulation", Proc. IMechE D 219, 2005; TUMFTM's laptime-simulation on GitHub).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from boxbox.model.constants import G_MPS2


@dataclass(frozen=True)
class PointMassCar:
    """What the lap simulation needs of a car.

    mass_kg with fuel; ca_n_per_mps2 and cw_n_per_mps2: downforce and drag coefficients (force
    = c v^2, N); mu: the tyres' friction (times what the skill level adds); wheel_radius_m of the
    driven wheels; gear_ratios: forward gears with the final drive; torque curve in rad/s and N m;
    limiter_radps: the engine's rev limiter.
    """

    mass_kg: float
    ca_n_per_mps2: float
    cw_n_per_mps2: float
    mu: float
    wheel_radius_m: float
    gear_ratios: tuple[float, ...]
    torque_curve_radps: tuple[float, ...]
    torque_curve_nm: tuple[float, ...]
    limiter_radps: float
    # the tyres' load sensitivity (simuv2 wheel.cpp): grip = mu x load x f(load), f = min + (max -
    # min) exp(ln((1 - min) / (max - min)) load / operating load): 1 at the operating load, more
    # below it, less above (downforce). max == min == 1: no sensitivity. operating_load_n 0: 1.2 m g.
    load_factor_max: float = 1.0
    load_factor_min: float = 1.0
    operating_load_n: float = 0.0

    def load_factor(self, load_per_kg: np.ndarray | float) -> np.ndarray:
        """f at a normal load of `load_per_kg` (N per kg of the car, m/s^2)."""
        lo, hi = self.load_factor_min, self.load_factor_max
        if hi - lo <= 1e-9:
            return np.full_like(np.asarray(load_per_kg, dtype=float), lo)
        op = (self.operating_load_n or 1.2 * self.mass_kg * G_MPS2) / self.mass_kg
        k = math.log((1.0 - lo) / (hi - lo))
        return lo + (hi - lo) * np.exp(k * np.maximum(np.asarray(load_per_kg, dtype=float), 0.0) / op)

    def load_factor_at(self, load_per_kg: float) -> float:
        """load_factor for one load, in plain floats (the passes call it per sample)."""
        lo, hi = self.load_factor_min, self.load_factor_max
        if hi - lo <= 1e-9:
            return lo
        op = (self.operating_load_n or 1.2 * self.mass_kg * G_MPS2) / self.mass_kg
        return lo + (hi - lo) * math.exp(math.log((1.0 - lo) / (hi - lo)) * max(load_per_kg, 0.0) / op)

    def __post_init__(self) -> None:
        numbers = (self.mass_kg, self.ca_n_per_mps2, self.cw_n_per_mps2, self.mu, self.wheel_radius_m,
                   self.limiter_radps, *self.gear_ratios, *self.torque_curve_radps, *self.torque_curve_nm)
        if not all(math.isfinite(x) for x in numbers):
            raise ValueError("every number of the car must be finite")
        if self.mass_kg <= 0 or self.mu <= 0 or self.wheel_radius_m <= 0 or self.limiter_radps <= 0:
            raise ValueError("mass, mu, wheel radius and rev limiter must be > 0")
        if not self.gear_ratios or min(self.gear_ratios) <= 0:
            raise ValueError("at least one forward gear, every ratio > 0")
        if len(self.torque_curve_radps) < 2 or len(self.torque_curve_radps) != len(self.torque_curve_nm):
            raise ValueError("the torque curve needs two or more (rad/s, N m) points")
        if not (0.0 < self.load_factor_min <= 1.0 <= self.load_factor_max) and \
                not self.load_factor_min == self.load_factor_max == 1.0:
            raise ValueError("load factors: 0 < min <= 1 <= max")
        if not math.isfinite(self.operating_load_n) or self.operating_load_n < 0:
            raise ValueError("operating_load_n must be finite and >= 0")


def drive_force_n(speed_mps: np.ndarray, car: PointMassCar) -> np.ndarray:
    """The engine's most force at the wheels (N) at each speed (m/s), over the gears that keep it
    below its rev limiter (TORCS interpolates the torque curve linearly)."""
    v = np.asarray(speed_mps, dtype=float)
    best = np.zeros_like(v)
    for ratio in car.gear_ratios:
        engine_radps = np.maximum(v, 0.0) * ratio / car.wheel_radius_m
        torque = np.interp(engine_radps, car.torque_curve_radps, car.torque_curve_nm)
        force = np.where(engine_radps <= car.limiter_radps, torque * ratio / car.wheel_radius_m, 0.0)
        best = np.maximum(best, force)
    return best


def _tilt(curvature_1pm: np.ndarray, bank_rad: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin of the road's slope down towards the turn's centre (beta = -bank x sign(k))."""
    beta = -np.asarray(bank_rad, dtype=float) * np.sign(np.asarray(curvature_1pm, dtype=float))
    return np.cos(beta), np.sin(beta)


def corner_speed_mps(curvature_1pm: np.ndarray, mu: np.ndarray, car: PointMassCar,
                     vertical_curvature_1pm: np.ndarray | float = 0.0, max_speed_mps: float = 150.0,
                     bank_rad: np.ndarray | float = 0.0) -> np.ndarray:
    """Highest steady speed (m/s) through each sample (curvature 1/m, + left; bank in rad): the
    highest v with |v^2 |k| cos b - g sin b| <= mu f(N) N, N = g cos b + v^2 (|k| sin b + CA/m + kv)
    per kg (bisection: mu f(N) N grows with v while the need grows faster past the limit)."""
    k = np.abs(np.asarray(curvature_1pm, dtype=float))
    cos_b, sin_b = _tilt(curvature_1pm, bank_rad)
    mu_a = np.broadcast_to(np.asarray(mu, dtype=float), k.shape)
    kv = np.broadcast_to(np.asarray(vertical_curvature_1pm, dtype=float), k.shape)

    def fits(v: np.ndarray) -> np.ndarray:
        v2 = v * v
        load = G_MPS2 * cos_b + v2 * (k * sin_b + car.ca_n_per_mps2 / car.mass_kg + kv)
        return np.abs(v2 * k * cos_b - G_MPS2 * sin_b) <= mu_a * car.load_factor(load) * np.maximum(load, 0.0)

    lo, hi = np.zeros_like(k), np.full_like(k, max_speed_mps)
    top = fits(hi)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        ok = fits(mid)
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    return np.where(top, max_speed_mps, lo)


def _grip_left_mps2(v: float, k: float, mu: float, kv: float, car: PointMassCar,
                    cos_b: float = 1.0, sin_b: float = 0.0) -> float:
    """Longitudinal acceleration the friction circle leaves beside the lateral need at speed v."""
    ak = abs(k)
    load = max(0.0, G_MPS2 * cos_b + v * v * (ak * sin_b + car.ca_n_per_mps2 / car.mass_kg + kv))
    total, lateral = mu * car.load_factor_at(load) * load, abs(v * v * ak * cos_b - G_MPS2 * sin_b)
    return math.sqrt(total * total - lateral * lateral) if total > lateral else 0.0


def lap_speeds_mps(step_m: np.ndarray, curvature_1pm: np.ndarray, mu: np.ndarray, car: PointMassCar,
                   vertical_curvature_1pm: np.ndarray | None = None, bank_rad: np.ndarray | None = None,
                   grade: np.ndarray | None = None, corner_limit_mps: np.ndarray | None = None) -> np.ndarray:
    """Limit speed (m/s) at each of n samples of a closed line; step_m[i] is the distance (m)
    from sample i to sample i + 1 (the last one back to the first). bank_rad: banking (rad, + left
    side higher); grade: sine of the slope along the line (+ uphill); corner_limit_mps: a robot's
    own cornering limit per sample, taken where it is lower than the point mass's."""
    ds = np.asarray(step_m, dtype=float)
    k = np.asarray(curvature_1pm, dtype=float)
    n = len(ds)
    mu_a = np.broadcast_to(np.asarray(mu, dtype=float), (n,))
    kv = np.zeros(n) if vertical_curvature_1pm is None else np.asarray(vertical_curvature_1pm, dtype=float)
    bank = np.zeros(n) if bank_rad is None else np.asarray(bank_rad, dtype=float)
    slope = np.zeros(n) if grade is None else np.asarray(grade, dtype=float)
    if n < 3 or len(k) != n or len(kv) != n or len(bank) != n or len(slope) != n:
        raise ValueError("step_m, curvature_1pm, vertical_curvature_1pm, bank_rad and grade need the same length >= 3")
    if not (np.all(np.isfinite(ds)) and np.all(ds > 0) and np.all(np.isfinite(k)) and np.all(mu_a > 0)
            and np.all(np.isfinite(bank)) and np.all(np.abs(bank) < 1.2) and np.all(np.abs(slope) < 1.0)):
        raise ValueError("steps must be finite and > 0, curvature finite, mu > 0, |bank| < 1.2 rad, |grade| < 1")
    v_corner = corner_speed_mps(k, mu_a, car, kv, bank_rad=bank)
    if corner_limit_mps is not None:
        if np.shape(corner_limit_mps) != (n,) or not np.all(np.asarray(corner_limit_mps) > 0):
            raise ValueError("corner_limit_mps needs one speed > 0 per sample")
        v_corner = np.minimum(v_corner, corner_limit_mps)
    v = v_corner.tolist()
    cos_a, sin_a = (x.tolist() for x in _tilt(k, bank))
    drive = _drive_table(car)
    ks, ms, kvs, dss, gs = k.tolist(), mu_a.tolist(), kv.tolist(), ds.tolist(), (G_MPS2 * slope).tolist()
    drag = car.cw_n_per_mps2 / car.mass_kg
    for _ in range(2):  # backward: what braking allows before each corner
        for i in range(n - 1, -1, -1):
            j = (i + 1) % n
            decel = _grip_left_mps2(v[j], ks[j], ms[j], kvs[j], car, cos_a[j], sin_a[j]) + drag * v[j] * v[j] + gs[i]
            v[i] = min(v[i], math.sqrt(max(0.0, v[j] * v[j] + 2.0 * dss[i] * decel)))
    for _ in range(2):  # forward: what the engine and the tyres allow out of each corner
        for i in range(n):
            j = (i + 1) % n
            push = min(drive(v[i]) / car.mass_kg, _grip_left_mps2(v[i], ks[i], ms[i], kvs[i], car, cos_a[i], sin_a[i]))
            accel = push - drag * v[i] * v[i] - gs[i]
            v[j] = min(v[j], math.sqrt(max(0.0, v[i] * v[i] + 2.0 * dss[i] * accel)))
    return np.asarray(v)


def _drive_table(car: PointMassCar, step_mps: float = 0.25, top_mps: float = 150.0):
    """drive_force_n as a fast lookup for the passes (linear between 0.25 m/s steps)."""
    speeds = np.arange(0.0, top_mps + step_mps, step_mps)
    forces = drive_force_n(speeds, car).tolist()
    last = len(forces) - 1

    def force(v: float) -> float:
        x = v / step_mps
        i = min(int(x), last - 1)
        return forces[i] + (x - i) * (forces[i + 1] - forces[i])

    return force


def lap_time_s(step_m: np.ndarray, speeds_mps: np.ndarray) -> float:
    """Time (s) to cover the closed line at these speeds (mean speed over each step)."""
    v = np.asarray(speeds_mps, dtype=float)
    mean = 0.5 * (v + np.roll(v, -1))
    if np.any(mean <= 0):
        raise ValueError("speeds must be > 0 everywhere")
    return float(np.sum(np.asarray(step_m, dtype=float) / mean))
