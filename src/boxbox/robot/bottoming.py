"""Speed caps that keep the suspension off its packers: drive the speed profile through the
suspension model (control/suspension.py) under each wheel, and where a wheel would hit the packers
harder than allowed, slow the stretch that leads there, then try again.

The road under a wheel is TORCS's (racingline.road_height_m: the right edge linear along each
segment, tan(banking) across it), `x` metres ahead of the car's place for an axle `x` ahead of
the CG.  The loads come from the profile itself: v^2 times the line's curvature sideways, v dv/ds
along.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from boxbox.control import lapsim
from boxbox.control.lapsim import PointMassCar
from boxbox.control.suspension import car_body, packer_impacts
from boxbox.model.car import Car
from boxbox.model.track import Track
from boxbox.robot.racingline import RacingLine, road_height_m

LEAD_M = 45.0  # a hit is slowed from this far before it (a landing comes some way after its crest)
SLOWER = 0.97  # each round takes this share of the speed there
ROUNDS = 12
FINE_STEP_M = 0.5
NO_PACKER_LIMIT_MPS = 100.0  # packer_impact_mps at or above this: no caps


def wheel_road_heights(track: Track, line: RacingLine, dist_m: np.ndarray, x_m: float, y_m: float) -> np.ndarray:
    """The road's height (m) under a wheel x_m ahead and y_m left of a car on the line at each
    distance (along the middle) from the start line."""
    mid = line.middle
    at = (np.asarray(dist_m) + x_m) % line.length_m
    offset = np.interp(at, mid.dist_m, line.offset_m)
    return road_height_m(track, at, offset + y_m)


def worst_impacts(track: Track, line: RacingLine, car: Car, mass_kg: float, speed_mps: np.ndarray) -> np.ndarray:
    """Per sample of the line: the hardest any wheel hits its packers within it (m/s) at these
    speeds (the suspension run every FINE_STEP_M so that no kink of the road is smoothed away)."""
    n = line.middle.n
    per = max(1, int(round(line.step_m / FINE_STEP_M)))
    fine_step = line.step_m / per
    dist = np.arange(n * per) * fine_step
    coarse = line.middle.dist_m[:n]

    def fine(values: np.ndarray) -> np.ndarray:
        return np.interp(dist, coarse, values, period=line.length_m)

    factor = np.asarray(line.length_factor[:n])
    dv = np.roll(speed_mps, -1) - np.roll(speed_mps, 1)
    speed = fine(speed_mps)
    lateral = fine(speed_mps * speed_mps * line.curvature_1pm[:n])
    longitudinal = fine(speed_mps * dv / (2.0 * line.step_m * factor))
    body = car_body(car, mass_kg)
    road = np.stack([wheel_road_heights(track, line, dist, c.x_m, c.y_m) for c in body.corners])
    # the car covers length_factor line metres per middle metre
    impacts = packer_impacts(road, speed, lateral, longitudinal, fine_step * fine(factor), body)
    return impacts.reshape(n, per).max(axis=1)


def driven_speeds(target_mps: np.ndarray, step_m: np.ndarray, car: PointMassCar) -> np.ndarray:
    """The speeds a car reaches under a target profile: the target, or less where the engine (in
    its best gear, against drag) cannot get there from the sample before.  Two passes round the lap."""
    table_step = 0.25
    forces = lapsim.drive_force_n(np.arange(0.0, 150.0 + table_step, table_step), car).tolist()
    drag_per_kg = car.cw_n_per_mps2 / car.mass_kg
    v = np.asarray(target_mps, dtype=float).tolist()
    ds = np.asarray(step_m, dtype=float).tolist()
    n = len(v)
    for _ in range(2):
        for i in range(n):
            j = (i + 1) % n
            push = forces[min(int(v[i] / table_step), len(forces) - 1)] / car.mass_kg - drag_per_kg * v[i] * v[i]
            v[j] = min(v[j], math.sqrt(max(1.0, v[i] * v[i] + 2.0 * ds[i] * push)))
    return np.asarray(v)


def packer_speed_caps(track: Track, line: RacingLine, car: Car, point_mass: PointMassCar, allowed_impact_mps: float,
                      speeds_with: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Per sample: the highest speed (m/s, inf where free) that keeps every wheel's packer hits at
    or below allowed_impact_mps; speeds_with(caps) is the speed profile the caps give."""
    n = line.middle.n
    mass_kg = point_mass.mass_kg
    caps = np.full(n, np.inf)
    lead = max(1, int(round(LEAD_M / line.step_m)))
    step_m = line.step_m * np.asarray(line.length_factor[:n])
    for _ in range(ROUNDS):
        speeds = driven_speeds(speeds_with(caps), step_m, point_mass)
        hits = np.nonzero(worst_impacts(track, line, car, mass_kg, speeds) > allowed_impact_mps)[0]
        if len(hits) == 0:
            break
        for i in hits:
            window = np.arange(i - lead, i + 1) % n
            caps[window] = np.minimum(caps[window], SLOWER * speeds[window])
    return caps
