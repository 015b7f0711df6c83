"""What the car "sees": range finders to the track edges and the nearest opponent per sector.

The sensors of the SCR championship's software, computed in Python from the track the bridge sends
(no patched TORCS).  Angles are in degrees from the car's heading, positive clockwise (to the
right), as in SCR: the default track sensors span -90 (left) to +90 (right).

Track edges: both edges as straight lines from each segment's start corner to its end corner
(TORCS splits turns into segments a few metres long, so the chords stay close to the arcs), every
ray cast against the lines within the sensor range of the car's segment (`TrackEdges.ranges`: a C
loop, gym/raycast.c, or the same in numpy without a C compiler).  Off the track (the car's centre
beyond an edge) every sensor reads -1, as in SCR.
"""

from __future__ import annotations

import math

import numpy as np

from boxbox.gym import raycast
from boxbox.model import State, Track

RANGE_M = 200.0  # range of every sensor (SCR's)
SCR_TRACK_ANGLES_DEG = (-90.0, -75.0, -60.0, -45.0, -30.0, -20.0, -15.0, -10.0, -5.0, 0.0,
                        5.0, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 75.0, 90.0)
OPPONENT_SECTORS = 36  # 10 degrees each, clockwise from -180 (behind, passing left) to +180
OFF_TRACK = -1.0  # every track sensor's reading with the car off the track


def track_edge_lines(track: Track) -> np.ndarray:
    """(n_segments, 2 sides, 4): start x, start y, dx, dy of each segment's left and right edge."""
    seg = track.seg
    out = np.empty((track.n_segments, 2, 4))
    for side, (sx, sy, ex, ey) in enumerate((("start_left_x", "start_left_y", "end_left_x", "end_left_y"),
                                             ("start_right_x", "start_right_y", "end_right_x", "end_right_y"))):
        ax, ay = seg[sx], seg[sy]
        out[:, side] = np.stack([ax, ay, seg[ex] - ax, seg[ey] - ay], axis=1)
    return out


def segments_within(track: Track, dist_m: float) -> int:
    """The most segments any stretch of dist_m metres of the track spans (+1 for the car's own)."""
    lengths = np.maximum(track.seg["length_m"], 1e-3)
    n = len(lengths)
    twice = np.concatenate([lengths, lengths])
    ends = np.cumsum(twice)
    starts = ends - twice
    # from the start of each segment, the first segment that ends dist_m or more later
    reach = np.searchsorted(ends, starts[:n] + dist_m, side="left")
    return int(min(n, (reach - np.arange(n)).max() + 1))


def cast_numpy(lines: np.ndarray, x_m: float, y_m: float, yaw_rad: float, rays: np.ndarray,
               range_m: float) -> np.ndarray:
    """What raycast.c computes, in numpy (used without a C compiler, and to check the C)."""
    theta = yaw_rad + rays
    dx, dy = np.cos(theta)[:, None], np.sin(theta)[:, None]
    wx, wy = lines[:, 0] - x_m, lines[:, 1] - y_m
    ex, ey = lines[:, 2], lines[:, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        den = dx * ey - dy * ex
        t = (wx * ey - wy * ex) / den
        u = (wx * dy - wy * dx) / den
    hit = (u >= 0.0) & (u <= 1.0) & (t >= 0.0)
    return np.minimum(np.where(hit, t, np.inf).min(axis=1), range_m)


def ahead(rays_rad: np.ndarray) -> int:
    """1 when every ray points within 90 degrees of the heading (lets the C loop skip chords behind)."""
    return int(bool(np.all(np.abs(rays_rad) <= 0.5 * math.pi)))


class TrackEdges:
    """Range finders to the track edges at fixed angles (degrees, + clockwise), up to range_m."""

    def __init__(self, track: Track, angles_deg: tuple[float, ...] = SCR_TRACK_ANGLES_DEG,
                 range_m: float = RANGE_M, use_c: bool = True) -> None:
        self.angles_rad = np.ascontiguousarray(-np.radians(np.asarray(angles_deg, dtype=float)))  # as yaw turns
        self.range_m = float(range_m)
        lines = track_edge_lines(track)
        n = len(lines)
        # the lines of `reach` segments on both sides of the car's segment, as one contiguous slice
        # of the lines repeated around the loop (rays may point backwards: a car turned round)
        self.reach = min(segments_within(track, self.range_m), n)
        wrapped = np.concatenate([lines[n - self.reach:], lines, lines[:self.reach + 1]])
        self.lines = np.ascontiguousarray(wrapped.reshape(-1, 4))
        self.n_segments = n
        self.window = 2 * (2 * self.reach + 1)  # lines in a window
        self.lib = raycast.load() if use_c else None
        self._lines_at = self.lines.ctypes.data
        self._rays_at = self.angles_rad.ctypes.data
        self._ahead = ahead(self.angles_rad)
        self._out = np.empty(len(self.angles_rad))
        self._out_at = self._out.ctypes.data

    def ranges(self, state: State) -> np.ndarray:
        """Distance (m) along each ray from the car's centre to the first edge; range_m when none is
        that close; OFF_TRACK for every ray when the car's centre is off the track."""
        if state.to_left_m < 0.0 or state.to_right_m < 0.0:
            return np.full(len(self.angles_rad), OFF_TRACK)
        return self.cast(state.x_m, state.y_m, state.yaw_rad, int(state.seg_id), self.angles_rad)

    def cast(self, x_m: float, y_m: float, yaw_rad: float, seg: int, rays: np.ndarray) -> np.ndarray:
        """The rays' distances (m) from (x, y) on segment `seg`; rays in radians from the heading,
        counter-clockwise."""
        first = seg % self.n_segments * 2  # the window's first line: `reach` segments before the car's
        k = len(rays)
        if self.lib is None:
            return cast_numpy(self.lines[first: first + self.window], x_m, y_m, yaw_rad, rays, self.range_m)
        if rays is self.angles_rad:  # the usual sensors: the arrays' addresses are known
            self.lib.bb_cast(self._lines_at + first * 32, self.window, x_m, y_m, yaw_rad, self._rays_at, k,
                             self.range_m, self._ahead, self._out_at)
            return self._out.copy()
        rays = np.ascontiguousarray(rays, dtype=float)
        out = np.empty(k)
        self.lib.bb_cast(self._lines_at + first * 32, self.window, x_m, y_m, yaw_rad, rays.ctypes.data, k,
                         self.range_m, ahead(rays), out.ctypes.data)
        return out


_NONE_NEAR = np.full(OPPONENT_SECTORS, RANGE_M)  # (a copy costs a third of np.full's time, every step)


def opponent_sectors(state: State, range_m: float = RANGE_M, sectors: int = OPPONENT_SECTORS) -> np.ndarray:
    """Distance (m) to the nearest opponent's centre in each of `sectors` equal sectors around the
    car, clockwise from straight behind (SCR's order); range_m where there is none that close."""
    out = np.full(sectors, range_m) if (range_m, sectors) != (RANGE_M, OPPONENT_SECTORS) else _NONE_NEAR.copy()
    if not state.opponents:
        return out
    x, y, yaw = state.x_m, state.y_m, state.yaw_rad
    width = 2.0 * math.pi / sectors
    for o in state.opponents:
        dx, dy = o.x_m - x, o.y_m - y
        dist = math.hypot(dx, dy)
        if dist >= range_m:
            continue
        clockwise = yaw - math.atan2(dy, dx)  # bearing from the heading, + to the right
        i = int(((clockwise + math.pi) % (2.0 * math.pi)) / width) % sectors
        if dist < out[i]:
            out[i] = dist
    return out
