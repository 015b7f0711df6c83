"""The minimum-curvature line (control/minline.py) on a stadium-shaped track."""

import math

import numpy as np
import pytest

from boxbox.control.minline import closed_curvature, min_curvature_offsets


def stadium(straight_m=200.0, radius_m=50.0, step_m=2.0):
    """Middle points and left normals of a counter-clockwise stadium: two straights, two half circles."""
    pts, heads = [], []
    length = 2 * straight_m + 2 * math.pi * radius_m
    n = round(length / step_m)
    for s in np.linspace(0.0, length, n, endpoint=False):
        if s < straight_m:
            point, heading = (s, 0.0), 0.0
        elif s < straight_m + math.pi * radius_m:
            a = (s - straight_m) / radius_m
            point, heading = (straight_m + radius_m * math.sin(a), radius_m - radius_m * math.cos(a)), a
        elif s < 2 * straight_m + math.pi * radius_m:
            point, heading = (straight_m - (s - straight_m - math.pi * radius_m), 2 * radius_m), math.pi
        else:
            a = (s - 2 * straight_m - math.pi * radius_m) / radius_m
            point, heading = (-radius_m * math.sin(a), radius_m + radius_m * math.cos(a)), math.pi + a
        pts.append(point)
        heads.append(heading)
    xy, h = np.array(pts), np.array(heads)
    return xy[:, 0], xy[:, 1], -np.sin(h), np.cos(h)


def test_the_line_stays_inside_and_has_less_curvature():
    x, y, nx, ny = stadium()
    room = np.full(len(x), 5.0)
    off = min_curvature_offsets(x, y, nx, ny, room, room)
    assert np.all(off <= 5.0 + 1e-9) and np.all(off >= -5.0 - 1e-9)
    k_mid, _ = closed_curvature(x, y)
    k_line, _ = closed_curvature(x + off * nx, y + off * ny)
    assert k_mid.max() == pytest.approx(1 / 50.0, rel=1e-3)
    # the turn starts earlier on the straights: less curvature over the lap (not at every point)
    assert np.sum(k_line ** 2) < 0.95 * np.sum(k_mid ** 2)
    apex = np.argmin(np.abs(x - 250.0) + np.abs(y - 50.0))  # middle of the first turn
    assert off[apex] > 4.5  # at the inside (left) edge there


def test_no_room_means_the_middle():
    x, y, nx, ny = stadium()
    off = min_curvature_offsets(x, y, nx, ny, np.zeros(len(x)), np.zeros(len(x)))
    assert np.allclose(off, 0.0)


def test_bad_input():
    x, y, nx, ny = stadium()
    with pytest.raises(ValueError):
        min_curvature_offsets(x, y, nx, ny, -np.ones(len(x)), np.ones(len(x)))
    with pytest.raises(ValueError):
        min_curvature_offsets(x[:3], y[:3], nx[:3], ny[:3], np.ones(3), np.ones(3))
    with pytest.raises(ValueError):
        closed_curvature(np.zeros(6), np.zeros(6))
