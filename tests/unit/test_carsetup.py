"""The tutorial robot's rear wing choice (robot/carsetup.py) on plain numbers and a recorded car."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from boxbox.control.carmodel import axle_downforce_coefficients
from boxbox.robot.carsetup import best_rear_wing_rad, least_rear_wing_rad
from trackdata import load


def car1():
    _, car = load("g-track-1")
    return dataclasses.replace(car, front_weight_share=0.52, rear_wing_angle_rad=math.radians(14.0))


@pytest.mark.parametrize("balance", [1.0, 1.5, 2.0])
def test_least_rear_wing_keeps_the_rear_axle_stronger_by_the_balance(balance):
    car = car1()
    angle = least_rear_wing_rad(car, balance)
    front, rear = axle_downforce_coefficients(dataclasses.replace(car, rear_wing_angle_rad=angle))
    if 0.0 < angle < car.rear_wing_angle_rad:
        assert rear / 0.48 == pytest.approx(balance * front / 0.52, rel=1e-9)
    assert 0.0 <= angle <= car.rear_wing_angle_rad


def test_least_rear_wing_never_above_the_cars_own():
    assert least_rear_wing_rad(car1(), 10.0) == pytest.approx(math.radians(14.0))


def oval(straight_m: float, radius_m: float, step_m: float = 2.0):
    """Curvature per sample of two straights and two half circles."""
    n_straight, n_turn = int(straight_m / step_m), int(math.pi * radius_m / step_m)
    k = np.concatenate([np.zeros(n_straight), np.full(n_turn, 1.0 / radius_m)] * 2)
    return np.full(len(k), step_m), k


def test_long_straights_take_less_wing_than_tight_turns():
    """Drag costs most where the car is flat out: a long-straight oval with wide turns takes the least
    wing the balance allows; the choice is the fastest simulated lap either way."""
    car = car1()

    def limits(model, k):
        return np.where(k > 0, np.sqrt(1.1 * 9.81 / np.maximum(k, 1e-9)), 100.0)

    step, k = oval(1000.0, 250.0)
    angle, times = best_rear_wing_rad(car, 20.0, step, k, np.full(len(k), 1.2), lambda m: limits(m, k), 1.5)
    assert angle == pytest.approx(min(times)) or angle == min(times, key=times.get)
    assert angle < car.rear_wing_angle_rad and times[angle] < times[car.rear_wing_angle_rad]
    assert angle == pytest.approx(min(times.keys()), abs=1e-9)


def test_no_torque_curve_keeps_the_cars_angle():
    car = dataclasses.replace(car1(), torque_curve_radps=(), torque_curve_nm=())
    step, k = oval(500.0, 100.0)
    assert best_rear_wing_rad(car, 20.0, step, k, np.full(len(k), 1.2), lambda m: np.full(len(k), 50.0), 1.5) == \
        (car.rear_wing_angle_rad, {})
