"""How far left and right of the track's middle a car may drive, sample by sample, and on what surface.

TORCS's rules (docs/track-limits.md; TORCS 1.3.7 raceengine.cpp, ReRaceRules): a race penalises only
the inside of a turn, once the car's centre of gravity is more than 0.7 car widths beyond the main
track's edge there, except on the pit side between the pit entry and exit. Everything else may be
driven up to the barrier, which stops the car where its body reaches it (simuv2 collide.cpp). A
border of style wall is a wall (simuv2 buildWalls): the drivable width ends at it.

All lengths in metres. An offset is + to the left of the middle, as TORCS's `toMiddle`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from boxbox.model.track import LEFT, RIGHT
from boxbox.options import TRACK_LIMITS

CUT_LIMIT_CAR_WIDTHS = 0.7  # ReRaceRules: a cut starts 0.7 car widths beyond the inside edge
BORDER_WALL = 2  # TORCS's TR_WALL as a border style


@dataclass(frozen=True)
class SideParts:
    """One side of the track at each of n samples: the border next to the track (width, whether it
    is a wall, friction) and the side beyond it (width, friction). Widths >= 0 m; 0 where absent."""

    border_width_m: np.ndarray
    border_wall: np.ndarray
    border_friction: np.ndarray
    outer_width_m: np.ndarray
    outer_friction: np.ndarray

    def reach_m(self) -> np.ndarray:
        """Width beside the track's edge a car can reach before the barrier or a wall (m)."""
        return np.where(self.border_wall, 0.0, self.border_width_m + self.outer_width_m)


def _check(n: int, arrays: dict[str, np.ndarray]) -> None:
    for name, a in arrays.items():
        if a.shape != (n,):
            raise ValueError(f"{name} must have one value per sample ({n}), not shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite")


def _side_arrays(side: SideParts, n: int, label: str) -> SideParts:
    out = SideParts(*(np.asarray(getattr(side, f), dtype=float) for f in SideParts.__dataclass_fields__))
    _check(n, {f"{label}.{f}": getattr(out, f) for f in SideParts.__dataclass_fields__})
    if np.any(out.border_width_m < 0) or np.any(out.outer_width_m < 0):
        raise ValueError(f"{label}: widths must be >= 0 m")
    return out


def drivable_width(track_limits: str, half_width_m: np.ndarray, turn: np.ndarray, left: SideParts,
                   right: SideParts, car_width_m: float, pit_exempt_left: np.ndarray | None = None,
                   pit_exempt_right: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Room (m, >= 0) for the car's centre of gravity left and right of the middle at each sample.

    half_width_m: half the main track's width; turn: +1 on a left turn, -1 on a right turn, 0 on a
    straight (the main segment's type); car_width_m: the car's width. "strict": the car's body stays
    between the track's edges. "torcs": the body stays inside the barrier and any border wall, and on
    the inside of a turn (not pit-exempt on that side) the centre of gravity stops 0.7 car widths
    beyond the edge, where TORCS's cutting penalty starts.
    """
    if track_limits not in TRACK_LIMITS:
        raise ValueError(f"track_limits {track_limits!r}: use one of {', '.join(TRACK_LIMITS)}")
    half = np.asarray(half_width_m, dtype=float)
    n = half.shape[0] if half.ndim == 1 else -1
    if n < 1:
        raise ValueError("half_width_m must be a 1-D array with one value per sample")
    t = np.asarray(turn, dtype=float)
    ex_l = np.zeros(n, bool) if pit_exempt_left is None else np.asarray(pit_exempt_left, dtype=bool)
    ex_r = np.zeros(n, bool) if pit_exempt_right is None else np.asarray(pit_exempt_right, dtype=bool)
    _check(n, {"half_width_m": half, "turn": t, "pit_exempt_left": ex_l.astype(float),
               "pit_exempt_right": ex_r.astype(float)})
    if np.any(half < 0):
        raise ValueError("half_width_m must be >= 0")
    if not np.isfinite(car_width_m) or car_width_m <= 0:
        raise ValueError(f"car_width_m {car_width_m} must be finite and > 0")
    lp, rp = _side_arrays(left, n, "left"), _side_arrays(right, n, "right")
    body = 0.5 * car_width_m
    if track_limits == "strict":
        room = np.maximum(half - body, 0.0)
        return room, room.copy()
    cut = half + CUT_LIMIT_CAR_WIDTHS * car_width_m
    left_m = half + lp.reach_m() - body
    right_m = half + rp.reach_m() - body
    left_m = np.where((t > 0) & ~ex_l, np.minimum(left_m, cut), left_m)
    right_m = np.where((t < 0) & ~ex_r, np.minimum(right_m, cut), right_m)
    return np.maximum(left_m, 0.0), np.maximum(right_m, 0.0)


def surface_friction(offset_m: np.ndarray, half_width_m: np.ndarray, main_friction: np.ndarray,
                     left: SideParts, right: SideParts) -> np.ndarray:
    """The friction of the surface under the centre of gravity at `offset_m` (+ left) per sample:
    the main track's within its half width, then the border's, then the side's."""
    off = np.asarray(offset_m, dtype=float)
    half = np.asarray(half_width_m, dtype=float)
    main = np.asarray(main_friction, dtype=float)
    n = len(half)
    _check(n, {"offset_m": off, "half_width_m": half, "main_friction": main})
    lp, rp = _side_arrays(left, n, "left"), _side_arrays(right, n, "right")
    beyond = np.abs(off) - half
    border_w = np.where(off >= 0, lp.border_width_m, rp.border_width_m)
    border_mu = np.where(off >= 0, lp.border_friction, rp.border_friction)
    outer_mu = np.where(off >= 0, lp.outer_friction, rp.outer_friction)
    return np.where(beyond <= 0, main, np.where(beyond <= border_w, border_mu, outer_mu))


def turn_direction(seg_type: np.ndarray) -> np.ndarray:
    """+1 on a left turn, -1 on a right turn, 0 on a straight, per TORCS segment type."""
    return np.where(seg_type == LEFT, 1.0, np.where(seg_type == RIGHT, -1.0, 0.0))


def side_parts(seg: dict[str, np.ndarray], ids: np.ndarray, frac: np.ndarray, side: str) -> SideParts:
    """One side ("left" or "right") of the track at samples on segments `ids`, `frac` of the way
    along each, from the bridge's segment arrays (Track.seg); no sides where the arrays lack them
    (tracks recorded before the bridge sent them)."""
    if f"{side}_border_width_m" not in seg:
        zero = np.zeros(len(ids))
        return SideParts(zero, np.zeros(len(ids), bool), zero, zero, zero)
    outer0, outer1 = seg[f"{side}_outer_start_width_m"][ids], seg[f"{side}_outer_end_width_m"][ids]
    return SideParts(border_width_m=seg[f"{side}_border_width_m"][ids].astype(float),
                     border_wall=seg[f"{side}_border_style"][ids] == BORDER_WALL,
                     border_friction=seg[f"{side}_border_friction"][ids].astype(float),
                     outer_width_m=(outer0 + frac * (outer1 - outer0)).astype(float),
                     outer_friction=seg[f"{side}_outer_friction"][ids].astype(float))


def grippy_sides(side: SideParts, main_friction: np.ndarray,
                 roughness: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                 roll_resistance: tuple[np.ndarray, np.ndarray] | None = None,
                 ride_height_m: float = 0.0) -> SideParts:
    """The side with its parts that grip less than the track cut off (a wall from there out).
    roughness: (the track's, the border's, the side's) surface roughness per sample: the height (m)
    of the wave TORCS puts on the surface (RtTrackHeightL). A part rougher than the track counts as
    gripping less (the wave shakes the wheels' load), unless its crest-to-trough height (twice the
    roughness) stays below the car's `ride_height_m`: the floor clears the waves.
    roll_resistance: (the track's, the side's) rolling resistance; a side that brakes the car more
    than the track is left out as well."""
    border_ok = (side.border_width_m <= 0) | (side.border_friction >= main_friction)
    outer_ok = side.outer_friction >= main_friction
    if roughness is not None:
        main_rough, border_rough, outer_rough = roughness
        smooth = np.maximum(main_rough, 0.5 * ride_height_m)
        border_ok &= (side.border_width_m <= 0) | (border_rough <= smooth)
        outer_ok &= outer_rough <= smooth
    if roll_resistance is not None:
        outer_ok &= roll_resistance[1] <= roll_resistance[0]
    outer_ok &= border_ok
    return dataclasses.replace(side, border_wall=side.border_wall | ~border_ok,
                               outer_width_m=np.where(outer_ok, side.outer_width_m, 0.0))


def pit_exempt(pit_side: int | None, entry_seg: int, exit_seg: int, ids: np.ndarray, side: int) -> np.ndarray:
    """Samples on main segments from the pit entry to the pit exit on that side (ReRaceRules): there
    the pit side's edge is not checked for cutting. pit_side None: the track has no pit lane."""
    if pit_side is None or pit_side != side:
        return np.zeros(len(ids), bool)
    a, b = entry_seg, exit_seg
    return (ids >= a) & (ids <= b) if a <= b else (ids >= a) | (ids <= b)
