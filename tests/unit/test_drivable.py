"""The width the tutorial robot's line may use (robot/drivable.py) on a hand-built track with sides."""

from __future__ import annotations

import math

import numpy as np
import pytest

from boxbox.model.track import LEFT
from boxbox.robot.drivable import centre_room
from boxbox.robot.racingline import middle_line
from boxbox.torcs import wire
from trackdata import build_track

CAR_WIDTH_M = 1.94


def track_with_sides(border_friction: float = 1.4, outer_friction: float = 0.4, outer_roughness: float = 0.0):
    """Straights and 90 degree left turns, 12 m wide, 3 m of border and 3 m of side on each side."""
    track = build_track([("S", 200.0), ("L", 30.0, 90.0)] * 4)
    n = len(track.seg["type"])
    values = {"border_width_m": 3.0, "border_style": 0.0, "border_height_m": 0.0, "border_friction": border_friction,
              "border_roughness": 0.0, "outer_start_width_m": 3.0, "outer_end_width_m": 3.0,
              "outer_friction": outer_friction, "outer_roll_resistance": 0.001, "outer_roughness": outer_roughness,
              "barrier_style": 2.0, "barrier_width_m": 0.5}
    for side in ("left", "right"):
        for name in wire.SIDE_PART_FIELDS:
            track.seg[f"{side}_{name}"] = np.full(n, values[name])
    track.seg["roughness"] = np.zeros(n)
    track.seg["roll_resistance"] = np.full(n, 0.001)
    return track


def rooms(track, limits: str):
    mid = middle_line(track, 2.0)
    n = mid.n
    left, right = centre_room(track, mid.seg_id[:n], mid.seg_frac[:n], mid.half_left_m[:n], CAR_WIDTH_M, limits)
    turn = track.seg["type"][mid.seg_id[:n]] == LEFT
    return left, right, turn


def test_strict_is_the_track_less_half_the_car():
    left, right, _ = rooms(track_with_sides(), "strict")
    assert np.allclose(left, 6.0 - CAR_WIDTH_M / 2) and np.allclose(right, 6.0 - CAR_WIDTH_M / 2)


def test_torcs_adds_the_grippy_border_and_stops_at_the_cut_limit_inside_turns():
    left, right, turn = rooms(track_with_sides(), "torcs")
    # the grass beyond the border grips less than the track: only the 3 m border counts
    assert np.allclose(right, 6.0 + 3.0 - CAR_WIDTH_M / 2)  # the outside of every left turn, and straights
    assert np.allclose(left[~turn], 6.0 + 3.0 - CAR_WIDTH_M / 2)
    # the inside of a left turn: 0.7 car widths beyond the edge is where TORCS's penalty starts
    assert np.allclose(left[turn], 6.0 + 0.7 * CAR_WIDTH_M)


@pytest.mark.parametrize("border_friction, outer_friction, outer_roughness, extra_m", [
    (1.0, 1.2, 0.0, 0.0),  # a border that grips less than the track (1.2) cuts off everything beyond it
    (1.4, 1.2, 0.0, 6.0),  # border and side grip like the track: both count
    (1.4, 1.2, 0.02, 3.0),  # the side is rougher than the track: the border only
])
def test_only_sides_that_grip_like_the_track_count(border_friction, outer_friction, outer_roughness, extra_m):
    _, right, _ = rooms(track_with_sides(border_friction, outer_friction, outer_roughness), "torcs")
    assert math.isclose(float(right.min()), 6.0 + extra_m - CAR_WIDTH_M / 2, abs_tol=1e-9)
