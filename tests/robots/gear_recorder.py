"""A robot that writes the car's gear data (gears.json) and all its constants (car.json) as the host
sees them, then drives like the middle robot."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

from boxbox.model import Car, CarSetup, Track
from boxbox.robot.simple import MiddleRobot


class GearRecorder(MiddleRobot):
    def on_track(self, track: Track, car: Car) -> None:
        super().on_track(track, car)
        out = Path(os.environ["BOXBOX_RUN_DIR"]) / "gears.json"
        out.write_text(json.dumps({"max_gear": car.max_gear, "gear_nb": car.gear_count,
                                   "gear_offset": car.gear_offset, "ratios": list(car.gear_ratios)}))
        (out.parent / "car.json").write_text(json.dumps(dataclasses.asdict(car)))


class ShortFirstGear(GearRecorder):
    """The GearRecorder with its own first gear (car_setup): $FIRST_GEAR, 2.5 by default (car1-trb1's
    own is 3.0)."""

    def car_setup(self, track: Track, car: Car) -> CarSetup:
        return CarSetup(gear_ratios=(float(os.environ.get("FIRST_GEAR", "2.5")),))
