"""The ABS held off its bang where the car runs far over its target speed (issue #49)."""

from __future__ import annotations

from boxbox.torcs import launch


def test_abs_bang_held_off_into_street1_hairpin(tmp_path, overlay):
    """car1-stock1's brakes lock its front wheels within one drive step at full pressure, and the
    tutorial's ABS then released fully: full, nothing, full ... from 81 m/s into street-1's hairpin
    at 2800 m, about half the braking; it came in 8-12 m/s too fast and slid into the wall (one lap:
    347 damage). Held at half pressure after a full step while over 8 m/s too fast: 52."""
    cfg = launch.RaceConfig(track="street-1", category="road", car="car1-stock1", laps=1, telemetry=False,
                            learning="fresh", run_dir=tmp_path / "run")
    result = launch.run_race(cfg, overlay)
    assert result.error is None, result.error
    [driver] = result.drivers
    assert driver.laps == 1 and driver.damage < 100, (driver.damage, driver.lap_times)
