import dataclasses
import math

import pytest

from boxbox.control.carmodel import (
    CarModel,
    axle_downforce_coefficients,
    brake_force_n,
    cornering_downforce_coefficient,
    downforce_coefficient,
    drag_coefficient,
    wing_drag_coefficient,
)
from boxbox.model.car import Car
from boxbox.model.constants import G_MPS2 as G
from trackdata import load


def _car(**kw) -> Car:
    base = dict(
        mass_kg=1000.0, front_clift=0.5, rear_clift=0.5, rear_wing_area_m2=1.0, rear_wing_angle_rad=math.pi / 6,
        front_wing_area_m2=0.0, ride_height_fr_m=0.0, ride_height_fl_m=0.0, ride_height_rr_m=0.0,
        ride_height_rl_m=0.0, cx=0.4, front_area_m2=2.0,
    )
    base.update(kw)
    return Car(**base)


def test_gravity():
    assert G == 9.81


def test_downforce_by_hand_flat_car():
    # h = 2 at zero ride height: 2 * (0.5 + 0.5) + 4 * 1.23 * 1 * sin(30 deg) = 2 + 2.46
    assert downforce_coefficient(_car()) == pytest.approx(4.46, rel=1e-12)


def test_downforce_ride_height_factor():
    # 1.5 * sum of heights = 1 -> h = 2 exp(-3)
    car = _car(ride_height_fr_m=1 / 6, ride_height_fl_m=1 / 6, ride_height_rr_m=1 / 6, ride_height_rl_m=1 / 6,
               rear_wing_area_m2=0.0)
    assert downforce_coefficient(car) == pytest.approx(2 * math.exp(-3) * 1.0, rel=1e-12)


def test_downforce_front_wing_counted_when_present():
    car = _car(front_wing_area_m2=0.5, front_wing_angle_rad=math.pi / 2)
    assert downforce_coefficient(car) == pytest.approx(4.46 + 4 * 1.23 * 0.5, rel=1e-12)
    assert downforce_coefficient(car, include_front_wing=False) == pytest.approx(4.46, rel=1e-12)


def test_downforce_recorded_car():
    _, car = load("e-track-2")
    h = 2 * math.exp(-3 * (1.5 * (0.09 + 0.09 + 0.105 + 0.105)) ** 4)
    expected = (h * (0.69 + 0.70) + 4 * 1.23 * 0.70 * math.sin(math.radians(14))
                + 4 * 1.23 * 0.25 * math.sin(math.radians(6)))
    assert downforce_coefficient(car) == pytest.approx(expected, rel=1e-5)


def test_drag():
    assert drag_coefficient(_car()) == pytest.approx(0.645 * 0.4 * 2.0, rel=1e-12)


def test_from_car_mass_mu_and_fuel():
    car = _car(mu_fr=1.5, mu_fl=1.4, mu_rr=1.6, mu_rl=1.7)
    m = CarModel.from_car(car, fuel_l=30.0)
    assert m.mass_kg == 1030.0
    assert m.empty_mass_kg == 1000.0
    assert m.mu == 1.4
    assert m.ca == downforce_coefficient(car)
    assert m.cw == drag_coefficient(car)
    light = m.with_fuel(5.0)
    assert light.mass_kg == 1005.0
    assert (light.ca, light.cw, light.mu) == (m.ca, m.cw, m.mu)
    assert CarModel.from_car(car).mass_kg == 1000.0


def test_plain_constructor_and_frozen():
    m = CarModel(mass_kg=900.0, ca=1.0, cw=0.5, mu=1.2)
    assert m.empty_mass_kg == 900.0
    assert m.with_fuel(10.0).mass_kg == 910.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.mass_kg = 1.0  # type: ignore[misc]


def test_axle_downforce_adds_up_to_the_whole_car():
    _, car = load("g-track-1")
    front, rear = axle_downforce_coefficients(car)
    assert front + rear == pytest.approx(downforce_coefficient(car))
    assert 0.0 < front < rear  # car1-trb1: small front wing, big rear wing


@pytest.mark.parametrize("front_share", [0.3, 0.52, 0.7])
def test_cornering_downforce_is_the_weaker_axles(front_share):
    """Each axle holds the side force of its own weight: the axle with less downforce per share of
    weight limits, and a car with downforce split like its weight corners on all of it."""
    _, car = load("g-track-1")
    car = dataclasses.replace(car, front_weight_share=front_share)
    front, rear = axle_downforce_coefficients(car)
    ca = cornering_downforce_coefficient(car)
    assert ca == pytest.approx(min(front / front_share, rear / (1.0 - front_share)))
    assert ca <= downforce_coefficient(car) + 1e-12
    balanced = dataclasses.replace(car, front_weight_share=front / (front + rear))
    assert cornering_downforce_coefficient(balanced) == pytest.approx(downforce_coefficient(car))


def test_car_model_corners_on_the_weaker_axle():
    _, car = load("g-track-1")
    car = dataclasses.replace(car, front_weight_share=0.52)
    model = CarModel.from_car(car)
    assert model.ca_corner == pytest.approx(cornering_downforce_coefficient(car))
    assert CarModel(mass_kg=1000.0, ca=2.0, cw=0.4, mu=1.0).ca_corner == 2.0  # default: all of it


def test_brake_force_from_the_cars_brakes():
    # per wheel: disk diameter / 2 x piston area x pad mu x its share of the pressure / wheel radius
    car = _car(brake_pressure_max=20e6, brake_front_rear=0.6, wheel_radius_fr_m=0.3, wheel_radius_fl_m=0.3,
               wheel_radius_rr_m=0.32, wheel_radius_rl_m=0.32,
               **{f"brake_disk_diameter_{w}_m": 0.36 for w in ("fr", "fl", "rr", "rl")},
               **{f"brake_piston_area_{w}_m2": 0.005 for w in ("fr", "fl", "rr", "rl")},
               **{f"brake_mu_{w}": 0.4 for w in ("fr", "fl", "rr", "rl")})
    front = 0.18 * 0.005 * 0.4 * 20e6 * 0.6 / 0.3
    rear = 0.18 * 0.005 * 0.4 * 20e6 * 0.4 / 0.32
    assert brake_force_n(car) == pytest.approx(2 * front + 2 * rear, rel=1e-12)
    assert CarModel.from_car(car, brakes=True).brake_force_n == pytest.approx(2 * front + 2 * rear, rel=1e-12)
    assert brake_force_n(_car(brake_pressure_max=0.0)) == math.inf  # no pressure given: no limit known


def test_the_brakes_model_counts_the_wings_drag_and_the_tyres_model_no_brakes():
    """from_car(brakes=True) is what slows the car at full pressure: brakes, engine and all the drag
    (the wings' too, as simuv2 applies it); without, the tyres alone limit (the plan's model)."""
    _, car = load("g-track-1")
    tyres, brakes = CarModel.from_car(car), CarModel.from_car(car, brakes=True)
    assert tyres.brake_force_n == math.inf and tyres.engine_brake_w == 0.0
    assert tyres.cw == pytest.approx(drag_coefficient(car))
    assert wing_drag_coefficient(car) > 0.0
    assert brakes.cw == pytest.approx(drag_coefficient(car) + wing_drag_coefficient(car))
