"""The track as the bridge sends it once per race: every segment as numpy arrays, and the pit lane."""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import NoReturn

import numpy as np

from boxbox.model.names import no_such_field

# segment types (TORCS TR_RGT, TR_LFT, TR_STR)
RIGHT, LEFT, STRAIGHT = 1, 2, 3
# race_info bits (TORCS TR_*)
SEG_PITLANE, SEG_SPEEDLIMIT, SEG_PITENTRY, SEG_PITEXIT, SEG_PIT = 0x4, 0x8, 0x10, 0x20, 0x40


@dataclass(frozen=True)
class PitLane:
    side: int  # RIGHT or LEFT
    entry_seg: int
    start_seg: int  # speed limit starts here
    end_seg: int  # speed limit ends here
    exit_seg: int
    width_m: float
    box_length_m: float
    speed_limit_mps: float
    count: int  # number of pit boxes


@dataclass(eq=False)
class Track:
    name: str
    category: str
    length_m: float
    width_m: float
    # per-segment arrays, one entry per segment in track order (index == segment id)
    seg: dict[str, np.ndarray]
    pit: PitLane | None
    _starts: list[float] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        self._starts = self.seg["start_dist_m"].tolist()

    @property
    def n_segments(self) -> int:
        return len(self._starts)

    def segment_at(self, dist_m: float) -> int:
        """Index of the segment containing a distance from the start line."""
        return max(0, bisect.bisect_right(self._starts, dist_m % self.length_m) - 1)

    def dist_of(self, seg_id: int, to_start: float) -> float:
        """Distance from the start line of a local position (to_start in rad on turns)."""
        i = int(seg_id)
        if self.seg["type"][i] != STRAIGHT:
            to_start *= self.seg["radius_m"][i]
        return self._starts[i] + to_start

    def curvature(self) -> np.ndarray:
        """Signed curvature per segment (1/m), + for left turns."""
        t, r = self.seg["type"], self.seg["radius_m"]
        with np.errstate(divide="ignore"):
            k = np.where(t == STRAIGHT, 0.0, 1.0 / np.where(r > 0, r, math.inf))
        return np.where(t == RIGHT, -k, k)

    def __getattr__(self, name: str) -> NoReturn:
        no_such_field(self, name)
