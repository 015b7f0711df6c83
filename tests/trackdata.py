"""Real track and car data recorded from TORCS (tests/data/tracks/*.npz) for tests without TORCS.

Each file holds one track's segment arrays as the bridge sends them, and the car1-trb1 constants.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from boxbox.model import Car, PitLane, Track

DATA = Path(__file__).parent / "data" / "tracks"
TRACKS = sorted(p.stem for p in DATA.glob("*.npz"))


def load(name: str) -> tuple[Track, Car]:
    with np.load(DATA / f"{name}.npz") as z:
        meta = json.loads(str(z["meta"]))
        seg = {k: z[k] for k in z.files if k != "meta"}
    car = meta["car"]
    car["gear_ratios"] = tuple(car["gear_ratios"])
    pit = PitLane(**meta["pit"]) if meta["pit"] else None
    track = Track(name=meta["name"], category=meta["category"], length_m=meta["length_m"],
                  width_m=meta["width_m"], seg=seg, pit=pit)
    return track, Car(**car)


def build_track(pieces: list[tuple], width_m: float = 12.0, seg_len_m: float = 5.0) -> Track:
    """A closed track from ("S", length_m) / ("L" | "R", radius_m, angle_deg) pieces, cut into
    ~5 m segments with the same fields the bridge sends (start at (0, 0), heading +x)."""
    names = ("type", "length_m", "width_m", "start_width_m", "end_width_m", "start_dist_m", "radius_m",
             "arc_rad", "center_x", "center_y", "start_left_x", "start_left_y", "start_right_x",
             "start_right_y", "end_left_x", "end_left_y", "end_right_x", "end_right_y", "start_angle_rad",
             "friction", "start_z_m", "end_z_m")
    cols: dict[str, list[float]] = {k: [] for k in names}
    x = y = h = dist = 0.0
    hw = width_m / 2
    for piece in pieces:
        if piece[0] == "S":
            k = max(1, math.ceil(piece[1] / seg_len_m))
            seg_len = piece[1] / k
        else:
            radius, arc = piece[1], math.radians(piece[2])
            k = max(1, math.ceil(radius * arc / seg_len_m))
            seg_len = radius * arc / k
        for _ in range(k):
            lx, ly = -math.sin(h), math.cos(h)
            row = dict(length_m=seg_len, width_m=width_m, start_width_m=width_m, end_width_m=width_m,
                       start_dist_m=dist, start_left_x=x + hw * lx, start_left_y=y + hw * ly,
                       start_right_x=x - hw * lx, start_right_y=y - hw * ly, start_angle_rad=h,
                       friction=1.2)
            if piece[0] == "S":
                row.update(type=3, radius_m=0.0, arc_rad=0.0, center_x=0.0, center_y=0.0)
                x, y = x + seg_len * math.cos(h), y + seg_len * math.sin(h)
            else:
                sign = 1.0 if piece[0] == "L" else -1.0
                cx, cy = x + sign * radius * lx, y + sign * radius * ly
                row.update(type=2 if sign > 0 else 1, radius_m=radius, arc_rad=seg_len / radius,
                           center_x=cx, center_y=cy)
                h += sign * seg_len / radius
                x, y = cx + sign * radius * math.sin(h), cy - sign * radius * math.cos(h)
            lx, ly = -math.sin(h), math.cos(h)
            row.update(end_left_x=x + hw * lx, end_left_y=y + hw * ly, end_right_x=x - hw * lx,
                       end_right_y=y - hw * ly, start_z_m=0.0, end_z_m=0.0)  # flat
            for key, value in row.items():
                cols[key].append(value)
            dist += seg_len
    seg = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    return Track(name="synthetic", category="road", length_m=dist, width_m=width_m, seg=seg, pit=None)
