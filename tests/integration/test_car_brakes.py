"""Each car's brakes as its description gives them, and the robot braking as they really slow it (issue #49)."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest

from boxbox.torcs import launch
from boxbox.torcs.paths import system_torcs
from helpers import ROBOTS

WHEELS = {"fr": "Front Right Brake", "fl": "Front Left Brake", "rr": "Rear Right Brake", "rl": "Rear Left Brake"}
UNITS = {"mm": 1e-3, "cm2": 1e-4}  # TORCS converts the file's units to SI


def _brake_values(xml, section: str) -> dict[str, float]:
    root = ET.parse(xml).getroot()
    found = {}
    for num in root.findall(f"./section[@name='{section}']/attnum"):
        found[num.get("name")] = float(num.get("val")) * UNITS.get(num.get("unit", ""), 1.0)
    return found


def brakes_in_description(car: str) -> dict[str, dict[str, float]]:
    """Per wheel the disk diameter (m), piston area (m^2) and pad mu: the category's file, then the
    car's over it, the order TORCS merges them in."""
    data = system_torcs().data_dir
    car_xml = data / "cars" / car / f"{car}.xml"
    category = ET.parse(car_xml).getroot().find("./section[@name='Car']/attstr[@name='category']")
    out = {}
    for w, section in WHEELS.items():
        values = _brake_values(data / "categories" / f"{category.get('val')}.xml", section) if category is not None \
            else {}
        values.update(_brake_values(car_xml, section))
        out[w] = values
    return out


@pytest.mark.parametrize("car", ["155-DTM", "car1-trb1"])
def test_each_wheels_brake_reaches_the_robot(tmp_path, overlay, car):
    cfg = launch.RaceConfig(track="michigan", category="oval", car=car, laps=1, telemetry=False,
                            robots=[f"{ROBOTS / 'gear_recorder.py'}:GearRecorder"], run_dir=tmp_path / "run")
    result = launch.run_race(cfg, overlay)
    assert result.error is None, result.error
    seen = json.loads((tmp_path / "run" / "car.json").read_text())
    for w, values in brakes_in_description(car).items():
        assert seen[f"brake_disk_diameter_{w}_m"] == pytest.approx(values["disk diameter"], rel=1e-6)
        assert seen[f"brake_piston_area_{w}_m2"] == pytest.approx(values["piston area"], rel=1e-6)
        assert seen[f"brake_mu_{w}"] == pytest.approx(values["mu"], rel=1e-6)


@pytest.mark.parametrize("car", [
    # The 155-DTM's brakes stop it at about 20 m/s^2, less than its tyres grip at speed: braking from
    # 68 m/s into street-1's hairpin on its tyres' grip, it came in 9 m/s too fast and went straight on
    # into the wall (313 damage on the first lap) before the speed profile took the brakes' ceiling
    # (TutorialRobot._brake_ceiling, control/braking.py).
    "155-DTM",
    # car1-stock1's brakes lock its front wheels within one drive step at full pressure, and the
    # tutorial's ABS then released fully: full, nothing, full ... from 81 m/s into the same hairpin,
    # about half the braking; it came in 8-12 m/s too fast and slid into the wall (347 damage).  Held
    # at half pressure after a full step while over 8 m/s too fast (traction.abs_hold): 52.
    "car1-stock1",
])
def test_street1_hairpin_braked_for_in_time(tmp_path, overlay, car):
    """One lap of street-1 alone, under 100 damage: the hairpin at 2800 m braked for as the car's
    brakes and ABS really slow it (issue #49)."""
    cfg = launch.RaceConfig(track="street-1", category="road", car=car, laps=1, telemetry=False,
                            learning="fresh", run_dir=tmp_path / "run")
    result = launch.run_race(cfg, overlay)
    assert result.error is None, result.error
    [driver] = result.drivers
    assert driver.laps == 1 and driver.damage < 100, (driver.damage, driver.lap_times)
