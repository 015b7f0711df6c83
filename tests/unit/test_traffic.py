"""Traffic physics on plain numbers (control/traffic.py) and racecraft's decisions (robot/racecraft.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from boxbox.control.offset_room import offset_room_ahead
from boxbox.control.traffic import brake_for, closing_time_s, min_gap_m, pass_pays, pass_side, predicted_speed_mps, room
from boxbox.robot.opponent_lines import OpponentLines
from boxbox.robot.opponents import Nearby
from boxbox.robot.racecraft import Racecraft, RacecraftParams, conflict_time_s, on_our_path

G = 9.81


def test_closing_time():
    assert closing_time_s(20.0, 30.0, 20.0) == pytest.approx(2.0)
    assert closing_time_s(20.0, 20.0, 25.0) == math.inf


def test_predicted_speed_slows_to_its_target_and_never_speeds_up():
    assert predicted_speed_mps(30.0, 20.0, 10.0, 0.5) == pytest.approx(25.0)
    assert predicted_speed_mps(30.0, 20.0, 10.0, 3.0) == 20.0
    assert predicted_speed_mps(15.0, 20.0, 10.0, 3.0) == 15.0


def test_min_gap_of_a_constant_speed_car_is_the_textbook_one():
    # it keeps 20 m/s; we brake from 30 at 5 m/s^2 at once: the gap closes by (30-20)^2 / (2*5) = 10 m
    gap = min_gap_m(30.0, 30.0, 20.0, 20.0, 5.0, 5.0, reaction_s=0.0, horizon_s=5.0)
    assert gap == pytest.approx(20.0, abs=0.3)


def test_min_gap_counts_the_car_ahead_braking():
    steady = min_gap_m(30.0, 30.0, 30.0, 30.0, 8.0, 8.0, 0.1, 2.0)
    braking = min_gap_m(30.0, 30.0, 30.0, 15.0, 8.0, 8.0, 0.1, 2.0)
    assert steady == pytest.approx(30.0)
    assert braking < steady - 1.0  # we react 0.1 s late and brake more softly (8 vs 8 but later)


def test_brake_rises_as_the_predicted_gap_falls():
    assert brake_for(10.0, 2.0, 4.0) == 0.0
    assert brake_for(4.0, 2.0, 4.0) == pytest.approx(0.5)
    assert brake_for(1.0, 2.0, 4.0) == 1.0


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


def test_a_pass_pays_when_it_completes_before_the_braking_zone_or_on_the_inside():
    # 10 m behind, 5 m/s faster, 4.5 m cars: (10 + 9) / 5 = 3.8 s at 40 m/s = 152 m of straight
    assert pass_pays(10.0, 40.0, 35.0, 4.5, 200.0, inside=False)
    assert not pass_pays(10.0, 40.0, 35.0, 4.5, 100.0, inside=False)
    assert pass_pays(10.0, 40.0, 35.0, 4.5, 100.0, inside=True)
    assert not pass_pays(10.0, 30.0, 35.0, 4.5, 1000.0, inside=False)


def _car(dist_m, mid_m, speed_mps, my_mid_m=0.0, laps_ahead=0):
    gap = dist_m - 4.5 if dist_m > 0 else dist_m + 4.5
    return Nearby(dist_m, gap, mid_m - my_mid_m, speed_mps, laps_ahead, 2.0, mid_m)


def _craft(**kw):
    return Racecraft(RacecraftParams(**kw), width_m=2.0, length_m=4.5, mu=1.2)


def test_racecraft_gives_room_to_a_car_alongside_and_marks_the_step_spoiled():
    craft = _craft()
    assert not craft.spoiled(0.0)
    # racing line at our position (0), a car alongside on our left at +2 m: the line moves right
    off = craft.offset(1.0, 30.0, 0.0, [_car(1.0, 2.0, 30.0)], 0.0, 0.0, (6.0, -6.0), 0.0, 400.0, 0.1, 0.0)
    assert off <= 2.0 - (2.0 + 1.0) + 1e-9
    assert craft.spoiled(1.5) and not craft.spoiled(2.5)


def test_a_car_predicted_across_us_gets_room_on_the_side_it_is_on():
    """A car on our right closing in sideways so fast that 0.5 s ahead it would be on our left is
    taken at our centre, still on our right: the room pushes us left, away from it, not into it."""
    craft = _craft()
    craft.predict(0.0, [_car(1.0, -3.0, 30.0)])
    cars = craft.predict(0.02, [_car(1.0, -2.8, 30.0)])  # 10 m/s towards us: 2.2 m left of us in 0.5 s
    assert cars[0].lateral_m < 0.0 and cars[0].mid_m < 0.0
    off = craft.offset(0.02, 30.0, 0.0, cars, 0.0, 0.0, (6.0, -6.0), 0.0, 400.0, 0.1, 0.0)
    assert off == pytest.approx(0.5 * (2.0 + 2.0) + 1.5 - 1e-3)


def test_racecraft_leaves_the_line_alone_when_nobody_is_near():
    craft = _craft()
    far = _car(150.0, 0.0, 30.0)  # far ahead, no faster than us
    assert craft.offset(1.0, 30.0, 0.0, [far], 0.0, 0.0, (6.0, -6.0), 0.0, 400.0, 0.1, 0.0) == 0.0
    assert not craft.spoiled(1.0)


def test_planned_pass_goes_round_a_slower_car_and_gives_up_in_time():
    craft = _craft(plan_passes=True, abort_s=2.0)
    slow = _car(15.0, 0.0, 20.0)
    # right turn coming (inside -1), room on both sides: the inside
    off = craft.offset(0.0, 30.0, 0.0, [slow], 0.0, 0.0, (6.0, -6.0), -1.0, 400.0, 0.1)
    assert off == pytest.approx(-0.1) and craft.pass_side == -1.0
    craft.offset(2.5, 30.0, 0.0, [slow], -1.0, 0.0, (6.0, -6.0), -1.0, 400.0, 0.1)
    assert craft.pass_side == 0.0  # not done in abort_s: given up (back towards the line)


def test_racecraft_brakes_for_a_car_stopped_in_our_lane_not_for_one_beside_it():
    craft = _craft()
    stopped = _car(30.0, 0.0, 0.0)
    aside = _car(30.0, 4.0, 0.0)
    assert craft.brake(0.0, 0.0, 30.0, [stopped], lambda c: 0.0) == 1.0
    assert craft.brake(0.0, 0.0, 30.0, [aside], lambda c: 0.0) == 0.0


def test_racecraft_touches_the_brake_behind_a_close_car_unless_it_pulls_away():
    craft = _craft()
    # 1 m gap (margin 2 m) in our lane, gap filter only: half the close brake for a car as fast as us
    same = _car(5.5, 0.0, 20.0)
    assert craft.brake(0.0, 0.0, 20.0, [same], lambda c: 20.0, predict=False) == pytest.approx(0.25)
    # faster than us (close_opening_mps 0): it pulls away, no brake; with 1 m/s allowed, 0.9 faster: still
    assert craft.brake(0.0, 0.0, 20.0, [_car(5.5, 0.0, 20.9)], lambda c: 20.9, predict=False) == 0.0
    assert craft.brake(0.0, 0.0, 18.0, [_car(5.5, 0.0, 22.0)], lambda c: 22.0, predict=False) == 0.0
    one = _craft(close_opening_mps=1.0)
    assert one.brake(0.0, 0.0, 20.0, [_car(5.5, 0.0, 20.9)], lambda c: 20.9, predict=False) > 0.0
    # the old rule (faster or not) with an unlimited opening speed
    always = _craft(close_opening_mps=math.inf)
    assert always.brake(0.0, 0.0, 18.0, [_car(5.5, 0.0, 22.0)], lambda c: 22.0, predict=False) > 0.0


def test_inward_step_is_held_by_the_grip_left_and_outward_never():
    from boxbox.robot.racecraft import inward_step
    # left turn (k > 0) at the grip limit: v^2 k = 20^2 * 0.03 = 12 = the grip: no move inwards (left)
    assert inward_step(0.0, 0.1, 0.03, 20.0, 12.0, 0.1, 0.3) == 0.0
    assert inward_step(0.0, -0.1, 0.03, 20.0, 12.0, 0.1, 0.3) == -0.1  # outwards eases the path
    # half the grip spare (more than the 0.3 share): the full step; 15 % spare: half of it
    assert inward_step(0.0, 0.1, 0.015, 20.0, 12.0, 0.1, 0.3) == pytest.approx(0.1)
    assert inward_step(0.0, 0.1, 0.0255, 20.0, 12.0, 0.1, 0.3) == pytest.approx(0.05)
    assert inward_step(0.0, 0.1, 0.03, 20.0, 12.0, 0.1, 0.0) == 0.1  # share 0: no limit


def test_inside_speed_follows_the_tighter_radius():
    from boxbox.robot.racecraft import inside_speed_mps
    # R = 20 m left turn, 2 m to the left (inside): R 18 m, speed x sqrt(18/20)
    assert inside_speed_mps(20.0, 0.05, 2.0) == pytest.approx(20.0 * math.sqrt(0.9))
    assert inside_speed_mps(20.0, 0.05, -2.0) == 20.0  # outside: unchanged
    assert inside_speed_mps(20.0, -0.05, -2.0) == pytest.approx(20.0 * math.sqrt(0.9))


def test_racecraft_brakes_for_a_car_ahead_that_brakes_hard():
    craft = _craft(braking_ahead_mps2=5.0)
    t = 0.0
    # a car 8 m ahead (bumper gap 3.5 m) in our lane at our speed: no brake while it keeps its speed
    for _ in range(10):
        t += 0.02
        craft.predict(t, [_car(8.0, 0.0, 40.0)])
    assert craft.brake(t, 0.0, 40.0, [_car(8.0, 0.0, 40.0)], lambda c: c.speed_mps, predict=False) == 0.0
    # it brakes at 10 m/s^2: measured from its speed, it is braked for before it is slower than the gap allows
    speed = 40.0
    for _ in range(10):
        t += 0.02
        speed -= 0.2
        cars = craft.predict(t, [_car(8.0, 0.0, speed)])
    assert craft.brake(t, 0.0, 40.0, cars, lambda c: c.speed_mps, predict=False) == 1.0
    assert craft.brake(t, 0.0, 40.0, cars, lambda c: c.speed_mps, predict=False) > \
        _craft(braking_ahead_mps2=0.0).brake(t, 0.0, 40.0, cars, lambda c: c.speed_mps, predict=False)


def test_racecraft_lifts_before_the_fixed_gap_brake_only_behind_a_slower_car():
    craft = _craft(lift_m=5.0)

    def brakedist(v1, v2):
        return (v1 * v1 - v2 * v2) / (2.0 * 10.0)

    # 30 -> 25 m/s needs 13.75 m; the fixed-gap brake acts inside 13.75 + 3 m, the lift 5 m before (18.75)
    assert craft.lift(1.0, 30.0, [_car(4.5 + 18.0, 0.0, 25.0)], brakedist) == 0.0
    assert craft.lift(1.0, 30.0, [_car(4.5 + 20.0, 0.0, 25.0)], brakedist) == 1.0
    assert craft.lift(1.0, 30.0, [_car(4.5 + 18.0, 0.0, 31.0)], brakedist) == 1.0  # faster: no lift
    assert _craft().lift(1.0, 30.0, [_car(4.5 + 18.0, 0.0, 25.0)], brakedist) == 1.0  # off by default
    assert craft.lift(1.0, 30.0, [_car(4.5 + 18.0, 5.0, 25.0)], brakedist) == 1.0  # beside our lane
    assert _craft(lift_m=0.0).lift(1.0, 30.0, [_car(4.5 + 18.0, 0.0, 25.0)], brakedist) == 1.0  # off


def test_racecraft_falls_in_behind_a_car_turning_in_from_the_outside():
    craft = _craft(yield_inside=True)
    # right turn ahead (inside -1): we are on its inside, the car alongside 2 m ahead, 3 m to our left
    craft.offset(0.0, 30.0, 0.0, [], 0.0, 0.0, (6.0, -6.0), -1.0, 400.0, 0.1)
    beside = _car(2.0, 3.0, 30.0)
    assert craft.brake(0.0, 0.0, 30.0, [beside], lambda c: c.speed_mps, predict=False) == 1.0
    craft.offset(0.0, 30.0, 0.0, [], 0.0, 0.0, (6.0, -6.0), 1.0, 400.0, 0.1)  # left turn: we are outside
    assert craft.brake(0.0, 0.0, 30.0, [beside], lambda c: c.speed_mps, predict=False) == 0.0


def test_a_pass_under_way_on_the_inside_is_not_called_back_to_the_line():
    craft = _craft()  # keep_inside, commit_lengths 2.5 (11.25 m here)
    near, far = _car(8.0, 0.5, 25.0), _car(20.0, 0.5, 25.0)
    # right turn ahead (inside -1) sharp enough at 30 m/s for the hold-line rule; the tutorial moved us right
    def step(car, inside):
        return craft.offset(0.0, 30.0, 0.0, [car], -0.5, 0.0, (6.0, -6.0), inside, 400.0, 0.1, -0.6, 0.01)
    assert step(near, -1.0) == pytest.approx(-0.6) and craft.pass_side == -1.0  # under way on the inside: kept
    assert step(far, -1.0) == pytest.approx(-0.4) and craft.pass_side == 0.0  # not under way: back to the line
    assert step(near, 1.0) == pytest.approx(-0.6)  # aside towards the outside (left turn): kept too
    craft = _craft(keep_outside=False)
    assert step(near, 1.0) == pytest.approx(-0.4)  # ... unless keep_outside is off: back to the line
    assert _craft(keep_inside=False).offset(0.0, 30.0, 0.0, [near], -0.5, 0.0, (6.0, -6.0), -1.0, 400.0, 0.1,
                                            -0.6, 0.01) == pytest.approx(-0.4)


def test_an_offset_towards_the_outside_of_a_turn_is_kept_and_one_inwards_is_not():
    """keep_outside: moving out widens the radius (the line's speed holds), moving in tightens it."""
    craft = _craft(keep_inside=False)
    car = _car(30.0, 0.5, 25.0)  # far ahead: no pass under way

    def step(offset, inside):  # a turn ahead needing most of the grip at 30 m/s
        return craft.offset(0.0, 30.0, 0.0, [car], offset, 0.0, (6.0, -6.0), inside, 400.0, 0.1, offset, 0.01)
    assert step(1.0, -1.0) == pytest.approx(1.0)  # left of the line, right turn: outside, kept
    assert step(1.0, 1.0) == pytest.approx(0.9)  # left of the line, left turn: inside, back to the line
    assert step(-1.0, 1.0) == pytest.approx(-1.0)  # right of the line, left turn: outside, kept
    assert _craft(keep_inside=False, keep_outside=False).offset(
        0.0, 30.0, 0.0, [car], 1.0, 0.0, (6.0, -6.0), -1.0, 400.0, 0.1, 1.0, 0.01) == pytest.approx(0.9)


def test_a_car_ahead_counts_where_our_line_meets_it():
    """on_our_path: a slower car 6 m aside now, our line swinging 5 m across to it, is in our lane
    where we reach it; a car alongside and a faster car are where they are."""
    ahead = _car(24.5, -6.0, 10.0)  # gap 20 m, closing at 10 m/s: met after 2 s, 40 m on
    swing = lambda ahead_m: -5.0 * min(1.0, ahead_m / 40.0)  # noqa: E731  our line moves right as we go

    [met] = on_our_path([ahead], 20.0, 3.0, swing)
    assert met.lateral_m == pytest.approx(-1.0) and met.mid_m == pytest.approx(-6.0)
    [later] = on_our_path([ahead], 20.0, 1.5, swing)  # met beyond the horizon: where it is now
    assert later.lateral_m == pytest.approx(-6.0)
    beside, faster = _car(3.0, -2.0, 10.0), _car(24.5, -6.0, 25.0)
    assert [c.lateral_m for c in on_our_path([beside, faster], 20.0, 3.0, swing)] == [-2.0, -6.0]
    # its line known from laps before: 40 m further on it drives 3 m left of where it is now
    [seen] = on_our_path([ahead], 20.0, 3.0, swing, lambda c, ahead_m: (c.mid_m + 3.0 * ahead_m / 20.0, True))
    assert seen.mid_m == pytest.approx(-3.0) and seen.lateral_m == pytest.approx(2.0)
    # unknown there, and our line moving away from it: still counts where it is now (the closer)
    [away] = on_our_path([ahead], 20.0, 3.0, lambda ahead_m: -swing(ahead_m))
    assert away.lateral_m == pytest.approx(-6.0)
    # lapped_only: a car on our lap is where it is, a car we are lapping where we meet it
    lapped = replace(ahead, laps_ahead=-1)
    assert [c.lateral_m for c in on_our_path([ahead, lapped], 20.0, 3.0, swing, lapped_only=True)] \
        == [pytest.approx(-6.0), pytest.approx(-1.0)]


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


def test_a_car_turning_in_across_us_is_a_conflict_before_it_moves():
    """conflict_time_s: a car half a length ahead, 3 m to our left, whose line comes to ours 10 m on."""
    car = _car(2.0, 3.0, 20.0)
    ours = lambda ahead_m: 0.0  # noqa: E731
    turning = lambda c, ahead_m: (c.mid_m - 3.0 * min(1.0, ahead_m / 10.0), True)  # noqa: E731
    keeping = lambda c, ahead_m: (c.mid_m, False)  # noqa: E731
    assert conflict_time_s(car, 20.0, 4.5, 2.2, 1.0, ours, turning) == pytest.approx(0.2)  # 4 m on: 1.8 m apart
    assert conflict_time_s(car, 20.0, 4.5, 2.2, 1.0, ours, keeping) == math.inf  # it keeps its 3 m
    # we are 10 m/s faster: past it (0.65 s) before its line, turning in over 80 m, reaches ours
    assert conflict_time_s(car, 30.0, 4.5, 2.2, 1.0, ours, lambda c, a: (c.mid_m - 3.0 * min(1.0, a / 80.0), True)) \
        == math.inf


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
