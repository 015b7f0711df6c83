"""The width the tutorial robot's racing line may use, per sample of the middle line.

With `track_limits = "strict"` the line keeps `line_margin_m` from the track's edges (the car's
centre), as a racing series would enforce.  With `"torcs"` (the default) it may also use what TORCS
allows without a penalty (docs/track-limits.md: the outside of every turn and both sides of every
straight up to the barrier, the inside of a turn up to 0.7 car widths beyond its edge), but only
sides that grip at least as well as the track (grass and sand would cost more than the width gives)
and never the pit lane's side between the pit entry and exit.  The same safety as on the track is
kept from every limit, `line_margin_m` less half the car's width, and `side_catch_m` more where the
usable sides end (beyond them grass, gravel or a wall: a car running wide there spins).
"""

from __future__ import annotations

import numpy as np

from boxbox.control.trackwidth import drivable_width, grippy_sides, pit_exempt, side_parts, turn_direction
from boxbox.model import Track
from boxbox.model.track import LEFT, RIGHT


def centre_room(track: Track, seg_id: np.ndarray, seg_frac: np.ndarray, half_width_m: np.ndarray,
                car_width_m: float, track_limits: str, ride_height_m: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Room (m) for the car's centre left and right of the middle at samples on segments `seg_id`,
    `seg_frac` of the way along each (MiddleLine's), where the track is 2 x half_width_m wide;
    ride_height_m: the car's lowest, the surface waves it clears (trackwidth.grippy_sides)."""
    seg = track.seg
    ids = np.asarray(seg_id, dtype=int)
    frac = np.asarray(seg_frac, dtype=float)
    main_mu = seg["friction"].astype(float)[ids]
    left = grippy_sides(side_parts(seg, ids, frac, "left"), main_mu, _roughness(seg, ids, "left"),
                        _roll_resistance(seg, ids, "left"), ride_height_m)
    right = grippy_sides(side_parts(seg, ids, frac, "right"), main_mu, _roughness(seg, ids, "right"),
                         _roll_resistance(seg, ids, "right"), ride_height_m)
    turn = turn_direction(seg["type"][ids])
    pit = track.pit
    side, entry, exit_ = (pit.side, pit.entry_seg, pit.exit_seg) if pit else (None, 0, 0)
    exempt_l, exempt_r = pit_exempt(side, entry, exit_, ids, LEFT), pit_exempt(side, entry, exit_, ids, RIGHT)
    room_l, room_r = drivable_width(track_limits, half_width_m, turn, left, right, car_width_m, exempt_l, exempt_r)
    # the pit lane's side stays the track's edge between the pit entry and exit: the lane is there
    on_track = np.maximum(np.asarray(half_width_m) - 0.5 * car_width_m, 0.0)
    room_l = np.where(exempt_l, np.minimum(room_l, on_track), room_l)
    room_r = np.where(exempt_r, np.minimum(room_r, on_track), room_r)
    return room_l, room_r


def _roughness(seg: dict[str, np.ndarray], ids: np.ndarray,
               side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(the track's, the border's, the side's) roughness per sample, None where the bridge sent none."""
    if f"{side}_border_roughness" not in seg:
        return None
    return (seg["roughness"].astype(float)[ids], seg[f"{side}_border_roughness"].astype(float)[ids],
            seg[f"{side}_outer_roughness"].astype(float)[ids])


def _roll_resistance(seg: dict[str, np.ndarray], ids: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(the track's, the side's) rolling resistance per sample, None where the bridge sent none."""
    if f"{side}_outer_roll_resistance" not in seg:
        return None
    return seg["roll_resistance"].astype(float)[ids], seg[f"{side}_outer_roll_resistance"].astype(float)[ids]
