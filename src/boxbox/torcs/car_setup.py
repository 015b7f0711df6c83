"""The car setup (model/car_setup.py) in TORCS's terms: where each field lives in a car's parameter
files, what the car allows (read from the installed TORCS: the category's file with the car's over
it, the ranges of both holding, as TORCS merges them), and the values the bridge writes into the
robot's setup handle at rbNewTrack (the FUEL record: one slot per place, NaN for the car's own)."""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from boxbox.errors import UsageError
from boxbox.model import Car, CarSetup
from boxbox.model.car import AWD, FWD, RWD
from boxbox.model.car_setup import GEAR_SETTINGS, group_of, setup_from, unit_of
from boxbox.model.constants import INCH_M, POUND_KG

NUMBER = re.compile(r"\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")
Place = tuple[str, str]  # (section path, key) in a car's parameter file
DIFFERENTIALS = {RWD: "Rear Differential", FWD: "Front Differential", AWD: "Central Differential"}
DRIVETRAINS = {"RWD": RWD, "FWD": FWD, "4WD": AWD}
DAMPERS = {"slow_bump": "slow bump", "slow_rebound": "slow rebound", "fast_bump": "fast bump",
           "fast_rebound": "fast rebound"}
# the SI value of one of each unit the car files write these settings in (TORCS's lbs is the pound
# mass, so its spring rate lbs/in is 17.86 kg/m: car1-trb1's 5500 lbs/in reach simuv2 as 98,219 N/m)
UNIT_SI = {"": 1.0, "deg": math.pi / 180.0, "rad": 1.0, "m": 1.0, "cm": 0.01, "mm": 0.001, "in": INCH_M,
           "Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "bar": 1e5, "N.m": 1.0, "N/m": 1.0, "N.s/m": 1.0,
           "lbs/in": POUND_KG / INCH_M, "lbs/in/s": POUND_KG / INCH_M}


def places(drivetrain: int) -> dict[str, list[Place]]:
    """Each setting (CarSetup's range names) -> where TORCS reads it for a car of this drivetrain
    (a front or rear value is both wheels' of the axle)."""
    diff = DIFFERENTIALS[drivetrain]
    out = {"front_wing_angle_rad": [("Front Wing", "angle")], "rear_wing_angle_rad": [("Rear Wing", "angle")],
           **{name: [(f"Gearbox/gears/{i}", "ratio")] for i, name in enumerate(GEAR_SETTINGS, start=1)},
           "final_drive_ratio": [(diff, "ratio")], "diff_max_slip_bias": [(diff, "max slip bias")],
           "diff_locking_torque_nm": [(diff, "locking input torque")],
           "diff_locking_brake_torque_nm": [(diff, "locking brake input torque")],
           "brake_front_share": [("Brake System", "front-rear brake repartition")],
           "brake_pressure_max_pa": [("Brake System", "max pressure")]}
    for axle in ("front", "rear"):
        sides = [f"{axle.capitalize()} {side}" for side in ("Right", "Left")]
        out[f"{axle}_spring_npm"] = [(f"{s} Suspension", "spring") for s in sides]
        for name, key in DAMPERS.items():
            out[f"{axle}_{name}_nspm"] = [(f"{s} Suspension", key) for s in sides]
        out[f"{axle}_anti_roll_npm"] = [(f"{axle.capitalize()} Anti-Roll Bar", "spring")]
        out[f"{axle}_ride_height_m"] = [(f"{s} Wheel", "ride height") for s in sides]
    return out


# the Car fields (what on_track sees) each setting changes; the others (gears, differential, anti-roll
# bars) are not Car fields, or come with the car TORCS builds (the gears' overall ratios)
WHEEL_KEYS = {"front": ("fr", "fl"), "rear": ("rr", "rl")}
CAR_FIELDS = {"front_wing_angle_rad": ("front_wing_angle_rad",), "rear_wing_angle_rad": ("rear_wing_angle_rad",),
              "brake_front_share": ("brake_front_rear",), "brake_pressure_max_pa": ("brake_pressure_max",),
              **{f"{axle}_spring_npm": tuple(f"spring_{w}_npm" for w in ws) for axle, ws in WHEEL_KEYS.items()},
              **{f"{axle}_{name}_nspm": tuple(f"{name}_{w}_nspm" for w in ws)
                 for axle, ws in WHEEL_KEYS.items() for name in DAMPERS},
              **{f"{axle}_ride_height_m": tuple(f"ride_height_{w}_m" for w in ws) for axle, ws in WHEEL_KEYS.items()}}

# every place any drivetrain sets, in a fixed order: the FUEL record's slots (wire.py)
SLOTS: list[Place] = list(dict.fromkeys(p for d in (RWD, FWD, AWD) for ps in places(d).values() for p in ps))


@dataclass(frozen=True)
class Setting:
    """One setting of a car: its own value and the range it allows (SI)."""

    value: float
    lo: float
    hi: float


@dataclass(frozen=True)
class CarSettings:
    """What a car allows to set: the settings by CarSetup's range names, and its drivetrain."""

    car: str
    drivetrain: int
    settings: dict[str, Setting]

    def ranges(self) -> dict[str, tuple[float, float]]:
        return {name: (s.lo, s.hi) for name, s in self.settings.items()}

    def problem(self, setup: CarSetup) -> str | None:
        return setup.problem(self.ranges(), self.car)


@dataclass(frozen=True)
class SettingRow:
    """One setting as `boxbox params` shows it: the value the race gives the car (the settings' or
    the car's own), where it comes from, and the car's range (None: the car's files have no such
    setting)."""

    group: str
    name: str
    unit: str
    value: float | None
    source: str  # "car" (its files) or "--set"
    car: Setting | None


def setting_rows(car: str, given: dict) -> list[SettingRow]:
    """Each setting of the car setup on `car`, in CarSetup's order (the gears: each the car has or
    `given` sets), with the settings of `given` (--set's) over the car's own values."""
    settings = car_settings(car).settings
    values = setup_from(given).values()
    rows = []
    for f in dataclasses.fields(CarSetup):
        names = [g for g in GEAR_SETTINGS if g in settings or g in values] if f.name == "gear_ratios" else [f.name]
        for name in names:
            own = settings.get(name)
            value = values.get(name, None if own is None else own.value)
            rows.append(SettingRow(group_of(name), name, unit_of(name), value,
                                   "--set" if name in values else "car", own))
    return rows


def _number(text: str | None) -> float:
    """The number a car file's attribute starts with, as TORCS's strtod reads it (car3-trb1 writes
    a torque's max as 350.0.0: 350), NaN where there is none."""
    found = NUMBER.match(text or "")
    return float(found.group()) if found else math.nan


def _read_params(path: Path) -> dict[Place, Setting]:
    """Each number of a TORCS parameter file, by place: its value and range in SI (a number without
    min and max is fixed at its value)."""
    out: dict[Place, Setting] = {}

    def walk(element: ET.Element, path: str) -> None:
        for child in element:
            name = child.get("name", "")
            if child.tag == "section":
                walk(child, f"{path}/{name}" if path else name)
            elif child.tag == "attnum" and child.get("unit", "") in UNIT_SI:
                scale = UNIT_SI[child.get("unit", "")]
                value = _number(child.get("val")) * scale
                lo, hi = (_number(child.get(k)) * scale for k in ("min", "max"))
                out[(path, name)] = Setting(value, value if math.isnan(lo) else lo, value if math.isnan(hi) else hi)

    walk(ET.parse(path).getroot(), "")
    return out


def _read_strings(path: Path) -> dict[Place, str]:
    root = ET.parse(path).getroot()
    return {(section.get("name", ""), a.get("name", "")): a.get("val", "")
            for section in root.iter("section") for a in section.findall("attstr")}


@functools.lru_cache(maxsize=16)
def car_settings(car: str) -> CarSettings:
    """What car (a name of the installed TORCS's cars) allows to set, from its files."""
    from boxbox.torcs.paths import system_torcs

    data = system_torcs().data_dir
    car_file = data / "cars" / car / f"{car}.xml"
    if not car_file.exists():
        raise UsageError(f"unknown car {car!r}: `boxbox cars` lists them")
    strings = _read_strings(car_file)
    category_file = data / "categories" / f"{strings.get(('Car', 'category'), '')}.xml"
    numbers = _read_params(category_file) if category_file.exists() else {}
    if category_file.exists():
        strings = {**_read_strings(category_file), **strings}
    for place, own in _read_params(car_file).items():
        base = numbers.get(place)
        numbers[place] = own if base is None else Setting(own.value, max(own.lo, base.lo), min(own.hi, base.hi))
    drivetrain = DRIVETRAINS.get(strings.get(("Drivetrain", "type"), "RWD"), RWD)
    settings = {}
    for name, where in places(drivetrain).items():
        found = [numbers[p] for p in where if p in numbers]
        if len(found) == len(where):  # every wheel's place: the range all of them allow
            settings[name] = Setting(found[0].value, max(s.lo for s in found), min(s.hi for s in found))
    return CarSettings(car, drivetrain, settings)


def checked_setup(answer: object, settings: dict, car: str) -> tuple[CarSetup, str | None]:
    """A robot's car_setup() answer with the race's setup settings over it (RaceOptions.car_setup),
    and what is wrong with it against what the car allows (None: nothing)."""
    if answer is not None and not isinstance(answer, CarSetup):
        return CarSetup(), f"returned {type(answer).__name__}, not CarSetup or None"
    setup = setup_from(settings, answer)
    return setup, car_settings(car).problem(setup)


def apply_setup(car: Car, setup: CarSetup) -> None:
    """The car as the robot set it up (what on_track and drive then see; the gears come with the
    car TORCS builds, at NEW_RACE)."""
    for name, value in setup.values().items():
        for car_field in CAR_FIELDS.get(name, ()):
            setattr(car, car_field, float(value))


def slot_values(setup: CarSetup | None, drivetrain: int) -> list[float]:
    """The FUEL record's setup slots for this setup: each place's value, NaN for the car's own."""
    out = [math.nan] * len(SLOTS)
    if setup is None:
        return out
    where = places(drivetrain)
    for name, value in setup.values().items():
        for place in where[name]:
            out[SLOTS.index(place)] = float(value)
    return out
