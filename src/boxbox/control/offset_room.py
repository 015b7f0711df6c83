"""Room for an overtaking offset: how far the line may be moved aside at each sample so that, over
the next stretch of road, the moved line stays inside the room the track leaves.

A constant offset from the racing line keeps its distance from the line, but the line runs to the
inside edge at each apex: an offset towards the inside taken into a turn meets the edge there
(aalborg's right-hander at 1350 m: 29,000 damage in nine field races, the car moved 2.5-3.5 m inside
the line, off the road 10 m before the apex).  Bounding the offset by the least room over the road
ahead brings the car back towards the line before the apex, not at it.
"""

from __future__ import annotations

import numpy as np


def offset_room_ahead(line_mid_m: np.ndarray, half_left_m: np.ndarray, half_right_m: np.ndarray,
                      ahead_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) room (m, >= 0) for a lateral offset of the line at each sample of a closed track:
    the least room between the line and the left (right) limit over this sample and the next
    ahead_samples (wrapping round the lap).

    line_mid_m: the line's to_middle per sample (m, + left); half_left_m / half_right_m: how far
    left / right of the middle the car's centre may go (m, >= 0)."""
    line = np.asarray(line_mid_m, dtype=float)
    left = np.asarray(half_left_m, dtype=float)
    right = np.asarray(half_right_m, dtype=float)
    if not (line.shape == left.shape == right.shape and line.ndim == 1 and line.size > 0):
        raise ValueError("line, left and right room must be 1-D arrays of one length")
    if ahead_samples < 0 or not np.all(np.isfinite(line) & np.isfinite(left) & np.isfinite(right)):
        raise ValueError("ahead_samples must be >= 0 and the arrays finite")
    n = line.size
    window = min(ahead_samples, n - 1) + 1
    idx = (np.arange(n)[:, None] + np.arange(window)[None, :]) % n
    room_l = np.maximum(left - line, 0.0)[idx].min(axis=1)
    room_r = np.maximum(right + line, 0.0)[idx].min(axis=1)
    return room_l, room_r
