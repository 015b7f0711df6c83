"""The race's driver files: boxbox's own list and the copies of TORCS robots' files with a skill level."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from boxbox.model.skill import SkillLevel
from boxbox.torcs.racefile import grid, grid_offset_m, race_xml, robot_xml, with_skill_level

DRIVER_FILE = """<?xml version="1.0" encoding="UTF-8"?>
<!-- the author's comment stays -->
<!DOCTYPE params SYSTEM "../../libs/tgf/params.dtd">
<params name="bt" type="robotdef">
  <section name="Robots">
    <section name="index">
      <section name="0">
        <attstr name="name" val="bt 1"></attstr>
      </section>
      <section name="1">
        <attstr name="name" val="bt 2"/>
        <attstr name="skill level" val="rookie"></attstr>
        <section name="2"><attnum name="nested" val="1"/></section>
      </section>
      <section name="2">
        <attstr name="name" val="bt 3"/>
      </section>
    </section>
  </section>
</params>
"""


def levels(text: str) -> dict[str, str | None]:
    root = ET.fromstring(text.split("?>", 1)[1].split("]>", 1)[-1].replace(
        '<!DOCTYPE params SYSTEM "../../libs/tgf/params.dtd">', ""))
    index = root.find("./section[@name='Robots']/section[@name='index']")
    assert index is not None
    out = {}
    for sec in index.findall("section"):
        attr = sec.find("attstr[@name='skill level']")
        out[sec.get("name")] = None if attr is None else attr.get("val")
    return out


def test_boxbox_cars_get_the_race_level():
    text = robot_xml([("a", "car1-trb1"), ("b", "car1-trb1")], SkillLevel.PRO)
    root = ET.fromstring(text.split("\n", 2)[2])
    found = [a.get("val") for a in root.iter("attstr") if a.get("name") == "skill level"]
    assert found == ["pro", "pro"]
    assert 'val="semi-pro"' in robot_xml([("a", "car1-trb1")])  # TORCS's own default


def test_a_torcs_robots_copy_sets_only_the_racing_indices():
    out = with_skill_level(DRIVER_FILE, {1, 2}, SkillLevel.PRO)
    assert levels(out) == {"0": None, "1": "pro", "2": "pro"}
    assert out.count("skill level") == 2  # the old rookie entry was replaced, the nested section left alone
    assert "<!-- the author's comment stays -->" in out and "<!DOCTYPE params" in out
    assert with_skill_level(out, {1}, SkillLevel.ROOKIE).count('val="rookie"') == 1


def test_a_missing_index_is_an_error():
    with pytest.raises(ValueError, match=r"no robot index \[7\]"):
        with_skill_level(DRIVER_FILE, {7}, SkillLevel.PRO)


def test_levels_parse_and_name_the_valid_ones():
    assert SkillLevel.parse("semi-pro") is SkillLevel.SEMI_PRO
    assert SkillLevel.SEMI_PRO.skid_factor == 0.3 and SkillLevel.PRO.damage_factor == 1.0
    with pytest.raises(ValueError, match="rookie, amateur, semi-pro, pro"):
        SkillLevel.parse("expert")


def test_grid_puts_the_python_cars_at_their_slot():
    from boxbox.torcs.racefile import Entry, grid

    field = [("inferno", 4), ("berniw", 3), ("bt", 2)]
    assert grid(1, field) == [Entry("boxbox", 0), Entry("inferno", 4), Entry("berniw", 3), Entry("bt", 2)]
    assert grid(1, field, 4) == [Entry("inferno", 4), Entry("berniw", 3), Entry("bt", 2), Entry("boxbox", 0)]
    assert grid(2, field, 2) == [Entry("inferno", 4), Entry("boxbox", 0), Entry("boxbox", 1), Entry("berniw", 3),
                                 Entry("bt", 2)]
    with pytest.raises(ValueError, match="outside the grid"):
        grid(1, field, 5)


def test_the_starting_grid_is_placed_where_the_race_file_says():
    entries = grid(1, [("bt", 2)])
    base = race_xml("g-track-1", "road", 1, entries)
    section = '<section name="Starting Grid"><attnum name="rows" val="2"/><attnum name="distance to start" val="25"/>'
    assert section in base and '<attnum name="initial speed" val="0"/>' in base  # the grid every race has
    placed = race_xml("g-track-1", "road", 1, entries, to_start_m=1234.56, start_speed_mps=3.0)
    assert '<attnum name="distance to start" val="1234.56"/>' in placed and '"initial speed" val="3"' in placed
    assert [grid_offset_m(i) for i in range(4)] == [0.0, 10.0, 20.0, 30.0]  # rows of 2, staggered 10 m, 20 m apart


def test_tracks_that_place_their_own_grid_are_known():
    from boxbox.torcs import catalog

    if not catalog.tracks():
        pytest.skip("TORCS's tracks are not installed")
    assert catalog.track_sets_grid("alpine-1") and catalog.track_sets_grid("spring")
    assert not catalog.track_sets_grid("g-track-1")
    assert not catalog.track_sets_grid("e-track-2")  # its section is a comment
