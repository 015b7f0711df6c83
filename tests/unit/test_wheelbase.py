"""One wheelbase per use: the axles' distance (the load the drive moves, control/traction.py) and the
steering's share of the car's length (the robot's and the gym's pit steering), each defined once."""

import pytest

from boxbox.control.traction import drive_axles
from boxbox.model.car import STEERING_WHEELBASE_SHARE, Car


def test_the_wheelbase_is_the_axles_distance():
    car = Car(front_axle_x_m=1.22, rear_axle_x_m=-1.42, length_m=4.52)
    assert car.wheelbase_m == pytest.approx(2.64)
    assert car.steering_wheelbase_m == STEERING_WHEELBASE_SHARE * 4.52


def test_the_drive_moves_load_by_the_cg_height_over_the_wheelbase():
    front, rear = drive_axles(Car(front_axle_x_m=1.0, rear_axle_x_m=-1.5, gc_height_m=0.5))
    assert rear.load_per_force == pytest.approx(0.5 / 2.5) and front.load_per_force == pytest.approx(-0.2)

