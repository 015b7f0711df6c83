"""The example robots of docs/robots.md, raced exactly as the docs write them."""

from __future__ import annotations

import re
from pathlib import Path

from boxbox.robot.base import RaceOptions
from boxbox.torcs import launch

DOC = Path(__file__).resolve().parents[2] / "docs" / "robots.md"


def example(name: str, folder: Path) -> Path:
    """The python block after <!-- example: name --> in the docs, written to folder/name.py."""
    m = re.search(rf"<!-- example: {name} -->\s*```python\n(.*?)```", DOC.read_text(), re.S)
    assert m, f"docs/robots.md has no example {name}"
    path = folder / f"{name}.py"
    path.write_text(m.group(1))
    return path


def test_the_track_follower_finishes_a_lap(tmp_path, overlay):
    robot = f"{example('follower', tmp_path)}:Follower"
    result = launch.run_race(launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=[robot],
                                               run_dir=tmp_path / "run", telemetry=False), overlay)
    assert result.error is None and result.drivers[0].laps == 1


def test_the_pit_stop_robot_stops_in_its_box(tmp_path, overlay):
    robot = f"{example('pitstopper', tmp_path)}:PitStopper"
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=2, robots=[robot], run_dir=tmp_path / "run",
                            options=RaceOptions(pit_laps=(1,)), telemetry=False)
    result = launch.run_race(cfg, overlay)
    assert result.error is None, result.error
    [me] = result.drivers
    assert me.pit_stops == 1 and me.laps == 2
    [stop] = [e for e in me.pit_events if e["stop_time"] is not None]
    assert abs(stop["stop_error_m"]) < 0.5
