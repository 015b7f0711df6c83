"""Where the suspension bottoms out: the car's body on its four springs and dampers, driven over
the road's height under each wheel at a given speed.

TORCS (simuv2) holds each wheel on the road and measures its travel from the body: the spring
pushes F0 + k b^2 (x0 - x) at the wheel (k the file's spring, b the bellcrank, x0 the ride height,
F0 the wheel's static weight, never below 0), the damper b f(b v) with a slow rate below a
threshold speed and a fast rate above it.  The body is one rigid mass: it heaves, pitches and rolls
(inertia m (l^2 + h^2) / 12 and m (w^2 + h^2) / 12 over the body's length, width and height).  The
body's lift (Clift) is scaled by the ground effect of the four ride heights, so a car that leaves
the ground loses most of its downforce.  Where the road rises faster than the body follows (a kink
into an uphill, a dip's floor, the landing after a crest) a wheel's travel reaches its packers;
then TORCS puts the body back on them and counts damage for the speed it hits them with
(`SimCarCollideZ`).  Sources: TORCS 1.3.7 simuv2 car.cpp, suspension.cpp, wheel.cpp, aero.cpp and
collide.cpp.  Left out: anti-roll bars and the wheels' own mass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from boxbox.control.carmodel import WING_FACTOR
from boxbox.model.car import Car
from boxbox.model.constants import AIR_DENSITY_KGPM3, G_MPS2

WHEELS = ("fr", "fl", "rr", "rl")
REBOUND_KEPT = 0.5  # simuv2 takes half the speed into the road off the body when it hits the packers


@dataclass(frozen=True)
class Corner:
    """One wheel's suspension, in the wheel's terms."""

    x_m: float  # the axle's place ahead of the CG
    y_m: float  # the wheel's place left of the CG
    ride_height_m: float  # static travel x0
    packers_m: float  # travel where the body sits on the packers
    weight_n: float  # the wheel's static load F0
    rate_npm: float  # spring rate at the wheel: k b^2
    bellcrank: float
    bump: tuple[float, float, float]  # damper in compression: slow, fast rate (N s/m), threshold (m/s)
    rebound: tuple[float, float, float]  # the same in extension
    lift_npv2: float  # this wheel's half of its axle's Clift (before the ground effect)
    wing_npv2: float  # ... and of its axle's wing


@dataclass(frozen=True)
class Body:
    """The sprung car: mass, CG height, pitch and roll inertia and its four corners."""

    mass_kg: float
    gc_height_m: float
    pitch_inertia_kgm2: float
    roll_inertia_kgm2: float
    corners: tuple[Corner, Corner, Corner, Corner]  # fr, fl, rr, rl


def car_body(car: Car, mass_kg: float) -> Body:
    """The car's body at mass_kg (with fuel), from its parameter file as the bridge read it."""
    if mass_kg <= 0.0 or car.length_m <= 0.0 or car.width_m <= 0.0:
        raise ValueError("the car's mass and size must be positive")
    front = min(max(car.front_weight_share, 0.05), 0.95)
    corners = []
    for w in WHEELS:
        b = getattr(car, f"bellcrank_{w}")
        at_front = w[0] == "f"
        area, angle = ((car.front_wing_area_m2, car.front_wing_angle_rad) if at_front
                       else (car.rear_wing_area_m2, car.rear_wing_angle_rad))
        corners.append(Corner(
            x_m=car.front_axle_x_m if at_front else car.rear_axle_x_m, y_m=getattr(car, f"wheel_y_{w}_m"),
            ride_height_m=getattr(car, f"ride_height_{w}_m"), packers_m=getattr(car, f"packers_{w}_m"),
            weight_n=0.5 * (front if at_front else 1.0 - front) * mass_kg * G_MPS2,
            rate_npm=getattr(car, f"spring_{w}_npm") * b * b, bellcrank=b,
            bump=(getattr(car, f"slow_bump_{w}_nspm"), getattr(car, f"fast_bump_{w}_nspm"),
                  getattr(car, f"bump_threshold_{w}_mps")),
            rebound=(getattr(car, f"slow_rebound_{w}_nspm"), getattr(car, f"fast_rebound_{w}_nspm"),
                     getattr(car, f"rebound_threshold_{w}_mps")),
            lift_npv2=0.5 * (car.front_clift if at_front else car.rear_clift),
            wing_npv2=0.5 * WING_FACTOR * AIR_DENSITY_KGPM3 * area * math.sin(angle)))
    h = car.height_m
    return Body(mass_kg=mass_kg, gc_height_m=car.gc_height_m,
                pitch_inertia_kgm2=mass_kg * (car.length_m ** 2 + h * h) / 12.0,
                roll_inertia_kgm2=mass_kg * (car.width_m ** 2 + h * h) / 12.0, corners=tuple(corners))  # type: ignore[arg-type]


def ground_effect(ride_heights_sum_m: float) -> float:
    """simuv2's factor on the body's lift (aero.cpp): 2 exp(-3 (1.5 x the four ride heights)^4),
    near 2 on the ground, near 0 once the car has taken off."""
    x = 1.5 * max(ride_heights_sum_m, 0.0)
    return 2.0 * math.exp(-3.0 * x * x * x * x)


def damper_force_n(speed_mps: float, rates: tuple[float, float, float]) -> float:
    """simuv2's two-rate damper at the damper: slow rate up to the threshold speed, fast beyond."""
    slow, fast, threshold = rates
    v = abs(speed_mps)
    f = slow * v if v < threshold else slow * threshold + fast * (v - threshold)
    return f if speed_mps >= 0.0 else -f


def packer_impacts(road_z_m: np.ndarray, speed_mps: np.ndarray, lateral_mps2: np.ndarray,
                   longitudinal_mps2: np.ndarray, step_m: float | np.ndarray, body: Body,
                   warmup_m: float = 200.0) -> np.ndarray:
    """Per sample of a closed lap: the speed (m/s) the body hits any wheel's packers with there,
    0 if it does not.

    road_z_m: shape (4, n), the road's height under each wheel (fr, fl, rr, rl) per sample,
    step_m apart (one step or one per sample; fine enough to keep the road's kinks: 0.5 m);
    speed_mps: the car's speed per sample (> 0); lateral_mps2 (+ to the left) and
    longitudinal_mps2 (+ forwards): its acceleration, which pitches and rolls the body through its
    CG height.  The run starts warmup_m before the start line, from rest on the road, so the lap
    begins with the body moving as it would.
    """
    road = np.asarray(road_z_m, dtype=float)
    n = road.shape[-1]
    if road.shape != (4, n) or n < 2 or any(len(a) != n for a in (speed_mps, lateral_mps2, longitudinal_mps2)):
        raise ValueError("road_z_m must be (4, n) and speed and accelerations n long, n >= 2")
    if not np.all(np.asarray(step_m) > 0.0) or not np.all(np.asarray(speed_mps) > 0.0):
        raise ValueError("step_m and every speed must be positive")
    dt = np.broadcast_to(np.asarray(step_m, dtype=float) / np.asarray(speed_mps, dtype=float), (n,))
    v_sq = np.asarray(speed_mps, dtype=float) ** 2
    pitch_torque = body.mass_kg * body.gc_height_m * np.asarray(longitudinal_mps2, dtype=float)
    roll_torque = body.mass_kg * body.gc_height_m * np.asarray(lateral_mps2, dtype=float)
    warm = min(n, int(warmup_m / float(np.mean(step_m))))
    order = np.r_[np.arange(n - warm, n), np.arange(n)]
    impacts = _run(body, road[:, order].T.tolist(), dt[order].tolist(), v_sq[order].tolist(),
                   pitch_torque[order].tolist(), roll_torque[order].tolist())
    return np.asarray(impacts[warm:])


def _run(body: Body, roads: list[list[float]], dts: list[float], v_sqs: list[float], pitch_torques: list[float],
         roll_torques: list[float]) -> list[float]:
    """The time loop of packer_impacts (semi-implicit Euler), one entry per sample."""
    cs = body.corners
    xs, ys = [c.x_m for c in cs], [c.y_m for c in cs]
    m, iy, ix = body.mass_kg, body.pitch_inertia_kgm2, body.roll_inertia_kgm2
    weight = m * G_MPS2
    lift = [c.lift_npv2 for c in cs]
    wing = [c.wing_npv2 for c in cs]
    # heave z is the body's height over the road it started on, x0 - travel at rest: 0
    z, zv, pitch, pitch_v, roll, roll_v = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    base = roads[0]
    prev = list(base)
    out = []
    for road, dt, v_sq, pt, rt in zip(roads, dts, v_sqs, pitch_torques, roll_torques, strict=True):
        travel = [c.ride_height_m + z + xs[i] * pitch + ys[i] * roll - (road[i] - base[i]) for i, c in enumerate(cs)]
        effect = ground_effect(sum(travel))
        fz, my, mx, worst = -weight, pt, rt, 0.0
        for i, c in enumerate(cs):
            road_v = (road[i] - prev[i]) / dt
            spring = c.weight_n + c.rate_npm * (c.ride_height_m - travel[i])
            force = -(lift[i] * effect + wing[i]) * v_sq
            if spring > 0.0:  # the wheel on the road
                rate = c.bellcrank * (road_v - (zv + xs[i] * pitch_v + ys[i] * roll_v))  # + in compression
                force += spring + c.bellcrank * damper_force_n(rate, c.bump if rate >= 0.0 else c.rebound)
            fz += force
            my += force * xs[i]
            mx += force * ys[i]
            if travel[i] < c.packers_m:
                worst = max(worst, road_v - zv)
        zv += fz / m * dt
        pitch_v += my / iy * dt
        roll_v += mx / ix * dt
        z += zv * dt
        pitch += pitch_v * dt
        roll += roll_v * dt
        for i, c in enumerate(cs):  # on the packers: the body is put back on them, half its speed into them taken off
            low = c.packers_m - (c.ride_height_m + z + xs[i] * pitch + ys[i] * roll - (road[i] - base[i]))
            if low > 0.0:
                z += low
                hit = (road[i] - prev[i]) / dt - zv
                if hit > 0.0:
                    zv += REBOUND_KEPT * hit
        prev = road
        out.append(worst)
    return out
