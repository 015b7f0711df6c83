"""A robot that only records what the bridge tells it: the track's segment arrays and the car's
constants, written to its run directory (`BOXBOX_RUN_DIR`) as `track.npz` (one array per segment
field, and `meta`: JSON of the track's scalars, its pit lane and the car) when the race starts.
It then stands still with the brake on. `boxbox limit` races it for the shortest race TORCS runs to
learn a track and a car without driving them.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from boxbox.model import Car, Controls, PitLane, State, Track
from boxbox.robot.base import Robot

RECORD_FILE = "track.npz"


class Recorder(Robot):
    name = "recorder"

    def on_track(self, track: Track, car: Car) -> None:
        super().on_track(track, car)
        save_track(Path(os.environ["BOXBOX_RUN_DIR"]) / RECORD_FILE, track, car)

    def drive(self, state: State) -> Controls:
        return Controls(brake=1.0)


def save_track(path: Path, track: Track, car: Car) -> None:
    """Write the track and the car as `load_track` reads them back."""
    meta = {"name": track.name, "category": track.category, "length_m": track.length_m, "width_m": track.width_m,
            "pit": dataclasses.asdict(track.pit) if track.pit else None, "car": dataclasses.asdict(car)}
    tmp = path.with_name(path.name + ".tmp.npz")
    arrays: dict[str, Any] = {"meta": np.asarray(json.dumps(meta)), **track.seg}
    np.savez(tmp, **arrays)
    tmp.replace(path)


def load_track(path: Path) -> tuple[Track, Car]:
    """The track and car `save_track` wrote."""
    with np.load(path) as z:
        meta = json.loads(str(z["meta"]))
        seg = {k: z[k] for k in z.files if k != "meta"}
    car = meta["car"]
    for key in ("gear_ratios", "torque_curve_radps", "torque_curve_nm"):
        car[key] = tuple(car[key])
    pit = PitLane(**meta["pit"]) if meta["pit"] else None
    track = Track(name=meta["name"], category=meta["category"], length_m=meta["length_m"], width_m=meta["width_m"],
                  seg=seg, pit=pit)
    return track, Car(**car)
