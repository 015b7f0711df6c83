"""Gears as TORCS has them: every installed car's top gear, and the shipped robot using it."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pyarrow.parquet as pq

from boxbox.torcs import catalog, launch
from boxbox.torcs.paths import system_torcs
from helpers import ROBOTS

FORWARD_GEARS = [str(g) for g in range(1, 9)]  # TORCS names forward gears "1".."8"


def _gear_ratios(xml: Path) -> dict[str, float]:
    """Gear name -> ratio from one parameter file's Gearbox/gears section."""
    root = ET.parse(xml).getroot()
    gears = root.find("./section[@name='Gearbox']/section[@name='gears']")
    ratios = {}
    for sec in gears if gears is not None else []:
        num = sec.find("attnum[@name='ratio']")
        if num is not None:
            ratios[sec.get("name")] = float(num.get("val"))
    return ratios


def forward_gears_in_description(car: str) -> int:
    """Non-zero forward ratios in the car's own description (its category's file, then the car's
    file over it, the order TORCS merges them in)."""
    data = system_torcs().data_dir
    car_xml = data / "cars" / car / f"{car}.xml"
    root = ET.parse(car_xml).getroot()
    category = root.find("./section[@name='Car']/attstr[@name='category']")
    ratios: dict[str, float] = {}
    if category is not None:
        ratios.update(_gear_ratios(data / "categories" / f"{category.get('val')}.xml"))
    ratios.update(_gear_ratios(car_xml))
    return sum(1 for name in FORWARD_GEARS if ratios.get(name, 0.0) != 0.0)


def test_max_gear_matches_every_cars_description(tmp_path, overlay):
    cars = catalog.cars()
    assert len(cars) >= 17
    seen_by_car, expected_by_car = {}, {}
    for car in cars:
        run = tmp_path / car
        cfg = launch.RaceConfig(track="michigan", category="oval", car=car, laps=1, telemetry=False,
                                robots=[f"{ROBOTS / 'gear_recorder.py'}:GearRecorder"], run_dir=run)
        result = launch.run_race(cfg, overlay)
        assert result.error is None, (car, result.error)
        seen_by_car[car] = json.loads((run / "gears.json").read_text())
        expected_by_car[car] = forward_gears_in_description(car)
    assert min(expected_by_car.values()) >= 4  # the descriptions were read
    assert {c: s["max_gear"] for c, s in seen_by_car.items()} == expected_by_car
    for car, seen in seen_by_car.items():
        assert seen["gear_nb"] == seen["max_gear"] + 1  # TORCS's _gearNb is the top gear + 1
        assert seen["ratios"][seen["max_gear"] + seen["gear_offset"]] > 0.0, car


def test_the_shipped_robot_reaches_its_top_gear(tmp_path, overlay):
    cfg = launch.RaceConfig(track="michigan", category="oval", laps=1, run_dir=tmp_path / "run")
    result = launch.run_race(cfg, overlay)
    assert result.error is None, result.error
    gears = pq.read_table(tmp_path / "run" / "telemetry.parquet", columns=["gear"]).column("gear").to_pylist()
    assert max(gears) == 6  # car1-trb1 has six forward gears
    assert result.drivers[0].top_speed > 75.0
