"""boxbox.race from Python: robot classes defined right here, the typed result, telemetry, errors."""

from __future__ import annotations

import polars as pl
import pytest

import boxbox
from boxbox import Controls, Robot


def test_a_class_defined_in_the_test_races_beside_the_shipped_robot(tmp_path):
    class Cautious(Robot):
        name = "cautious"

        def drive(self, state):
            steer = (state.angle_rad - state.to_middle_m / 10) / self.car.steer_lock_rad
            return Controls(steer=max(-1.0, min(1.0, steer)), accel=0.3, brake=0.0, clutch=0.0, gear=1)

        def race_report(self):
            return {"cars": self.options.cars}  # the race's cars, this one included

    result = boxbox.race(track="g-track-1", laps=1, robots=[Cautious, "boxbox"], opponents=["bt:2"],
                         run_dir=tmp_path / "run", report=True)
    assert isinstance(result, boxbox.RaceResult) and result.error is None
    assert result.skill_level == "semi-pro" and result.track == "g-track-1"
    names = {d.name for d in result.drivers}
    assert {"cautious 1", "boxbox 2", "bt 3"} <= names
    ours = [d for d in result.drivers if d.is_python]
    assert len(ours) == 2 and all(d.laps >= 1 or d.name.startswith("cautious") for d in ours)
    assert next(d for d in ours if d.name.startswith("cautious")).report == {"cars": 3}
    frame = result.telemetry()
    assert isinstance(frame, pl.DataFrame) and frame.height > 1000
    assert {"time_s", "speed_mps", "gear"} <= set(frame.columns)
    assert frame.filter(pl.col("car") == 0)["gear"].max() == 1  # the class's own controls were applied
    assert (tmp_path / "run" / "report.html").exists()


def test_bad_input_raises_a_one_line_usage_error():
    with pytest.raises(boxbox.UsageError, match="g-track-1"):
        boxbox.race(track="g-track-11", laps=1)
    with pytest.raises(boxbox.UsageError, match="semi-pro"):
        boxbox.race(track="g-track-1", skill_level="expert")
    with pytest.raises(boxbox.UsageError, match="laps"):
        boxbox.race(track="g-track-1", laps=0)
