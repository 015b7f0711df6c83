"""The tutorial robot's car setup from the track: the rear wing angle that laps fastest.

Per track, before the car is built (Robot.car_setup), the lap simulation (control/lapsim.py) laps
the robot's own racing line, with the robot's own cornering limits (the weaker axle's downforce,
banking, crests: control/speed.py), for rear wing angles from the car's own down to the least
that keeps the rear axle `rear_balance` times as much downforce per share of weight as the front:
a rear-driven car needs grip to spare at the rear, for power out of turns and against spins.
Less wing is less drag (higher speed on straights) and less downforce (less braking grip, and
less cornering grip once the rear is the weaker axle); the fastest simulated lap wins, and the
car's own angle wins ties.  The engine drives through an ideal gearbox at its best power: the
car's gears are not known before the car is built, and the trade-off is about high speed.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np

from boxbox.control.carmodel import WING_FACTOR, CarModel, axle_downforce_coefficients, wing_drag_coefficient
from boxbox.control.engine import torque_curve_to_limit
from boxbox.control.lapsim import PointMassCar, lap_speeds_mps, lap_time_s
from boxbox.model import Car
from boxbox.model.constants import AIR_DENSITY_KGPM3

ANGLE_STEP_RAD = math.radians(1.0)
IDEAL_GEARS = 24  # ratios of the ideal gearbox, from 3 to 120 m/s at the engine's best power


def least_rear_wing_rad(car: Car, rear_balance: float) -> float:
    """The smallest rear wing angle (rad, >= 0) with CA_rear / w_rear >= rear_balance x CA_front / w_front,
    never more than the car's own angle."""
    front, rear = axle_downforce_coefficients(car)
    share = min(max(car.front_weight_share, 0.05), 0.95)
    per_sin = WING_FACTOR * AIR_DENSITY_KGPM3 * car.rear_wing_area_m2  # the rear wing's CA per sin(angle)
    if per_sin <= 0.0:
        return car.rear_wing_angle_rad
    body_rear = rear - per_sin * math.sin(car.rear_wing_angle_rad)
    need = rear_balance * front * (1.0 - share) / share - body_rear
    return min(car.rear_wing_angle_rad, math.asin(min(1.0, max(0.0, need / per_sin))))


def ideal_gearbox_car(car: Car, model: CarModel) -> PointMassCar:
    """A point mass with the car's mass, downforce, drag (with the wings'), grip and an engine that
    always runs at its best power (ideal gears): what a setup changes, without the gears.  The engine
    is its torque curve up to the rev limit (torque_curve_to_limit), as the car has it."""
    rpm_to_limit, torque_to_limit = torque_curve_to_limit(car)
    if len(rpm_to_limit) < 2:  # no rev limit below the curve: the whole curve
        rpm_to_limit, torque_to_limit = car.torque_curve_radps, car.torque_curve_nm
    rpm, torque = np.asarray(rpm_to_limit), np.asarray(torque_to_limit)
    best = int(np.argmax(rpm * torque))
    radius_m = 0.3  # any: ratios are made for it
    speeds = np.geomspace(3.0, 120.0, IDEAL_GEARS)
    ratios = tuple(float(rpm[best] * radius_m / v) for v in speeds)
    cw = model.cw + wing_drag_coefficient(car)
    return PointMassCar(mass_kg=model.mass_kg, ca_n_per_mps2=model.ca, cw_n_per_mps2=cw, mu=model.mu,
                        wheel_radius_m=radius_m, gear_ratios=ratios, torque_curve_radps=tuple(rpm.tolist()),
                        torque_curve_nm=tuple(torque.tolist()),
                        limiter_radps=float(rpm.max()))


def best_rear_wing_rad(car: Car, fuel_l: float, step_m: Sequence[float], curvature_1pm: Sequence[float],
                       mu: Sequence[float], corner_limits: Callable[[CarModel], Sequence[float]],
                       rear_balance: float) -> tuple[float, dict[float, float]]:
    """The rear wing angle (rad) whose simulated lap is fastest, and the lap time (s) per angle tried."""
    if len(car.torque_curve_nm) < 2:
        return car.rear_wing_angle_rad, {}
    low = least_rear_wing_rad(car, rear_balance)
    angles = [car.rear_wing_angle_rad]
    while angles[-1] - ANGLE_STEP_RAD >= low:
        angles.append(angles[-1] - ANGLE_STEP_RAD)
    times: dict[float, float] = {}
    for angle in angles:
        trial = dataclasses.replace(car, rear_wing_angle_rad=angle)
        model = CarModel.from_car(trial, fuel_l=fuel_l)
        limits = np.maximum(np.asarray(corner_limits(model), dtype=float), 0.1)
        speeds = lap_speeds_mps(np.asarray(step_m), np.asarray(curvature_1pm), np.asarray(mu),
                                ideal_gearbox_car(trial, model), corner_limit_mps=limits)
        times[angle] = lap_time_s(np.asarray(step_m), speeds)
    best = min(angles, key=lambda a: (round(times[a], 3), -a))
    return best, times
