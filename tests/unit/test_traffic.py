"""Traffic geometry on plain numbers (control/traffic.py) and racecraft's decisions (robot/racecraft.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from boxbox.control.offset_room import offset_room_ahead
from boxbox.control.traffic import pass_side, room
from boxbox.robot.opponent_lines import OpponentLines
from boxbox.robot.opponents import Nearby, relate
from boxbox.robot.racecraft import Racecraft, RacecraftParams

G = 9.81


def test_room_keeps_us_clear_of_cars_alongside():
    # a 2 m car 2.5 m to our right (at -2.5; we are at 0): our centre no lower than -2.5 + 2 + 1
    lo, hi = room(0.0, [(-2.5, 2.0)], 2.0, 1.0, 5.0, -5.0)
    assert (lo, hi) == (pytest.approx(0.5), 5.0)
    lo, hi = room(0.0, [(-1.0, 2.0), (1.0, 2.0)], 2.0, 1.0, 5.0, -5.0)
    assert lo == hi == pytest.approx(0.0)  # squeezed: the middle of what is left


def test_pass_side_takes_the_inside_with_room_else_the_wider_side():
    # a 2 m car at +1 m on a track from -5 to +5, gap 1.5 m: left needs 1 + 3.5 = 4.5 <= 5, right 1 - 3.5 = -2.5
    assert pass_side(1.0, 2.0, 2.0, 1.5, 5.0, -5.0, inside_sign=1.0) == (1.0, 4.5)
    assert pass_side(1.0, 2.0, 2.0, 1.5, 5.0, -5.0, inside_sign=0.0) == (-1.0, -2.5)
    assert pass_side(0.0, 2.0, 2.0, 1.5, 3.0, -3.0, inside_sign=1.0) is None  # no room either side
    # too close to cross behind it: only our side (we are to its right)
    assert pass_side(1.0, 2.0, 2.0, 1.5, 5.0, -5.0, inside_sign=1.0, my_mid_m=0.0) == (-1.0, -2.5)


def _car(dist_m, mid_m, speed_mps, my_mid_m=0.0, laps_ahead=0):
    gap = dist_m - 4.5 if dist_m > 0 else dist_m + 4.5
    # with its relation to a 2 m wide us: the lanes by OpponentParams' and RacecraftParams' defaults
    return relate([Nearby(dist_m, gap, mid_m - my_mid_m, speed_mps, laps_ahead, 2.0, mid_m)], 2.0, 1.0, 1.0)[0]


def _craft(**kw):
    return Racecraft(RacecraftParams(**kw), width_m=2.0, length_m=4.5, mu=1.2)


def test_racecraft_gives_room_to_a_car_alongside_and_marks_the_step_spoiled():
    craft = _craft()
    assert not craft.spoiled(0.0)
    # racing line at our position (0), a car alongside on our left at +2 m: the line moves right
    off = craft.offset(1.0, 30.0, 0.0, [_car(1.0, 2.0, 30.0)], 0.0, 0.0, (6.0, -6.0), 0.0, 0.1, 0.0)
    assert off <= 2.0 - (2.0 + 1.0) + 1e-9
    assert craft.spoiled(1.5) and not craft.spoiled(2.5)


def test_a_car_predicted_across_us_gets_room_on_the_side_it_is_on():
    """A car on our right closing in sideways so fast that 0.5 s ahead it would be on our left is
    taken at our centre, still on our right: the room pushes us left, away from it, not into it."""
    craft = _craft()
    craft.predict(0.0, [_car(1.0, -3.0, 30.0)])
    cars = craft.predict(0.02, [_car(1.0, -2.8, 30.0)])  # 10 m/s towards us: 2.2 m left of us in 0.5 s
    assert cars[0].lateral_m < 0.0 and cars[0].mid_m < 0.0
    off = craft.offset(0.02, 30.0, 0.0, cars, 0.0, 0.0, (6.0, -6.0), 0.0, 0.1, 0.0)
    assert off == pytest.approx(0.5 * (2.0 + 2.0) + 1.5 - 1e-3)


def test_racecraft_leaves_the_line_alone_when_nobody_is_near():
    craft = _craft()
    far = _car(150.0, 0.0, 30.0)  # far ahead, no faster than us
    assert craft.offset(1.0, 30.0, 0.0, [far], 0.0, 0.0, (6.0, -6.0), 0.0, 0.1, 0.0) == 0.0
    assert not craft.spoiled(1.0)


def test_racecraft_touches_the_brake_behind_a_close_car_unless_it_pulls_away():
    craft = _craft()
    # 1 m gap (margin 2 m) in our lane, gap filter only: half the close brake for a car as fast as us
    same = _car(5.5, 0.0, 20.0)
    assert craft.brake(0.0, 0.0, 20.0, [same]) == pytest.approx(0.25)
    # faster than us (close_opening_mps 0): it pulls away, no brake; with 1 m/s allowed, 0.9 faster: still
    assert craft.brake(0.0, 0.0, 20.0, [_car(5.5, 0.0, 20.9)]) == 0.0
    assert craft.brake(0.0, 0.0, 18.0, [_car(5.5, 0.0, 22.0)]) == 0.0
    one = _craft(close_opening_mps=1.0)
    assert one.brake(0.0, 0.0, 20.0, [_car(5.5, 0.0, 20.9)]) > 0.0
    # the old rule (faster or not) with an unlimited opening speed
    always = _craft(close_opening_mps=math.inf)
    assert always.brake(0.0, 0.0, 18.0, [_car(5.5, 0.0, 22.0)]) > 0.0


def test_inside_speed_follows_the_tighter_radius():
    from boxbox.robot.racecraft import inside_speed_mps
    # R = 20 m left turn, 2 m to the left (inside): R 18 m, speed x sqrt(18/20)
    assert inside_speed_mps(20.0, 0.05, 2.0) == pytest.approx(20.0 * math.sqrt(0.9))
    assert inside_speed_mps(20.0, 0.05, -2.0) == 20.0  # outside: unchanged
    assert inside_speed_mps(20.0, -0.05, -2.0) == pytest.approx(20.0 * math.sqrt(0.9))


def test_a_pass_under_way_on_the_inside_is_not_called_back_to_the_line():
    craft = _craft()  # keep_inside, commit_lengths 2.5 (11.25 m here)
    near, far = _car(8.0, 0.5, 25.0), _car(20.0, 0.5, 25.0)
    # right turn ahead (inside -1) sharp enough at 30 m/s for the hold-line rule; the tutorial moved us right
    def step(car, inside):
        return craft.offset(0.0, 30.0, 0.0, [car], -0.5, 0.0, (6.0, -6.0), inside, 0.1, -0.6, 0.01)
    assert step(near, -1.0) == pytest.approx(-0.6) and craft.pass_side == -1.0  # under way on the inside: kept
    assert step(far, -1.0) == pytest.approx(-0.4) and craft.pass_side == 0.0  # not under way: back to the line
    assert step(near, 1.0) == pytest.approx(-0.6)  # aside towards the outside (left turn): kept too
    craft = _craft(keep_outside=False)
    assert step(near, 1.0) == pytest.approx(-0.4)  # ... unless keep_outside is off: back to the line
    assert _craft(keep_inside=False).offset(0.0, 30.0, 0.0, [near], -0.5, 0.0, (6.0, -6.0), -1.0, 0.1,
                                            -0.6, 0.01) == pytest.approx(-0.4)


def test_an_offset_towards_the_outside_of_a_turn_is_kept_and_one_inwards_is_not():
    """keep_outside: moving out widens the radius (the line's speed holds), moving in tightens it."""
    craft = _craft(keep_inside=False)
    car = _car(30.0, 0.5, 25.0)  # far ahead: no pass under way

    def step(offset, inside):  # a turn ahead needing most of the grip at 30 m/s
        return craft.offset(0.0, 30.0, 0.0, [car], offset, 0.0, (6.0, -6.0), inside, 0.1, offset, 0.01)
    assert step(1.0, -1.0) == pytest.approx(1.0)  # left of the line, right turn: outside, kept
    assert step(1.0, 1.0) == pytest.approx(0.9)  # left of the line, left turn: inside, back to the line
    assert step(-1.0, 1.0) == pytest.approx(-1.0)  # right of the line, left turn: outside, kept
    assert _craft(keep_inside=False, keep_outside=False).offset(
        0.0, 30.0, 0.0, [car], 1.0, 0.0, (6.0, -6.0), -1.0, 0.1, 1.0, 0.01) == pytest.approx(0.9)


def test_opponent_lines_remember_where_each_car_drove():
    lines = OpponentLines(1000.0, 5.0)
    lines.observe(990.0, [replace(_car(20.0, 3.0, 30.0), index=4)])  # at 10 m past the line: wraps
    assert lines.mid_at(4, 1012.0, 0.0) == pytest.approx(3.0)  # the same 5 m step, a lap on
    assert lines.mid_at(4, 500.0, -1.0) == -1.0  # never seen there: the fallback
    assert lines.mid_at(7, 10.0, -2.0) == -2.0  # a car never seen
    with pytest.raises(ValueError, match="positive"):
        OpponentLines(0.0, 5.0)


def test_offset_room_is_the_least_room_over_the_road_ahead():
    line = np.array([0.0, 0.0, -3.0, -4.0, 0.0])  # the line runs to the right edge at sample 3
    left, right = np.full(5, 5.0), np.full(5, 5.0)
    room_l, room_r = offset_room_ahead(line, left, right, 2)
    assert room_r.tolist() == [2.0, 1.0, 1.0, 1.0, 5.0]  # the apex at 3 bounds the samples before it
    assert room_l.tolist() == [5.0, 5.0, 5.0, 5.0, 5.0]
    assert offset_room_ahead(line, left, right, 0)[1].tolist() == [5.0, 5.0, 2.0, 1.0, 5.0]
    assert offset_room_ahead(line, left, right, 99)[1].tolist() == [1.0] * 5  # the whole lap, wrapping
    with pytest.raises(ValueError):
        offset_room_ahead(line, left, right[:4], 2)
    with pytest.raises(ValueError):
        offset_room_ahead(line, left, np.full(5, np.nan), 2)


def test_a_stopped_car_in_our_lane_blocks_us_only_while_we_are_stopped_too():
    craft = _craft()
    wreck = _car(6.4, 0.5, 0.2)
    assert craft.blocking(0.0, [wreck]) is wreck
    assert craft.blocking(10.0, [wreck]) is None  # at speed the pass aside still works
    assert craft.blocking(0.0, [_car(6.4, 4.0, 0.2)]) is None  # beside our lane
    assert craft.blocking(0.0, [_car(6.4, 0.5, 5.0)]) is None  # moving off
    assert craft.blocking(0.0, [_car(12.0, 0.5, 0.2)]) is None  # room to steer round it
    # after backing away the nearest stopped car in our way counts, alongside too
    assert craft.stopped_ahead([_car(12.0, 0.5, 0.2), _car(-1.0, 1.0, 0.0)]).dist_m == -1.0


def test_a_wreck_is_driven_round_on_the_side_with_our_width():
    craft = _craft(wreck_gap_m=0.5)
    # mixed-2 at 257 m: 7.6 m wide, the wreck 1 m left of the middle: only the right has room
    target = craft.wreck_target(_car(6.4, 1.0, 0.2), 3.8, -3.8)
    assert target == pytest.approx(1.0 - (2.0 + 0.5))
    assert craft.wreck_target(_car(6.4, 0.0, 0.2), 2.9, -2.9) is None  # neither side has room
