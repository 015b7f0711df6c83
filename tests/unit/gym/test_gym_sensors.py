"""The range finders and opponent sectors on recorded tracks, against plain geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

import trackdata
from boxbox.gym.sensors import OFF_TRACK, RANGE_M, TrackEdges, opponent_sectors, segments_within
from boxbox.model import Opponent, State
from boxbox.model.track import STRAIGHT

STATE_ZERO = State(*([0.0] * 42))


def state(**fields) -> State:
    return STATE_ZERO._replace(**fields)


def opponent(x_m: float, y_m: float) -> Opponent:
    return Opponent(*([0.0] * 19))._replace(x_m=x_m, y_m=y_m)


def point_on(track, i: int, along: float, lateral: float) -> tuple[float, float]:
    """A point of segment i: `along` from start (0) to end (1), `lateral` from right (0) to left (1) edge."""
    s = track.seg
    sx = s["start_right_x"][i] + lateral * (s["start_left_x"][i] - s["start_right_x"][i])
    sy = s["start_right_y"][i] + lateral * (s["start_left_y"][i] - s["start_right_y"][i])
    ex = s["end_right_x"][i] + lateral * (s["end_left_x"][i] - s["end_right_x"][i])
    ey = s["end_right_y"][i] + lateral * (s["end_left_y"][i] - s["end_right_y"][i])
    return sx + along * (ex - sx), sy + along * (ey - sy)


def test_on_a_straight_the_side_rays_meet_the_edges_and_the_front_ray_runs_to_range():
    track, _ = trackdata.load("g-track-1")
    edges = TrackEdges(track)
    i = 5  # on the start straight, 15 m wide, heading along +x
    assert track.seg["type"][i] == STRAIGHT
    x, y = point_on(track, i, 0.5, 0.25)  # a quarter of the width from the right edge
    yaw = float(track.seg["start_angle_rad"][i])
    r = edges.cast(x, y, yaw, i, edges.angles_rad)
    assert r[0] == pytest.approx(11.25, abs=1e-6)  # -90 degrees: left, 3/4 of 15 m
    assert r[-1] == pytest.approx(3.75, abs=1e-6)  # +90 degrees: right
    assert r[9] == RANGE_M  # straight ahead: the straight is longer than 200 m
    # +30 degrees (to the right): the right edge 3.75 m away at 30 degrees off the axis
    assert r[14] == pytest.approx(3.75 / math.sin(math.radians(30)), abs=1e-6)


@pytest.mark.parametrize("name", trackdata.TRACKS)
def test_the_c_loop_equals_numpy_and_no_ray_escapes_the_track(name):
    track, _ = trackdata.load(name)
    c, py = TrackEdges(track), TrackEdges(track, use_c=False)
    assert c.lib is not None, "raycast.c did not build (is a C compiler installed?)"
    rng = np.random.default_rng(1)
    width = float(track.seg["width_m"].max())
    for _ in range(300):
        i = int(rng.integers(track.n_segments))
        x, y = point_on(track, i, rng.random(), rng.uniform(0.02, 0.98))
        yaw = rng.uniform(-math.pi, math.pi)
        a, b = c.cast(x, y, yaw, i, c.angles_rad), py.cast(x, y, yaw, i, py.angles_rad)
        assert np.array_equal(a, b)
        assert (a > 0).all() and (a <= RANGE_M).all()
        if track.seg["type"][i] == STRAIGHT:  # heading along it: the side rays span the width (x 1/cos 0.1)
            yaw = float(track.seg["start_angle_rad"][i]) + rng.uniform(-0.1, 0.1)
            a = c.cast(x, y, yaw, i, c.angles_rad)
            assert a[0] + a[-1] < 1.02 * width


def test_focus_rays_and_a_window_that_covers_200_m():
    track, _ = trackdata.load("e-track-2")
    edges = TrackEdges(track)
    lengths = track.seg["length_m"]
    ahead = sum(np.roll(lengths, -k) for k in range(edges.reach))  # from each segment's start
    assert ahead.min() >= RANGE_M  # the window reaches 200 m from any segment
    assert ahead.min() - lengths.max() < RANGE_M  # and no further than needed
    assert segments_within(track, 1e9) == track.n_segments
    x, y = point_on(track, 10, 0.5, 0.5)
    yaw = float(track.seg["start_angle_rad"][10])
    five = np.radians([-2.0, -1.0, 0.0, 1.0, 2.0])
    assert edges.cast(x, y, yaw, 10, five).shape == (5,)
    assert edges.cast(x, y, yaw, 10, five)[2] == edges.cast(x, y, yaw, 10, edges.angles_rad)[9]


def test_off_the_track_every_sensor_reads_minus_one():
    track, _ = trackdata.load("g-track-1")
    edges = TrackEdges(track)
    r = edges.ranges(state(to_left_m=-0.5, to_right_m=15.5, seg_id=3.0))
    assert r.shape == (19,) and (r == OFF_TRACK).all()


def test_opponent_sectors_clockwise_from_behind():
    me = state(x_m=100.0, y_m=50.0, yaw_rad=math.pi / 2)  # heading +y
    cars = (opponent(100.0, 60.0), opponent(95.0, 50.0), opponent(103.0, 50.0), opponent(100.0, 30.0),
            opponent(100.0, 300.0))
    r = opponent_sectors(me._replace(opponents=cars))
    assert r[18] == pytest.approx(10.0)  # ahead: the sector clockwise from 0 degrees
    assert r[9] == pytest.approx(5.0)  # to the left: -90 degrees
    assert r[27] == pytest.approx(3.0)  # to the right: +90 degrees
    assert r[0] == pytest.approx(20.0) or r[35] == pytest.approx(20.0)  # behind: +-180 degrees
    assert (np.sort(r)[:4] < RANGE_M).all() and np.sum(r < RANGE_M) == 4  # the one 250 m away is out of range
