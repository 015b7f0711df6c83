"""Opponent filters (boxbox.robot.opponents) and the brakes behind a car (boxbox.robot.behind) on
hand-built States: plain numbers and braking physics."""

import math
from dataclasses import replace

import pytest

from boxbox.model import Opponent, State
from boxbox.model.state import CAR_STATE_DNF, CAR_STATE_FINISH, CAR_STATE_PIT
from boxbox.robot.behind import BehindParams, collision_brake, hazard_brake, out_of_control
from boxbox.robot.opponents import (
    Nearby,
    OpponentParams,
    in_lane,
    nearby,
    overtake_offset,
    relate,
    side_steer,
    track_velocity_mps,
)

TRACK_M = 2000.0
LENGTH_M = 4.5
WIDTH_M = 1.9
LOCK_RAD = 0.366
HALF_WIDTH_M = 3.5  # how far aside overtaking may move the line
P = OpponentParams()
G = 9.81


def make_state(**fields) -> State:
    """A State with every field 0 (no opponents) except those given."""
    zero = State._make([0.0] * (len(State._fields) - 1) + [()])
    return zero._replace(**fields)


def make_opp(**fields) -> Opponent:
    zero = Opponent._make([0.0] * len(Opponent._fields))
    return zero._replace(**{"length_m": LENGTH_M, "width_m": WIDTH_M, **fields})


def near(dist_m, lateral_m=0.0, speed_mps=20.0, laps_ahead=0) -> Nearby:
    gap = dist_m - LENGTH_M if dist_m > 0 else dist_m + LENGTH_M
    return related(Nearby(dist_m, gap, lateral_m, speed_mps, laps_ahead))


def related(c: Nearby) -> Nearby:
    """c with its relation to us (relate: the lanes by P's side margin and BehindParams' lane_m)."""
    return relate([c], WIDTH_M, P.side_margin_m, BehindParams().lane_m)[0]


def brakedist(v1, v2, mu=1.0):
    """Plain physics: (v1^2 - v2^2) / (2 mu g); negative when v2 > v1 (no braking needed)."""
    return (v1 * v1 - v2 * v2) / (2.0 * mu * G)


def cars_of(state, back=50.0, front=200.0):
    return nearby(state, LENGTH_M, TRACK_M, back, front)


# --- nearby ------------------------------------------------------------------------------------

def test_nearby_ahead_and_behind():
    s = make_state(dist_from_start_m=500.0, to_middle_m=1.0, laps=3.0, opponents=(
        make_opp(dist_from_start_m=520.0, to_middle_m=-1.5, speed_mps=40.0, laps=3.0),
        make_opp(dist_from_start_m=490.0, to_middle_m=2.0, speed_mps=45.0, laps=4.0),
    ))
    ahead, behind = cars_of(s)
    assert ahead.dist_m == pytest.approx(20.0)
    assert ahead.gap_m == pytest.approx(20.0 - LENGTH_M)  # bumper to bumper
    assert ahead.lateral_m == pytest.approx(-2.5)  # to our right
    assert ahead.speed_mps == 40.0
    assert ahead.laps_ahead == 0
    assert behind.dist_m == pytest.approx(-10.0)
    assert behind.gap_m == pytest.approx(-10.0 + LENGTH_M)
    assert behind.lateral_m == pytest.approx(1.0)  # to our left
    assert behind.laps_ahead == 1
    assert isinstance(behind.laps_ahead, int)


@pytest.mark.parametrize("yaw_rad, speed_x_mps, speed_y_mps, along_mps", [
    (0.0, 20.0, 0.0, 20.0),  # along the track
    (0.2, 20.0, 0.0, 20.0 * math.cos(0.2)),  # at an angle: its share along the track
    (0.0, -2.0, 0.0, -2.0),  # backing
    (math.pi, 5.0, 0.0, -5.0),  # turned round, driving forwards
    (0.5 * math.pi, 0.0, -10.0, 10.0),  # across the track, sliding to its right: forwards
])
def test_along_track_speed_turns_the_cars_velocity_by_its_yaw(yaw_rad, speed_x_mps, speed_y_mps, along_mps):
    o = make_opp(yaw_rad=1.0 + yaw_rad, speed_x_mps=speed_x_mps, speed_y_mps=speed_y_mps)
    assert track_velocity_mps(o, 1.0)[0] == pytest.approx(along_mps)


def test_nearby_with_the_tracks_heading_sees_a_backing_car_as_stopped():
    backing = make_opp(dist_from_start_m=505.0, speed_x_mps=-2.0, speed_mps=2.0)
    s = make_state(dist_from_start_m=500.0, opponents=(backing,))
    (seen,) = nearby(s, LENGTH_M, TRACK_M, 50.0, 200.0, heading_at=lambda dist_m: 0.0)
    assert seen.speed_mps == 0.0
    forwards = make_opp(dist_from_start_m=505.0, yaw_rad=0.2, speed_x_mps=20.0, speed_mps=20.0)
    (ahead,) = nearby(s._replace(opponents=(forwards,)), LENGTH_M, TRACK_M, 50.0, 200.0, heading_at=lambda dist_m: 0.0)
    assert ahead.speed_mps == 20.0  # at an angle, forwards: its speed, not its share along the track
    (plain,) = nearby(s, LENGTH_M, TRACK_M, 50.0, 200.0)
    assert plain.speed_mps == 2.0  # without the heading: the size of its velocity


def test_nearby_wraps_around_the_start_line():
    # we are 10 m before the line, it is 15 m after it: 25 m ahead (not 1975 m behind)
    s = make_state(dist_from_start_m=TRACK_M - 10.0, opponents=(make_opp(dist_from_start_m=15.0),))
    (c,) = cars_of(s)
    assert c.dist_m == pytest.approx(25.0)
    assert c.gap_m == pytest.approx(25.0 - LENGTH_M)
    # we are just past the line, it is 20 m before it: 25 m behind
    s = make_state(dist_from_start_m=5.0, opponents=(make_opp(dist_from_start_m=TRACK_M - 20.0),))
    (c,) = cars_of(s)
    assert c.dist_m == pytest.approx(-25.0)
    assert c.gap_m == pytest.approx(-25.0 + LENGTH_M)


def test_nearby_far_cars_on_the_other_side_of_the_line_are_out_of_range():
    s = make_state(dist_from_start_m=100.0, opponents=(make_opp(dist_from_start_m=TRACK_M - 100.0),))
    assert cars_of(s) == []  # 200 m behind: beyond the back range


def test_nearby_ignores_cars_out_of_the_race():
    s = make_state(dist_from_start_m=500.0, opponents=(
        make_opp(dist_from_start_m=510.0, car_state=float(CAR_STATE_DNF)),
        make_opp(dist_from_start_m=520.0, car_state=float(CAR_STATE_FINISH)),
        make_opp(dist_from_start_m=530.0, car_state=float(CAR_STATE_FINISH | CAR_STATE_DNF)),
        make_opp(dist_from_start_m=540.0, car_state=0.0),
    ))
    cars = cars_of(s)
    assert [c.dist_m for c in cars] == [pytest.approx(40.0)]


def test_nearby_keeps_a_car_in_its_pit():
    pitted = make_opp(dist_from_start_m=510.0, car_state=float(CAR_STATE_PIT))
    s = make_state(dist_from_start_m=500.0, opponents=(pitted,))
    assert len(cars_of(s)) == 1


@pytest.mark.parametrize("offset_m, seen", [
    (-60.0, False), (-51.0, False), (-49.0, True), (-1.0, True), (0.5, True),
    (150.0, True), (199.0, True), (201.0, False), (400.0, False),
])
def test_nearby_back_and_front_ranges(offset_m, seen):
    s = make_state(dist_from_start_m=1000.0, opponents=(make_opp(dist_from_start_m=1000.0 + offset_m),))
    assert (len(cars_of(s, back=50.0, front=200.0)) == 1) == seen


def test_nearby_ranges_are_parameters():
    s = make_state(dist_from_start_m=1000.0, opponents=(make_opp(dist_from_start_m=1030.0),
                                                        make_opp(dist_from_start_m=985.0)))
    assert [c.dist_m for c in cars_of(s, back=10.0, front=20.0)] == []
    assert len(cars_of(s, back=20.0, front=40.0)) == 2


def test_nearby_no_opponents():
    assert cars_of(make_state(dist_from_start_m=10.0)) == []


def test_track_velocity_turns_the_car_frame_velocity_by_its_yaw_to_the_track():
    # yawed 30 degrees left of the track, moving straight ahead at 20 m/s: 17.3 along, 10 to the left
    o = make_opp(yaw_rad=math.radians(30.0), speed_x_mps=20.0)
    along, across = track_velocity_mps(o, 0.0)
    assert (along, across) == pytest.approx((20.0 * math.cos(math.radians(30.0)), 10.0))
    # the track itself turned 30 degrees left as well: all along it
    assert track_velocity_mps(o, math.radians(30.0)) == pytest.approx((20.0, 0.0))
    # sliding sideways to its right at 5 m/s while heading along the track
    assert track_velocity_mps(make_opp(speed_x_mps=20.0, speed_y_mps=-5.0), 0.0) == pytest.approx((20.0, -5.0))


def test_nearby_gives_a_sliding_cars_slip_and_its_speed_across_the_track():
    sliding = make_opp(dist_from_start_m=560.0, speed_x_mps=20.0, speed_y_mps=-20.0, speed_mps=28.28)
    s = make_state(dist_from_start_m=500.0, opponents=(sliding,))
    (seen,) = nearby(s, LENGTH_M, TRACK_M, 50.0, 200.0, heading_at=lambda dist_m: 0.0)
    assert seen.slip_rad == pytest.approx(-math.pi / 4)
    assert seen.across_mps == pytest.approx(-20.0)
    (plain,) = nearby(s, LENGTH_M, TRACK_M, 50.0, 200.0)
    assert (plain.slip_rad, plain.across_mps) == (0.0, 0.0)  # without the heading: unknown


# --- hazard_brake: a car out of control ahead ----------------------------------------------------

HAZARD = OpponentParams(hazard_slip_deg=25.0)


def sliding(dist_m, mid_m, speed_mps, across_mps, slip_deg=0.0, my_mid_m=0.0) -> Nearby:
    gap = dist_m - LENGTH_M
    return related(Nearby(dist_m, gap, mid_m - my_mid_m, speed_mps, 0, WIDTH_M, mid_m, 2, across_mps,
                          math.radians(slip_deg)))


def test_out_of_control_is_a_big_slip_or_crossing_the_road():
    assert not out_of_control(sliding(50.0, 0.0, 30.0, 2.0, slip_deg=5.0), HAZARD)  # racing
    assert out_of_control(sliding(50.0, 0.0, 30.0, 2.0, slip_deg=40.0), HAZARD)  # spinning
    assert out_of_control(sliding(50.0, 0.0, 30.0, 16.0, slip_deg=0.0), HAZARD)  # across the road
    assert not out_of_control(sliding(50.0, 0.0, 2.0, 2.0, slip_deg=90.0), HAZARD)  # stopped: other rules


def test_hazard_brake_for_a_car_sliding_into_our_lane_before_we_reach_it():
    """b-speedway's lap 3 on plain numbers: at 85 m/s, a car 80 m ahead and 20 m to our left at 31
    m/s, 14 m/s of it across the road towards us.  We close at 57 m/s: 1.4 s, in which it slides
    19.6 m across, into our lane; slowing to 28 m/s takes (85^2 - 28^2) / (2 g) = 328 m: brake now."""
    car = sliding(80.0 + LENGTH_M, 20.0, 31.0, -14.0, slip_deg=40.0)
    assert hazard_brake(0.0, 85.0, 0.0, [car], WIDTH_M, HAZARD, brakedist) == 1.0
    # the fixed-gap filter sees it out of our lane: nothing until it is there
    assert collision_brake(0.0, 85.0, [car], HAZARD, brakedist) == 0.0
    # off: nothing
    assert hazard_brake(0.0, 85.0, 0.0, [car], WIDTH_M, P, brakedist) == 0.0


def test_hazard_brake_not_for_a_slide_that_stays_clear_of_our_lane():
    away = sliding(80.0 + LENGTH_M, 10.0, 31.0, 14.0, slip_deg=40.0)  # sliding away from us
    assert hazard_brake(0.0, 85.0, 0.0, [away], WIDTH_M, HAZARD, brakedist) == 0.0
    # the same slide with us 8 m to the left of the middle: it crosses our lane
    assert hazard_brake(0.0, 85.0, 8.0, [away], WIDTH_M, HAZARD, brakedist) == 1.0
    slow_slide = sliding(80.0 + LENGTH_M, 20.0, 31.0, -3.0, slip_deg=40.0)  # 4.2 m across in 1.4 s
    assert hazard_brake(0.3, 85.0, 0.0, [slow_slide], WIDTH_M, HAZARD, brakedist) == 0.3


def test_hazard_brake_not_for_a_car_behind_or_faster_or_far_enough():
    behind = Nearby(-10.0, -10.0 + LENGTH_M, 0.0, 30.0, 0, WIDTH_M, 0.0, 2, 0.0, math.radians(40.0))
    assert hazard_brake(0.0, 40.0, 0.0, [behind], WIDTH_M, HAZARD, brakedist) == 0.0
    faster = sliding(20.0, 0.0, 50.0, 0.0, slip_deg=40.0)
    assert hazard_brake(0.0, 40.0, 0.0, [faster], WIDTH_M, HAZARD, brakedist) == 0.0
    # in our lane, slower, but slowing to its speed takes (40^2 - 30^2) / (2 g) = 35.7 m, far less than 150 m
    far = sliding(150.0, 0.0, 30.0, 0.0, slip_deg=40.0)
    assert hazard_brake(0.0, 40.0, 0.0, [far], WIDTH_M, HAZARD, brakedist) == 0.0


# --- collision_brake ------------------------------------------------------------------------------

def _brake(cars, speed=30.0, brake=0.0):
    return collision_brake(brake, speed, cars, P, brakedist)


def test_collision_brake_for_a_slower_car_ahead_within_braking_distance():
    # 30 -> 20 m/s needs (900 - 400) / (2 g) = 25.5 m, plus the 3 m margin = 28.5 m
    need = brakedist(30.0, 20.0) + P.length_margin_m
    assert need == pytest.approx(28.48, abs=0.01)
    assert _brake([near(LENGTH_M + 25.0, speed_mps=20.0)]) == 1.0
    assert _brake([near(LENGTH_M + need - 0.3, speed_mps=20.0)]) == 1.0
    assert _brake([near(LENGTH_M + need + 0.3, speed_mps=20.0)]) == 0.0
    assert _brake([near(LENGTH_M + 60.0, speed_mps=20.0)], brake=0.2) == 0.2  # input passes unchanged


def test_collision_brake_uses_our_speed_then_theirs():
    """brakedist(our speed, its speed): the other order gives a negative distance (no brake)."""
    calls = []

    def spy(v1, v2):
        calls.append((v1, v2))
        return brakedist(v1, v2)

    assert collision_brake(0.0, 30.0, [near(LENGTH_M + 20.0, speed_mps=20.0)], P, spy) == 1.0
    assert calls == [(30.0, 20.0)]


def test_collision_brake_margin_is_a_parameter():
    need = brakedist(30.0, 20.0)
    car = near(LENGTH_M + need + 5.0, speed_mps=20.0)
    assert _brake([car]) == 0.0
    wide = OpponentParams(length_margin_m=10.0)
    assert collision_brake(0.0, 30.0, [car], wide, brakedist) == 1.0


def test_collision_brake_when_almost_touching_a_slightly_slower_car():
    # 30 -> 29.9 needs only 0.3 m, but a gap under the length margin is too close anyway
    assert _brake([near(LENGTH_M + 2.0, speed_mps=29.9)]) == 1.0


def test_collision_brake_not_for_a_car_in_the_other_lane():
    lane = WIDTH_M + P.side_margin_m  # 2.9 m
    assert _brake([near(LENGTH_M + 10.0, lateral_m=lane + 0.5, speed_mps=10.0)]) == 0.0
    assert _brake([near(LENGTH_M + 10.0, lateral_m=-(lane + 0.5), speed_mps=10.0)]) == 0.0
    assert _brake([near(LENGTH_M + 10.0, lateral_m=lane - 0.5, speed_mps=10.0)]) == 1.0
    assert _brake([near(LENGTH_M + 10.0, lateral_m=-(lane - 0.5), speed_mps=10.0)]) == 1.0


def test_collision_brake_not_for_a_faster_car_or_one_behind():
    assert _brake([near(LENGTH_M + 5.0, speed_mps=35.0)]) == 0.0  # faster: the gap opens
    assert _brake([near(LENGTH_M + 2.0, speed_mps=35.0)]) == 0.0  # even closer than the length margin
    # with a braking distance that is never negative (0 when no braking is needed)
    nonneg = lambda v1, v2: max(0.0, brakedist(v1, v2))  # noqa: E731
    assert collision_brake(0.0, 30.0, [near(LENGTH_M + 2.0, speed_mps=35.0)], P, nonneg) == 0.0
    assert _brake([near(LENGTH_M + 5.0, speed_mps=30.0)]) == 0.0  # same speed
    assert _brake([near(-LENGTH_M - 2.0, speed_mps=10.0)]) == 0.0  # slower, but behind us


def test_collision_brake_soft_is_the_share_of_a_full_brake_the_gap_needs():
    soft = OpponentParams(soft_gap_m=1.0)
    # 30 -> 29.5 m/s needs (900 - 870.25) / (2 g) = 1.52 m; 4 m between bumpers leaves 3 m beyond the
    # soft gap: half a full brake slows us to its speed there
    need = brakedist(30.0, 29.5)
    assert collision_brake(0.0, 30.0, [near(LENGTH_M + 4.0, speed_mps=29.5)], soft, brakedist) \
        == pytest.approx(need / 3.0)
    assert _brake([near(LENGTH_M + 4.0, speed_mps=29.5)]) == 1.0  # the tutorial's: full whenever it fires
    # within the soft gap, or with less room than the braking distance: full
    assert collision_brake(0.0, 30.0, [near(LENGTH_M + 0.8, speed_mps=29.5)], soft, brakedist) == 1.0
    assert collision_brake(0.0, 30.0, [near(LENGTH_M + 20.0, speed_mps=20.0)], soft, brakedist) == 1.0
    # never less than the brake it is given, and none where the tutorial's does not fire
    assert collision_brake(0.7, 30.0, [near(LENGTH_M + 4.0, speed_mps=29.5)], soft, brakedist) == 0.7
    assert collision_brake(0.0, 30.0, [near(LENGTH_M + 30.0, speed_mps=20.0)], soft, brakedist) == 0.0


def test_in_lane_is_within_our_width_plus_the_side_margin():
    lane = WIDTH_M + P.side_margin_m
    assert in_lane(near(10.0, lateral_m=lane - 0.01), WIDTH_M, P.side_margin_m)
    assert in_lane(near(10.0, lateral_m=-(lane - 0.01)), WIDTH_M, P.side_margin_m)
    assert not in_lane(near(10.0, lateral_m=lane), WIDTH_M, P.side_margin_m)
    assert not in_lane(near(10.0, lateral_m=-(lane + 1.0)), WIDTH_M, P.side_margin_m)


def test_in_lane_with_half_widths_is_the_sides_within_the_margin():
    """racecraft's lane: half of both widths apart plus the margin (a car's width ours when unknown)."""
    wide = Nearby(10.0, 5.5, 0.0, 20.0, 0, 3.0)  # 3 m wide: 2.5 m centre to centre plus the margin
    assert in_lane(replace(wide, lateral_m=2.5 + 1.0 - 0.01), 2.0, 1.0, half_widths=True)
    assert not in_lane(replace(wide, lateral_m=-(2.5 + 1.0)), 2.0, 1.0, half_widths=True)
    unknown = replace(wide, width_m=0.0, lateral_m=2.0 + 1.0 - 0.01)  # its width ours: 2 m apart
    assert in_lane(unknown, 2.0, 1.0, half_widths=True) and not in_lane(unknown, 2.0, 0.5, half_widths=True)


def test_collision_brake_any_dangerous_car_among_several():
    cars = [near(-20.0, speed_mps=10.0), near(LENGTH_M + 10.0, lateral_m=5.0, speed_mps=5.0),
            near(LENGTH_M + 10.0, speed_mps=15.0)]
    assert _brake(cars) == 1.0
    assert _brake(cars[:2], brake=0.4) == 0.4


# --- side_steer ----------------------------------------------------------------------------------

def _side(cars, steer=0.0, params=P):
    return side_steer(steer, cars, LENGTH_M, WIDTH_M, LOCK_RAD, params)


def test_side_steer_away_from_a_car_alongside_on_the_left():
    # 2.5 m to our left: free space 2.5 - 1.9 = 0.6 m < 1 m margin -> push 0.4 * 0.1 / lock to the right
    s = _side([near(1.0, lateral_m=2.5)])
    assert s == pytest.approx(-(1.0 - 0.6) * 0.1 / LOCK_RAD, rel=1e-9)
    assert s < 0.0


def test_side_steer_away_from_a_car_alongside_on_the_right():
    s = _side([near(-2.0, lateral_m=-2.2)], steer=0.1)
    assert s == pytest.approx(0.1 + (1.0 - 0.3) * 0.1 / LOCK_RAD, rel=1e-9)


def test_side_steer_harder_when_closer():
    assert _side([near(0.0, lateral_m=2.0)]) < _side([near(0.0, lateral_m=2.6)]) < 0.0


def test_side_steer_leaves_the_steer_alone_with_room_or_nobody_alongside():
    assert _side([near(0.0, lateral_m=WIDTH_M + 1.2)], steer=0.3) == 0.3  # enough room
    assert _side([near(0.0, lateral_m=-(WIDTH_M + 1.2))], steer=-0.3) == -0.3
    assert _side([near(LENGTH_M + 1.0, lateral_m=2.0)], steer=0.3) == 0.3  # ahead, not alongside
    assert _side([near(-LENGTH_M - 1.0, lateral_m=2.0)], steer=0.3) == 0.3  # behind
    assert _side([], steer=0.3) == 0.3


def test_side_steer_margin_is_a_parameter():
    car = [near(0.0, lateral_m=WIDTH_M + 1.2)]
    assert _side(car) == 0.0
    assert _side(car, params=OpponentParams(side_margin_m=2.0)) < 0.0


def test_side_steer_clamps():
    assert _side([near(0.0, lateral_m=-0.5)], steer=0.99) == 1.0
    assert _side([near(0.0, lateral_m=0.5)], steer=-0.99) == -1.0


# --- overtake_offset -----------------------------------------------------------------------------

def _overtake(offset, cars, my_speed=40.0, my_to_middle=0.0, params=P):
    return overtake_offset(offset, my_speed, my_to_middle, cars, HALF_WIDTH_M, LENGTH_M, params)


def test_overtake_moves_to_the_right_of_a_slower_car_ahead_on_the_left():
    car = [near(LENGTH_M + 5.0, lateral_m=1.0, speed_mps=30.0)]  # it is left of the middle
    off = _overtake(0.0, car)
    assert off == pytest.approx(-P.overtake_step_m)
    for _ in range(200):
        off = _overtake(off, car)
    assert off == pytest.approx(-HALF_WIDTH_M)  # all the way, and no further


def test_overtake_moves_to_the_left_of_a_slower_car_ahead_on_the_right():
    car = [near(LENGTH_M + 5.0, lateral_m=-1.0, speed_mps=30.0)]
    off = 0.0
    steps = []
    for _ in range(50):
        off = _overtake(off, car)
        steps.append(off)
    assert steps[:3] == [pytest.approx(0.1), pytest.approx(0.2), pytest.approx(0.3)]
    assert off == pytest.approx(HALF_WIDTH_M)


def test_overtake_takes_the_side_with_more_room_not_the_side_away_from_us():
    # we are 3 m right of the middle; the car is 1 m to our left, so still 2 m right of the middle:
    # the free side is the left one
    car = [near(LENGTH_M + 5.0, lateral_m=1.0, speed_mps=30.0)]
    assert _overtake(0.0, car, my_to_middle=-3.0) == pytest.approx(0.1)
    assert _overtake(0.0, car, my_to_middle=3.0) == pytest.approx(-0.1)


def test_overtake_keeps_the_side_we_are_on_when_too_close_to_cross_behind_the_car():
    # e-track-1 at 240 m: 4.6 m right of a car in the track's middle, 9 m behind it and 14 m/s faster
    car = [near(LENGTH_M + 4.5, lateral_m=4.6, speed_mps=33.0)]
    keep = OpponentParams(keep_side_s=2.0)
    assert _overtake(0.0, car, my_speed=47.0, my_to_middle=-4.6) == pytest.approx(0.1)  # the tutorial: across it
    assert _overtake(0.0, car, my_speed=47.0, my_to_middle=-4.6, params=keep) == pytest.approx(-0.1)  # our side
    # reached in more than 2 s (8 m at 3 m/s, within two car lengths): time to cross behind it
    far = [near(LENGTH_M + 8.0, lateral_m=4.6, speed_mps=44.0)]
    assert _overtake(0.0, far, my_speed=47.0, my_to_middle=-4.6, params=keep) == pytest.approx(0.1)
    # right behind it (0.5 m aside): the side with more room, as the tutorial
    behind = [near(LENGTH_M + 4.5, lateral_m=0.5, speed_mps=33.0)]
    assert _overtake(0.0, behind, my_speed=47.0, my_to_middle=-0.5, params=keep) == pytest.approx(0.1)


def test_overtake_passes_a_car_we_lap_on_our_side_of_it_with_lapped_own_side():
    # we are 1.3 m right of the middle, the car 0.3 m to our left (1 m right of the middle): the
    # tutorial's side (more room) is its left, across its path as it moves left, away from us, to let
    # us by; with the option, the side we are on: its right
    car = [near(LENGTH_M + 5.0, lateral_m=0.3, speed_mps=30.0, laps_ahead=-1)]
    own = OpponentParams(lapped_own_side=True)
    assert _overtake(0.0, car, my_to_middle=-1.3) == pytest.approx(0.1)  # the tutorial: left of it, across it
    assert _overtake(0.0, car, my_to_middle=-1.3, params=own) == pytest.approx(-0.1)  # our side: its right
    same_lap = [near(LENGTH_M + 5.0, lateral_m=0.3, speed_mps=30.0, laps_ahead=0)]
    assert _overtake(0.0, same_lap, my_to_middle=-1.3, params=own) == pytest.approx(0.1)  # as the tutorial


def test_overtake_step_is_a_parameter():
    car = [near(LENGTH_M + 5.0, lateral_m=-1.0, speed_mps=30.0)]
    assert _overtake(0.0, car, params=OpponentParams(overtake_step_m=0.25)) == pytest.approx(0.25)


def test_overtake_returns_to_zero_when_nobody_is_there():
    off = 1.0
    seen = []
    for _ in range(30):
        off = _overtake(off, [])
        seen.append(off)
    assert seen[0] == pytest.approx(0.9)
    assert seen[-1] == 0.0
    assert _overtake(-0.05, []) == 0.0  # does not overshoot past zero
    assert _overtake(0.0, []) == 0.0


def test_overtake_ignores_a_faster_car_a_far_car_and_a_car_behind():
    assert _overtake(0.0, [near(LENGTH_M + 5.0, lateral_m=-1.0, speed_mps=45.0)]) == 0.0  # faster
    assert _overtake(0.0, [near(LENGTH_M + 60.0, lateral_m=-1.0, speed_mps=35.0)]) == 0.0  # far ahead
    assert _overtake(0.0, [near(-8.0, lateral_m=-1.0, speed_mps=20.0)]) == 0.0  # behind, same lap
    assert _overtake(0.5, [near(LENGTH_M + 60.0, lateral_m=-1.0, speed_mps=35.0)]) == pytest.approx(0.4)


def test_overtake_reach_grows_with_the_speed_difference():
    # closing at 20 m/s: start moving 40 m before (2 s), more than 2 car lengths
    car = [near(LENGTH_M + 30.0, lateral_m=-1.0, speed_mps=20.0)]
    assert _overtake(0.0, car, my_speed=40.0) == pytest.approx(0.1)
    assert _overtake(0.0, car, my_speed=25.0) == 0.0  # closing at 5 m/s: 30 m is still far


def test_overtake_moves_aside_for_a_lapping_car_close_behind():
    lapper = [near(-8.0, lateral_m=1.0, speed_mps=50.0, laps_ahead=1)]  # behind us, on the left
    off = 0.0
    for _ in range(100):
        off = _overtake(off, lapper)
    assert off == pytest.approx(-HALF_WIDTH_M)  # it passes on the left, we keep right
    lapper = [near(-8.0, lateral_m=-1.0, speed_mps=50.0, laps_ahead=1)]
    assert _overtake(0.0, lapper) == pytest.approx(0.1)
    # far behind (more than 4 car lengths): not yet
    assert _overtake(0.0, [near(-4 * LENGTH_M - 2.0, lateral_m=1.0, speed_mps=50.0, laps_ahead=1)]) == 0.0


def test_overtake_from_states_end_to_end():
    s = make_state(dist_from_start_m=300.0, to_middle_m=0.0, laps=2.0, speed_x_mps=40.0, opponents=(
        make_opp(dist_from_start_m=310.0, to_middle_m=-1.0, speed_mps=30.0, laps=2.0),))
    assert _overtake(0.0, cars_of(s)) == pytest.approx(0.1)


def test_lapping_car_behind_across_the_start_line_is_let_past():
    # we have just crossed the line (lap 3, 5 m in); the car is 15 m behind us, still in its lap 3
    # before the line, i.e. it has raced L - 15 m more than us: it is lapping us
    s = make_state(dist_from_start_m=5.0, to_middle_m=0.0, laps=3.0, opponents=(
        make_opp(dist_from_start_m=TRACK_M - 10.0, to_middle_m=1.0, speed_mps=60.0, laps=3.0),))
    (c,) = cars_of(s)
    if c.dist_m != pytest.approx(-15.0):
        raise RuntimeError("test setup: the car should be 15 m behind")
    assert c.laps_ahead > 0
    assert _overtake(0.0, [c]) == pytest.approx(-0.1)


def test_laps_ahead_counts_the_start_line_between_the_cars():
    # same lap, 15 m ahead of us across the line: its lap counter is one more, but it is not lapping us
    s = make_state(dist_from_start_m=TRACK_M - 10.0, laps=3.0, opponents=(make_opp(dist_from_start_m=5.0, laps=4.0),))
    (c,) = cars_of(s)
    assert c.dist_m == pytest.approx(15.0) and c.laps_ahead == 0
    # a lap down, 15 m behind us across the line
    s = make_state(dist_from_start_m=5.0, laps=4.0, opponents=(make_opp(dist_from_start_m=TRACK_M - 10.0, laps=2.0),))
    (c,) = cars_of(s)
    assert c.dist_m == pytest.approx(-15.0) and c.laps_ahead == -1
    # two laps ahead, away from the line
    s = make_state(dist_from_start_m=500.0, laps=2.0, opponents=(make_opp(dist_from_start_m=480.0, laps=4.0),))
    (c,) = cars_of(s)
    assert c.laps_ahead == 2


def test_overtake_passes_a_car_at_our_speed_that_is_slower_than_we_go_alone_with_draft_on():
    # f-speedway: 3 m behind a car at 81.7 m/s, both flat out; alone our lap simulation goes 85.8 here
    car = [near(LENGTH_M + 3.0, lateral_m=-0.8, speed_mps=81.7)]
    draft = OpponentParams(draft_mps=4.0)

    def off(params, alone_mps, cars=car):
        return overtake_offset(0.0, 81.7, 0.0, cars, HALF_WIDTH_M, LENGTH_M, params, alone_mps)

    assert off(draft, 85.8) == pytest.approx(0.1)  # 4.1 m/s slower than alone: towards its free side
    assert off(draft, 85.6) == 0.0  # 3.9 m/s: too little to get by out of its slipstream
    assert off(P, 85.8) == 0.0  # off by default: the tutorial passes only a car slower than us
    # a car slower than us is passed whatever our speed alone (the tutorial's rule stands)
    slower = [near(LENGTH_M + 3.0, lateral_m=-0.8, speed_mps=80.0)]
    assert off(draft, 0.0, slower) == pytest.approx(0.1)
    # nor a car out of reach: too far ahead for the tutorial's window (two car lengths at our speed)
    assert off(draft, 85.8, [near(LENGTH_M + 12.0, lateral_m=-0.8, speed_mps=81.7)]) == 0.0
