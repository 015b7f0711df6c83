"""TORCS parameter files for one race: the race file and our robot's driver list."""

from __future__ import annotations

from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

RACE_NAME = "Quick Race"


@dataclass(frozen=True)
class Entry:
    """One car in the race: a TORCS robot module and its index."""

    module: str
    idx: int


def _num(name: str, value: float) -> str:
    return f'<attnum name={quoteattr(name)} val="{value:g}"/>'


def _str(name: str, value: str) -> str:
    return f"<attstr name={quoteattr(name)} val={quoteattr(value)}/>"


def race_xml(track: str, category: str, laps: int, entries: list[Entry]) -> str:
    drivers = "\n".join(
        f'    <section name="{i}">{_num("idx", e.idx)}{_str("module", e.module)}</section>'
        for i, e in enumerate(entries, start=1))
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<!DOCTYPE params SYSTEM "params.dtd">
<params name="boxbox race" type="param" mode="mw">
  <section name="Header">{_str("name", "boxbox race")}{_num("priority", 10)}</section>
  <section name="Tracks">{_num("maximum number", 1)}
    <section name="1">{_str("name", track)}{_str("category", category)}</section>
  </section>
  <section name="Races"><section name="1">{_str("name", RACE_NAME)}</section></section>
  <section name="{RACE_NAME}">
    {_num("distance", 0)}{_str("type", "race")}{_str("starting order", "drivers list")}
    {_str("restart", "yes")}{_num("laps", laps)}{_str("display mode", "results only")}
    <section name="Starting Grid">{_num("rows", 2)}{_num("distance to start", 25)}
      {_num("distance between columns", 20)}{_num("offset within a column", 10)}
      {_num("initial speed", 0)}{_num("initial height", 0.2)}</section>
  </section>
  <section name="Drivers">{_num("maximum number", 40)}
{drivers}
  </section>
</params>
"""


def robot_xml(drivers: list[tuple[str, str]]) -> str:
    """drivers/boxbox/boxbox.xml: (name, car) per robot index 0.."""
    rows = "\n".join(
        f'      <section name="{i}">{_str("name", name)}{_str("team", "boxbox")}{_str("desc", "Python robot")}'
        f'{_str("author", "boxbox")}{_str("car name", car)}{_num("race number", i + 1)}{_str("type", "robot")}'
        f'{_str("skill level", "pro")}</section>'
        for i, (name, car) in enumerate(drivers))
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<!DOCTYPE params SYSTEM "../../config/params.dtd">
<params name="boxbox" type="robotdef" mode="mw">
  <section name="Robots">
    <section name="index">
{rows}
    </section>
  </section>
</params>
"""
