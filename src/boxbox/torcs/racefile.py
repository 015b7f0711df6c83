"""TORCS parameter files for one race: the race file and our robot's driver list."""

from __future__ import annotations

import re
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.torcs.paths import ROBOT_MODULE

RACE_NAME = "Quick Race"


@dataclass(frozen=True)
class Entry:
    """One car in the race: a TORCS robot module and its index."""

    module: str
    idx: int


def grid(python_cars: int, opponents: list[tuple[str, int]], position: int | None = None) -> list[Entry]:
    """The starting grid: the Python cars (boxbox's module, indices 0..) from grid slot `position`
    (1 = pole; None = pole), TORCS's robots filling the other slots in the order given."""
    others = [Entry(module, idx) for module, idx in opponents]
    slot = 1 if position is None else position
    if not 1 <= slot <= len(others) + 1:
        raise ValueError(f"grid position {slot} is outside the grid of {python_cars + len(others)} cars "
                         f"(1 .. {len(others) + 1} for the Python cars)")
    ours = [Entry(ROBOT_MODULE, i) for i in range(python_cars)]
    return others[: slot - 1] + ours + others[slot - 1:]


def _num(name: str, value: float) -> str:
    return f'<attnum name={quoteattr(name)} val="{value:g}"/>'


def _str(name: str, value: str) -> str:
    return f"<attstr name={quoteattr(name)} val={quoteattr(value)}/>"


# The starting grid the race file gives (a track's own "Starting Grid" section overrides it):
# the pole GRID_TO_START_M behind the start line, the others in rows of GRID_ROWS side by side,
# each row GRID_ROW_GAP_M behind the last, each car of a row GRID_STAGGER_M behind the one before
GRID_TO_START_M = 25.0
GRID_ROWS = 2
GRID_ROW_GAP_M = 20.0
GRID_STAGGER_M = 10.0


def grid_offset_m(slot_index: int) -> float:
    """How far behind the pole the car of grid slot `slot_index` (0: the pole) stands, as TORCS's
    race engine places the race file's grid."""
    return slot_index // GRID_ROWS * GRID_ROW_GAP_M + slot_index % GRID_ROWS * GRID_STAGGER_M


def race_xml(track: str, category: str, laps: int, entries: list[Entry], to_start_m: float = GRID_TO_START_M,
             start_speed_mps: float = 0.0) -> str:
    """The race file; `to_start_m` (the pole's distance behind the start line) and `start_speed_mps`
    (every car's speed when placed) are its starting grid's, which TORCS's race engine reads unless
    the track's own file sets them (tracks/<category>/<name>/<name>.xml, section "Starting Grid")."""
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
    <section name="Starting Grid">{_num("rows", GRID_ROWS)}{_num("distance to start", to_start_m)}
      {_num("distance between columns", GRID_ROW_GAP_M)}{_num("offset within a column", GRID_STAGGER_M)}
      {_num("initial speed", start_speed_mps)}{_num("initial height", 0.2)}</section>
  </section>
  <section name="Drivers">{_num("maximum number", 40)}
{drivers}
  </section>
</params>
"""


def robot_xml(drivers: list[tuple[str, str]], level: SkillLevel = DEFAULT_SKILL_LEVEL) -> str:
    """drivers/boxbox/boxbox.xml: (name, car) per robot index 0.., all at one skill level."""
    rows = "\n".join(
        f'      <section name="{i}">{_str("name", name)}{_str("team", "boxbox")}{_str("desc", "Python robot")}'
        f'{_str("author", "boxbox")}{_str("car name", car)}{_num("race number", i + 1)}{_str("type", "robot")}'
        f'{_str("skill level", level.torcs_name)}</section>'
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


_SECTION_OPEN = re.compile(r'<section\s+name\s*=\s*"([^"]*)"\s*>')
_SECTION_TAG = re.compile(r"<section\b[^>]*?(/?)>|</section\s*>")
_LEVEL_ATTR = re.compile(r'<attstr\s+name\s*=\s*"skill level"[^>]*?(?:/>|>\s*</attstr>)')


def with_skill_level(driver_xml: str, indices: set[int], level: SkillLevel) -> str:
    """A TORCS robot's driver file (drivers/NAME/NAME.xml) with `skill level` set for `indices`.

    Only the sections of Robots/index are touched, and the text is edited in place, not
    re-serialised, so comments, the DOCTYPE and everything else the robot's author wrote stay as
    they are. Raises ValueError when an index has no section.
    """
    index_open = re.search(r'<section\s+name="index"\s*>', driver_xml)
    if index_open is None:
        raise ValueError("the driver file has no Robots/index section")
    index_end = _section_end(driver_xml, index_open.end())
    out, pos, found = [], 0, set()
    for match in _SECTION_OPEN.finditer(driver_xml, index_open.end(), index_end):
        name = match.group(1)
        if match.start() < pos or not name.isdigit() or int(name) not in indices or int(name) in found:
            continue
        end = _section_end(driver_xml, match.end())
        body = _LEVEL_ATTR.sub("", driver_xml[match.end():end])
        out += [driver_xml[pos:match.end()], _str("skill level", level.torcs_name), body]
        pos = end
        found.add(int(name))
    missing = indices - found
    if missing:
        raise ValueError(f"no robot index {sorted(missing)} in the driver file")
    return "".join(out) + driver_xml[pos:]


def _section_end(text: str, start: int) -> int:
    """Offset of the `</section>` that closes the section whose body starts at `start`."""
    depth = 1
    for tag in _SECTION_TAG.finditer(text, start):
        if tag.group(0).startswith("</"):
            depth -= 1
        elif not tag.group(1):  # not self-closing
            depth += 1
        if depth == 0:
            return tag.start()
    raise ValueError(f"unclosed section at offset {start}")
