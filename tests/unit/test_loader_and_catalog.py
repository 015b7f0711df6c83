"""Robot loading and TORCS name checks (no race needed)."""

from __future__ import annotations

import pytest

from boxbox.errors import UsageError
from boxbox.robot.base import Robot
from boxbox.robot.loader import BUILTIN, load_robot_class
from boxbox.torcs import racefile
from helpers import ROBOTS


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_builtin_robots_load(name):
    assert issubclass(load_robot_class(name), Robot)


def test_file_and_module_specs():
    assert load_robot_class(f"{ROBOTS / 'faulty.py'}:Plain").__name__ == "Plain"
    assert load_robot_class("boxbox.robot.simple:MiddleRobot").__name__ == "MiddleRobot"


@pytest.mark.parametrize("spec,message", [
    ("boxbo", "did you mean boxbox"),
    (f"{ROBOTS / 'faulty.py'}:Plian", "robots there: Plain"),
    ("boxbox.robot.simple:Nope", "has no class 'Nope'"),
])
def test_bad_specs_name_the_nearest(spec, message):
    with pytest.raises(UsageError, match=message):
        load_robot_class(spec)


def test_race_file_lists_drivers_in_order():
    xml = racefile.race_xml("g-track-1", "road", 5, [racefile.Entry("boxbox", 0), racefile.Entry("bt", 2)])
    assert xml.index('val="boxbox"') < xml.index('val="bt"')
    assert '<attnum name="laps" val="5"/>' in xml
    assert '<attstr name="display mode" val="results only"/>' in xml


def test_an_unknown_track_or_car_in_capitals_gets_the_nearest_names(monkeypatch):
    """E-TRACK-2 got no suggestion: the nearest names are found case aside."""
    import pytest

    from boxbox.errors import UsageError
    from boxbox.torcs import catalog

    monkeypatch.setattr(catalog, "tracks", lambda: {"e-track-2": "road", "g-track-1": "road"})
    monkeypatch.setattr(catalog, "cars", lambda: ["car1-trb1", "155-DTM"])
    with pytest.raises(UsageError, match=r"unknown track 'E-TRACK-2'; did you mean e-track-2[,?]"):
        catalog.check_track("E-TRACK-2")
    with pytest.raises(UsageError, match=r"unknown car '155-dtm'; did you mean 155-DTM\?"):
        catalog.check_car("155-dtm")
