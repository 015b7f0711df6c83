"""Where each other car drives: its lateral position (to_middle, m) by distance along the track,
remembered from the laps it has been in sight.

TORCS's robots drive the same line lap after lap, and it is not ours: on aalborg they take the turn
at 1600 m on a line 7 m from ours at half our speed.  A car ahead is judged by where it will be
when we reach it (robot/racecraft.py `on_our_path`): from this memory where it has been seen there
before, else where it is now.  One array per car and per step of the track; a step records the
latest pass (a car pushed off its line by contact records that, until it drives there again).
"""

from __future__ import annotations

import math

import numpy as np

from boxbox.robot.opponents import Nearby


class OpponentLines:
    """The lateral positions other cars were seen at, per car index and per step_m of track."""

    def __init__(self, track_length_m: float, step_m: float) -> None:
        if not (track_length_m > 0.0 and step_m > 0.0 and math.isfinite(track_length_m + step_m)):
            raise ValueError(f"track length and step must be positive, got {track_length_m} m and {step_m} m")
        self.length_m = track_length_m
        self.step_m = step_m
        self.n = max(1, int(track_length_m / step_m))
        self._mid: dict[int, np.ndarray] = {}  # car index -> to_middle per step (NaN: not seen there)

    def observe(self, my_dist_m: float, cars: list[Nearby]) -> None:
        """Record each car's to_middle where it is now (my_dist_m: our distance from the start)."""
        for c in cars:
            mids = self._mid.get(c.index)
            if mids is None:
                mids = self._mid[c.index] = np.full(self.n, np.nan)
            mids[int(((my_dist_m + c.dist_m) % self.length_m) / self.step_m) % self.n] = c.mid_m

    def mid_at(self, index: int, dist_m: float, fallback_m: float) -> float:
        """Car index's to_middle at dist_m from the start as last seen there, else fallback_m."""
        mids = self._mid.get(index)
        if mids is None:
            return fallback_m
        seen = mids[int((dist_m % self.length_m) / self.step_m) % self.n]
        return fallback_m if seen != seen else float(seen)
