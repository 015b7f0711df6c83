"""What the installed TORCS offers: tracks, cars, robot modules.  Used to check names early."""

from __future__ import annotations

import difflib
import re
import xml.etree.ElementTree as ET
from functools import cache, lru_cache
from pathlib import Path

from boxbox.errors import UsageError
from boxbox.torcs.paths import ROBOT_MODULE, system_torcs


def _near(name: str, options: list[str]) -> str:
    """The nearest names, case aside (E-TRACK-2 -> e-track-2), as a hint."""
    spelt = {option.lower(): option for option in options}
    near = difflib.get_close_matches(name.lower(), list(spelt), n=3, cutoff=0.5)
    return f"; did you mean {', '.join(spelt[n] for n in near)}?" if near else ""


@lru_cache(maxsize=1)
def tracks() -> dict[str, str]:
    """track name -> category"""
    root = system_torcs().data_dir / "tracks"
    found = {}
    if root.is_dir():
        for xml in sorted(root.glob("*/*/*.xml")):
            if xml.stem == xml.parent.name:
                found[xml.stem] = xml.parent.parent.name
    return found


@lru_cache(maxsize=1)
def cars() -> list[str]:
    root = system_torcs().data_dir / "cars"
    return sorted(p.name for p in root.iterdir() if (p / f"{p.name}.xml").exists()) if root.is_dir() else []


def _sections(xml: Path) -> ET.Element | None:
    try:
        return ET.parse(xml).getroot()
    except (ET.ParseError, OSError):
        return None


@cache
def robot_indices(module: str) -> dict[int, dict[str, str]]:
    """idx -> {name, car} for a TORCS robot module, from drivers/NAME/NAME.xml."""
    root = _sections(system_torcs().data_dir / "drivers" / module / f"{module}.xml")
    out: dict[int, dict[str, str]] = {}
    if root is None:
        return out
    for robots in root.iter("section"):
        if robots.get("name") != "Robots":
            continue
        for index in robots.findall("section"):
            if index.get("name") != "index":
                continue
            for entry in index.findall("section"):
                attrs = {a.get("name", ""): a.get("val", "") for a in entry.findall("attstr")}
                try:
                    out[int(entry.get("name", ""))] = {"name": attrs.get("name", ""), "car": attrs.get("car name", "")}
                except (TypeError, ValueError):
                    pass
    return out


@lru_cache(maxsize=1)
def robot_modules() -> list[str]:
    root = system_torcs().lib_dir / "drivers"
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir() if (p / f"{p.name}.so").exists() and p.name != "human")


@cache
def has_pit_lane(track: str) -> bool:
    """Whether the track's file defines a pit lane (a Pits section with an entry)."""
    category = tracks().get(track)
    path = system_torcs().data_dir / "tracks" / str(category) / track / f"{track}.xml"
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return False
    # Track files pull in other files through XML entities, which ElementTree cannot resolve:
    # read the Pits section as text.
    m = re.search(r'<section\s+name="Pits"\s*>(.*?)</section>', text, re.S | re.I)
    return bool(m and re.search(r'<attstr\s+name="entry"\s+val="[^"]+"', m.group(1)))


@cache
def track_sets_grid(track: str) -> bool:
    """Whether the track's file places the starting grid itself (a "Starting Grid" section with a
    "distance to start", as alpine-1's), which TORCS reads over the race file's."""
    category = tracks().get(track)
    path = system_torcs().data_dir / "tracks" / str(category) / track / f"{track}.xml"
    try:
        text = re.sub(r"<!--.*?-->", "", path.read_text(errors="replace"), flags=re.S)  # e-track-2's is a comment
    except OSError:
        return False
    m = re.search(r'<section\s+name="Starting Grid"\s*>(.*?)</section>', text, re.S | re.I)
    return bool(m and re.search(r'name="distance to start"', m.group(1)))


def check_track(name: str) -> str:
    """The track's category; UsageError naming the nearest tracks when unknown."""
    known = tracks()
    if not known:
        raise UsageError("no TORCS tracks found; run `boxbox setup` first")
    if name not in known:
        raise UsageError(f"unknown track '{name}'{_near(name, list(known))} (`boxbox tracks` lists all)")
    return known[name]


def check_car(name: str) -> str:
    known = cars()
    if name not in known:
        raise UsageError(f"unknown car '{name}'{_near(name, known)} (`boxbox cars` lists all)")
    return name


def parse_opponent(text: str) -> tuple[str, int]:
    """'bt:2' -> ('bt', 2), checked against the installed robots."""
    module, sep, idx_text = text.strip().partition(":")
    modules = robot_modules()
    if module == ROBOT_MODULE:
        raise UsageError("boxbox robots go in --robot, not --opponents")
    if module not in modules:
        raise UsageError(f"unknown TORCS robot '{module}'{_near(module, modules)}; installed: {', '.join(modules)}")
    indices = robot_indices(module)
    if not sep:
        raise UsageError(f"opponent '{text}' needs an index: {module}:IDX with IDX in {sorted(indices)}")
    try:
        idx = int(idx_text)
    except ValueError:
        raise UsageError(f"opponent '{text}': index '{idx_text}' is not a number; use {module}:IDX") from None
    if idx not in indices:
        raise UsageError(f"robot {module} has no index {idx}; valid: {sorted(indices)}")
    return module, idx
