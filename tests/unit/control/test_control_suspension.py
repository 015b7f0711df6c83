"""The suspension model on plain roads: flat, a kink into an uphill, a crest and its landing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from boxbox.control.suspension import car_body, damper_force_n, ground_effect, packer_impacts
from boxbox.model import Car
from boxbox.model.constants import G_MPS2

STEP_M = 0.5
LBS_IN = 0.45359237 / 0.0254  # TORCS reads lbs as a mass: the file's lbs/in in N/m


def trb1() -> Car:
    """car1-trb1's suspension as its file has it (5500 lbs/in springs, 400/300 lbs/in/s dampers)."""
    car = Car(mass_kg=1150.0, front_weight_share=0.52, gc_height_m=0.25, front_axle_x_m=1.22, rear_axle_x_m=-1.42,
              length_m=4.52, width_m=1.94, height_m=1.1, front_clift=0.69, rear_clift=0.7,
              front_wing_area_m2=0.25, front_wing_angle_rad=math.radians(6.0), rear_wing_area_m2=0.7,
              rear_wing_angle_rad=math.radians(14.0), ride_height_fr_m=0.09, ride_height_fl_m=0.09,
              ride_height_rr_m=0.105, ride_height_rl_m=0.105)
    for w in ("fr", "fl", "rr", "rl"):
        front = w[0] == "f"
        setattr(car, f"wheel_y_{w}_m", -0.84 if w[1] == "r" else 0.84)
        setattr(car, f"spring_{w}_npm", 5500 * LBS_IN)
        setattr(car, f"bellcrank_{w}", 1.1)
        setattr(car, f"slow_bump_{w}_nspm", (400 if front else 300) * LBS_IN)
        setattr(car, f"slow_rebound_{w}_nspm", (300 if front else 400) * LBS_IN)
        setattr(car, f"fast_bump_{w}_nspm", 60 * LBS_IN)
        setattr(car, f"fast_rebound_{w}_nspm", 60 * LBS_IN)
    return car


def run(road: np.ndarray, speed_mps: float) -> np.ndarray:
    """Impacts on a road under all four wheels alike (the rear axle 2.64 m behind the front)."""
    n = len(road)
    lag = int(round(2.64 / STEP_M))
    wheels = np.stack([road, road, np.roll(road, lag), np.roll(road, lag)])
    zero = np.zeros(n)
    return packer_impacts(wheels, np.full(n, speed_mps), zero, zero, STEP_M, car_body(trb1(), 1200.0))


def kinked(slope: float, n: int = 2000) -> np.ndarray:
    """Flat, then from the middle on a straight climb of `slope`, then back down to close the lap."""
    s = np.arange(n) * STEP_M
    up = np.clip(s - s[n // 2], 0.0, 60.0) * slope
    return up - np.clip(s - s[n // 2] - 200.0, 0.0, 60.0) * slope


def test_the_body_weighs_what_the_car_does():
    body = car_body(trb1(), 1200.0)
    assert sum(c.weight_n for c in body.corners) == pytest.approx(1200.0 * G_MPS2)
    front = body.corners[0]
    assert front.rate_npm == pytest.approx(5500 * LBS_IN * 1.21)
    assert front.x_m == 1.22 and front.y_m == -0.84 and body.corners[1].y_m == 0.84


def test_a_flat_road_never_reaches_the_packers_even_flat_out():
    assert not run(np.zeros(2000), 85.0).any()


def test_a_sharp_kink_into_a_climb_hits_the_packers_fast_and_not_slow():
    road = kinked(0.12)
    fast, slow = run(road, 60.0), run(road, 15.0)
    assert fast.max() > 0.5
    assert not slow.any()
    # the hit is where the front wheels meet the kink (sample n / 2), not before
    assert int(np.argmax(fast > 0.0)) >= 1000


def test_harder_the_faster():
    road = kinked(0.12)
    assert run(road, 70.0).max() > run(road, 60.0).max() > 0.0


def test_a_crest_throws_the_car_off_and_it_lands_on_its_packers():
    n = 2000
    s = np.arange(n) * STEP_M
    # a climb that steepens gently to 0.15 and levels off at 400 m (the car takes off), then climbs
    # again from 415 m (where it lands), and falls back to 0 by the end of the lap (ole-road-1 at 3.3 km)
    climb = 0.15 * np.clip(s - 200.0, 0.0, 200.0) ** 2 / 400.0 + 0.12 * np.clip(s - 415.0, 0.0, 85.0)
    road = np.where(s < 500.0, climb, climb[int(500 / STEP_M)] * (1.0 - (s - 500.0) / 500.0))
    impacts = run(road, 50.0)
    hits = np.nonzero(impacts)[0]
    assert len(hits) and s[hits[0]] > 415.0  # the landing, after the crest
    assert not run(road, 15.0).any()


def test_the_two_rate_damper_and_the_ground_effect():
    rates = (1000.0, 100.0, 0.5)
    assert damper_force_n(0.2, rates) == pytest.approx(200.0)
    assert damper_force_n(1.5, rates) == pytest.approx(500.0 + 100.0)
    assert damper_force_n(-1.5, rates) == pytest.approx(-600.0)
    assert ground_effect(0.3) == pytest.approx(2.0 * math.exp(-3.0 * 0.45 ** 4))
    assert ground_effect(1.5) < 0.01


@pytest.mark.parametrize("bad", ["shape", "speed", "step"])
def test_bad_input_is_a_value_error(bad):
    road = np.zeros((4, 10))
    speed = np.full(10, 30.0)
    zero = np.zeros(10)
    body = car_body(trb1(), 1200.0)
    with pytest.raises(ValueError):
        if bad == "shape":
            packer_impacts(road[:3], speed, zero, zero, STEP_M, body)
        elif bad == "speed":
            packer_impacts(road, np.zeros(10), zero, zero, STEP_M, body)
        else:
            packer_impacts(road, speed, zero, zero, 0.0, body)
