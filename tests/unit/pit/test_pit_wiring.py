"""One wiring of the pit brake filter (robot/pit.py's pit_brake_filter) for the robot's pit part
and the gym's pit stops, each with its named parameter set: the robot's PitParams (its tuned pit_*
parameters), the gym's GYM_PIT_PARAMS (the filter's own defaults, as its pit stops were made)."""

import pytest

from boxbox.control.carmodel import CarModel
from boxbox.model.constants import G_MPS2
from boxbox.robot.base import RaceOptions
from boxbox.robot.pit import PitParams, PitStops
from trackdata import load


def _lane_mu(path, model) -> float:
    return path.surface_friction * model.mu


def test_the_gym_stops_with_its_own_set_through_the_same_wiring():
    from boxbox.gym.pitstop import GYM_PIT_PARAMS, PitStop

    track, car = load("e-track-2")
    stop = PitStop(track, car)
    f, lane_mu = stop.filter, _lane_mu(stop.path, CarModel.from_car(car, car.tank_l / 2.0))
    # the values the gym's own wiring gave: half the lane's grip at the box, 0.5 m, 5 s, 0.9
    assert f.stop.max_decel_mps2 == pytest.approx(0.5 * lane_mu * G_MPS2)
    assert (f.stop_mode, f.stop_threshold_m, f.give_up_timeout_s, f.surface_mu_scale) == (
        "constant-decel", 0.5, 5.0, 0.9)
    assert GYM_PIT_PARAMS.lookahead_m == 4.0


def test_the_robot_stops_with_its_tuned_set():
    track, car = load("e-track-2")
    pits = PitStops(track, car, RaceOptions(laps=3))
    f, lane_mu = pits.brake_filter, _lane_mu(pits.path, pits.model)
    p = PitParams()
    assert f.stop.max_decel_mps2 == pytest.approx(p.stop_grip_share * lane_mu * G_MPS2)
    assert (f.stop_threshold_m, f.give_up_timeout_s, f.surface_mu_scale) == (
        p.stop_threshold_m, p.give_up_s, p.brake_mu_scale) == (0.1, 10.0, 0.65)
