"""One copy of the engine's rules (control/engine.py): the torque curve up to the rev limit, the
engine brake, and the three that read them (the brakes' model, the fuel a lap takes, the ideal
gearbox of the lap simulation)."""

import dataclasses

import numpy as np
import pytest

from boxbox.control.carmodel import CarModel
from boxbox.control.engine import engine_brake_power_w, engine_brake_share, torque_curve_to_limit
from boxbox.model.car import Car
from boxbox.robot.carsetup import ideal_gearbox_car

# the 155-DTM's curve as the bridge sends it: padded with 750 N m past its 1047 rad/s limit
DTM_RADPS = (0.0, 105.0, 419.0, 628.0, 838.0, 1047.0, 1152.0, 1466.0)
DTM_NM = (750.0, 364.0, 463.0, 471.0, 401.0, 330.0, 750.0, 750.0)


def _dtm(**kw) -> Car:
    base = dict(torque_curve_radps=DTM_RADPS, torque_curve_nm=DTM_NM, engine_tickover_radps=105.0,
                engine_revs_max_radps=1047.0, engine_brake_coeff=0.33, mass_kg=1000.0, cx=0.3,
                front_area_m2=2.0)
    base.update(kw)
    return Car(**base)


def test_engine_brake_share_grows_from_tickover_to_the_coefficient_at_most_revs():
    assert engine_brake_share(100.0, 100.0, 1000.0, 0.33) == 0.0
    assert engine_brake_share(50.0, 100.0, 1000.0, 0.33) == 0.0  # below tickover: no brake
    assert engine_brake_share(550.0, 100.0, 1000.0, 0.33) == pytest.approx(0.165)
    assert engine_brake_share(1000.0, 100.0, 1000.0, 0.33) == pytest.approx(0.33)
    assert engine_brake_share(500.0, 1000.0, 1000.0, 0.33) == 0.0  # no range between tickover and top


def test_the_curve_ends_at_the_rev_limit_and_keeps_a_point_on_it():
    assert torque_curve_to_limit(_dtm()) == (DTM_RADPS[:6], DTM_NM[:6])
    # the limit as a float a hair under the point on it (car1-trb1's 1047.1976 rad/s): kept
    assert torque_curve_to_limit(_dtm(engine_revs_max_radps=1047.0 - 1e-4))[0] == DTM_RADPS[:6]
    assert torque_curve_to_limit(_dtm(engine_revs_max_radps=1000.0))[0] == DTM_RADPS[:5]


def test_engine_brake_power_reads_the_curve_up_to_the_rev_limit():
    # most power inside the limit at 1047 rad/s (346 kW; 838 rad/s gives 336): the whole
    # brake_coeff there, 0.33 x 330 N m x 1047 rad/s = 114 kW; the padded 750 N m at 1466 rad/s
    # would count 0.48 x 1.1 MW = 524 kW
    expected = 0.33 * (1047.0 - 105.0) / (1047.0 - 105.0) * 330.0 * 1047.0
    assert engine_brake_power_w(_dtm()) == pytest.approx(expected, rel=1e-12)
    assert engine_brake_power_w(_dtm(engine_brake_coeff=0.0)) == 0.0
    assert engine_brake_power_w(Car()) == 0.0  # no curve: no engine brake counted
    assert engine_brake_power_w(_dtm(engine_tickover_radps=1100.0)) == 0.0  # tickover past the limit


def test_the_brakes_model_counts_the_same_engine_brake():
    assert CarModel.from_car(_dtm(), brakes=True).engine_brake_w == engine_brake_power_w(_dtm())


def test_the_ideal_gearbox_reads_the_curve_up_to_the_rev_limit():
    """The padded points past the limit do not count: the point mass is the one of the cut curve,
    its best power 346 kW at 1047 rad/s (the padded curve's 1.1 MW at 1466 rad/s before)."""
    padded = _dtm()
    cut = _dtm(torque_curve_radps=DTM_RADPS[:6], torque_curve_nm=DTM_NM[:6])
    model = CarModel.from_car(padded)
    assert ideal_gearbox_car(padded, model) == ideal_gearbox_car(cut, model)
    car = ideal_gearbox_car(padded, model)
    assert car.limiter_radps == 1047.0
    assert max(np.asarray(car.torque_curve_radps) * np.asarray(car.torque_curve_nm)) == pytest.approx(330.0 * 1047.0)


def test_the_ideal_gearbox_of_a_curve_inside_its_limit_is_the_whole_curve():
    car = _dtm(torque_curve_radps=DTM_RADPS[:6], torque_curve_nm=DTM_NM[:6], engine_revs_max_radps=1100.0)
    point_mass = ideal_gearbox_car(car, CarModel.from_car(car))
    assert point_mass.torque_curve_radps == DTM_RADPS[:6] and point_mass.limiter_radps == 1047.0
    above = dataclasses.replace(car, engine_revs_max_radps=10.0)  # no point under the limit: the whole curve
    assert ideal_gearbox_car(above, CarModel.from_car(above)).torque_curve_radps == DTM_RADPS[:6]
