"""Real track and car data recorded from TORCS (tests/data/tracks/*.npz) for tests without TORCS.

Each file holds one track's segment arrays as the bridge sends them, and the car1-trb1 constants.
"""

from __future__ import annotations

import json
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
