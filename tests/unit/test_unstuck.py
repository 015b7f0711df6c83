"""The getting-unstuck part (robot/unstuck.py) on plain numbers: a car stopped against a wall backs
out after 2 s with the nose steered back to the track, a moving car is left alone, backing goes on
until the car points along the track (at most 4 s), boxed in it holds on the brakes, blind it
brakes; a car coming from behind holds the backing car on the brakes."""

from __future__ import annotations

import math

import pytest

from boxbox import Unstuck, UnstuckParams
from boxbox.model import Opponent
from boxbox.model.constants import DRIVE_STEP_S
from boxbox.robot.unstuck import BOXED_HOLD_S, REVERSE_MAX_S
from boxbox.testing import make_state
from trackdata import load

TRACK, CAR = load("e-track-2")
# against the left wall, pointing right of the track's direction, towards it: stuck after 2 s
AGAINST_WALL = make_state(dist_from_start_m=300.0, speed_x_mps=1.0, to_middle_m=4.0, angle_rad=-0.8, gear=1)
STUCK_STEPS = int(UnstuckParams().time_s / DRIVE_STEP_S) + 1  # drive steps stuck until it backs


def run(part: Unstuck, state, steps: int, dt_s: float = DRIVE_STEP_S, t0_s: float = 0.0) -> list:
    return [part.step(state._replace(sim_time_s=t0_s + i * dt_s)) for i in range(steps)]


def test_a_car_against_a_wall_backs_out_after_2_s_steering_its_nose_to_the_track():
    part = Unstuck(TRACK, CAR)
    answers = run(part, AGAINST_WALL, STUCK_STEPS + 1)
    assert all(a is None for a in answers[:STUCK_STEPS - 1])  # 2 s: drive on
    c = answers[-1]
    assert c is not None and c.gear == -1 and c.accel > 0.0 and c.brake == 0.0
    assert c.steer == 1.0  # angle -0.8, past the 0.37 rad lock: full lock left, the nose back to the track
    assert c.problem(CAR.max_gear) is None and part.reversing


@pytest.mark.parametrize("change", [dict(speed_x_mps=12.0), dict(angle_rad=-0.3), dict(to_middle_m=2.0),
                                    dict(angle_rad=0.8)])  # moving; along the track; near the middle; pointing away
def test_a_car_moving_or_not_sideways_at_an_edge_is_left_alone(change):
    part = Unstuck(TRACK, CAR)
    assert all(a is None for a in run(part, AGAINST_WALL._replace(**change), 3 * STUCK_STEPS))


def test_backing_goes_on_until_the_car_points_along_the_track_for_at_most_4_s():
    part = Unstuck(TRACK, CAR)
    run(part, AGAINST_WALL, STUCK_STEPS + 1)
    # no longer stuck by the rule that started it (2 m off the middle), still at 23 deg: backing on
    backing = AGAINST_WALL._replace(to_middle_m=2.0, angle_rad=-0.4, speed_x_mps=-3.0, gear=-1)
    assert all(c is not None and c.gear == -1 for c in run(part, backing, int(3.9 / DRIVE_STEP_S)))
    assert part.step(backing._replace(speed_x_mps=-5.0)).accel == 0.0  # past 4 m/s backwards: no throttle
    assert all(a is None for a in run(part, backing, int(0.2 / DRIVE_STEP_S))[-3:])  # past 4 s: drive on
    assert part.reverse_steps * DRIVE_STEP_S == pytest.approx(REVERSE_MAX_S + DRIVE_STEP_S)
    part = Unstuck(TRACK, CAR)
    run(part, AGAINST_WALL, STUCK_STEPS + 1)
    assert part.step(backing._replace(angle_rad=-0.2)) is None  # 11 deg, under half of 30: along the track


def test_turned_round_it_backs_out_only_when_grinding_into_something():
    part = Unstuck(TRACK, CAR)
    turned = make_state(dist_from_start_m=300.0, speed_x_mps=1.5, to_middle_m=0.5, angle_rad=3.0)
    assert all(a is None for a in run(part, turned, 200))  # alone: forward round the lock
    c = part.step(turned._replace(damage=10.0, sim_time_s=4.0))
    assert c is not None and c.gear == -1


def test_boxed_in_it_holds_on_the_brakes_then_tries_again():
    part = Unstuck(TRACK, CAR)
    turned = make_state(dist_from_start_m=300.0, speed_x_mps=0.5, to_middle_m=0.5, angle_rad=3.0)
    part.step(turned)
    assert part.step(turned._replace(damage=10.0, sim_time_s=0.02)).gear == -1
    stuck = turned._replace(speed_x_mps=-0.2, gear=-1)
    answers = [part.step(stuck._replace(damage=10.0 + i, sim_time_s=0.04 + 0.02 * i)) for i in range(40)]
    assert answers[10].gear == -1 and answers[-1].brake == 1.0 and answers[-1].accel == 0.0
    assert 0.5 < part.hold_until_s - BOXED_HOLD_S < 0.85
    held = part.step(stuck._replace(damage=70.0, sim_time_s=part.hold_until_s - 0.1))  # hit while held ...
    assert held is not None and held.brake == 1.0 and held.accel == 0.0
    assert part.step(stuck._replace(damage=70.0, sim_time_s=part.hold_until_s + 0.1)) is None  # ... is not new


def test_blind_it_brakes_in_its_gear():
    c = Unstuck(TRACK, CAR).step(make_state(dist_from_start_m=math.nan, gear=3))
    assert c is not None and (c.brake, c.accel, c.gear) == (1.0, 0.0, 3)


def test_a_car_coming_from_behind_holds_the_backing_car_on_the_brakes():
    part = Unstuck(TRACK, CAR)
    run(part, AGAINST_WALL, STUCK_STEPS + 1)
    fields = dict.fromkeys(Opponent._fields, 0.0)
    coming = Opponent(**{**fields, "dist_from_start_m": 270.0, "speed_mps": 30.0, "length_m": 4.5, "width_m": 2.0})
    c = part.step(AGAINST_WALL._replace(opponents=(coming,), n_opponents=1))
    assert c is not None and c.gear == -1 and c.brake == 1.0


def test_backing_away_from_a_wreck_goes_the_distance_asked():
    part = Unstuck(TRACK, CAR)
    part.back_away(make_state(dist_from_start_m=300.0), 11.0)
    backing = make_state(speed_x_mps=-2.0, gear=-1)
    assert part.step(backing._replace(dist_from_start_m=295.0)).gear == -1
    assert part.step(backing._replace(dist_from_start_m=288.0)) is None
