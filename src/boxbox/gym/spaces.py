"""The env's observation and action spaces, every field with its unit.

Observations are a `Dict` of float32 `Box`es, or the same numbers as one flat `Box` in the order
`gymnasium.spaces.flatten` gives the `Dict` (its keys sorted by name).  Each observation is one
entry of `OBSERVATIONS` (key, bounds, unit, meaning, where its numbers come from, the range it
takes in a race): the space, the vector and docs/gym.md's table are made from it.  By default each
number is scaled from that range to [-1, 1] (`Scaler`); `raw_observations=True` keeps the units.
Actions are one `Box`, its columns named by the env's `actions` option (`ACTION_RANGES`).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from boxbox.errors import UsageError
from boxbox.gym.sensors import OFF_TRACK, OPPONENT_SECTORS, RANGE_M, SCR_TRACK_ANGLES_DEG
from boxbox.model import Car, State

RADPS_TO_RPM = 60.0 / (2.0 * math.pi)
SCALED_BOUND = 1.0  # a scaled observation lies in [-1, 1] (clipped)


@dataclass(frozen=True)
class RaceScale:
    """What the ranges of some observations depend on: the race's track, car and length."""

    track_length_m: float = 2000.0
    redline_rpm: float = 10_000.0
    tank_l: float = 100.0
    top_gear: int = 6
    laps: int = 1

    @classmethod
    def of(cls, track_length_m: float, car: Car, laps: int) -> RaceScale:
        redline = car.rpm_redline * RADPS_TO_RPM
        return cls(float(track_length_m), redline if redline > 0.0 else cls.redline_rpm,
                   car.tank_l if car.tank_l > 0.0 else cls.tank_l, car.max_gear, laps)

@dataclass(frozen=True)
class Observation:
    """One observation: its key, bounds, unit, what it is (docs/gym.md's table is made of these) and
    where its numbers come from: `state`, fields of the drive step's State, in order; `compute`, a
    number computed from the State; or `sensor`, the range finders ("edges") or the opponent
    sectors ("opponents") gym/sensors.py computes."""

    name: str
    low: float
    high: float
    unit: str
    doc: str
    state: tuple[str, ...] = ()
    compute: Callable[[State], float] | None = None
    sensor: str | None = None
    size: int = 1  # the sensors' own sizes (the range finders: one per angle of the env)
    # the range the numbers take in a race (scaled to [-1, 1]): fixed, or from the race's track and car
    # the range the numbers take in a race, scaled to [-1, 1]: each end a number, or the name of a
    # RaceScale field (the race's track length, the car's redline...)
    span: tuple[float | str, float | str] = (-1.0, 1.0)

    def span_in(self, race: RaceScale) -> tuple[float, float]:
        return tuple(float(getattr(race, end)) if isinstance(end, str) else end for end in self.span)  # type: ignore[return-value]

    def span_text(self) -> str:
        return " to ".join(end if isinstance(end, str) else f"{end:g}" for end in self.span)

    def meaning(self) -> str:
        """The docs table's 'unit and meaning' cell."""
        return self.doc.replace("UNIT", self.unit)


def engine_rpm(s: State) -> float:
    return s.rpm * RADPS_TO_RPM


def track_pos(s: State) -> float:
    width = s.to_left_m + s.to_right_m
    return s.to_middle_m / (0.5 * width) if width > 0.0 else 0.0


# a race car's speed stays within 100 m/s (car1-trb1's top speed on g-track-1's straight: ~75 m/s);
# a wheel of 0.3 m radius turns at 333 rad/s at that speed
SPEED_SPAN_MPS = 100.0
HALF_PI = 0.5 * math.pi  # the car across the track (beyond: it faces backwards, rarely driven)
SPIN_SPAN_RADPS = 400.0

# The observations, by key (the Dict's keys; the flat vector's order is theirs sorted).  The bounds
# are finite (learners scale by them) and generous; a value beyond them is clipped.
OBSERVATIONS: dict[str, Observation] = {o.name: o for o in (
    Observation("angle_rad", -math.pi, math.pi, "rad", "the track axis's direction minus the car's heading, UNIT "
                "(+: the track runs to the car's left)", state=("angle_rad",), span=(-HALF_PI, HALF_PI)),
    Observation("damage", 0.0, 20_000.0, "points", "TORCS's damage UNIT (the car is out at 10000)", state=("damage",),
                span=(0.0, 10_000.0)),
    Observation("dist_from_start_m", 0.0, 100_000.0, "m", "distance along the track from the start line, UNIT",
                state=("dist_from_start_m",), span=(0.0, "track_length_m")),
    Observation("engine_rpm", 0.0, 30_000.0, "revolutions per minute", "engine speed, UNIT", compute=engine_rpm,
                span=(0.0, "redline_rpm")),
    Observation("fuel_l", 0.0, 1_000.0, "litres", "fuel in the tank, UNIT", state=("fuel_l",),
                span=(0.0, "tank_l")),
    Observation("gear", -1.0, 10.0, "", "-1 reverse, 0 neutral, 1.. forward", state=("gear",),
                span=(-1.0, "top_gear")),
    Observation("lap", 0.0, 1_000.0, "", "the lap being driven (0 on the grid behind the line, 1 after the first "
                "crossing)", state=("laps",), span=(0.0, "laps")),
    Observation("opponents_m", 0.0, RANGE_M, "m", f"nearest opponent (centre to centre, UNIT) per 10-degree sector, "
                f"clockwise from straight behind; {RANGE_M:g} when none within {RANGE_M:g} UNIT", sensor="opponents",
                size=OPPONENT_SECTORS, span=(0.0, RANGE_M)),
    Observation("speed_mps", -150.0, 150.0, "m/s", "speed along the car's axis and across it (+ left), UNIT",
                state=("speed_x_mps", "speed_y_mps"), span=(-SPEED_SPAN_MPS, SPEED_SPAN_MPS)),
    Observation("track_edges_m", OFF_TRACK, RANGE_M, "m", "range finders from the car's centre to the track edges, "
                "UNIT, at `track_sensor_angles_deg` (SCR's default: -90, -75, -60, -45, -30, -20, -15, -10, -5, 0, 5, "
                f"... 90; negative to the left); {RANGE_M:g} beyond range; all {OFF_TRACK:g} with the car's centre off "
                "the track", sensor="edges", size=len(SCR_TRACK_ANGLES_DEG), span=(0.0, RANGE_M)),
    Observation("track_pos", -50.0, 50.0, "", "offset from the track axis as a fraction of the half width: +1 the "
                "left edge, -1 the right", compute=track_pos, span=(-2.0, 2.0)),
    Observation("wheel_spin_radps", -2_000.0, 2_000.0, "rad/s", "wheel spin, UNIT: front right, front left, rear "
                "right, rear left", state=("spin_fr_rps", "spin_fl_rps", "spin_rr_rps", "spin_rl_rps"),
                span=(-SPIN_SPAN_RADPS, SPIN_SPAN_RADPS)),
)}


def docs_table() -> str:
    """docs/gym.md's table of the observations (a test holds the docs to it)."""
    rows = ["| key | size | unit and meaning | scaled to [-1, 1] from |", "|---|---|---|---|"]
    rows += [f"| `{o.name}` | {len(o.state) or o.size} | {o.meaning()} | {o.span_text()} |"
             for o in OBSERVATIONS.values()]
    return "\n".join(rows) + "\n"


# action name: (low, high)
ACTION_RANGES: dict[str, tuple[float, float]] = {
    "steer": (-1.0, 1.0),  # + left; 1 = full steering lock
    "throttle": (0.0, 1.0),
    "brake": (0.0, 1.0),
    "gear": (-1.0, 6.0),  # rounded to the nearest gear; the high end is the car's top gear
    "clutch": (0.0, 1.0),  # 1 = fully disengaged
    "pit": (0.0, 1.0),  # >= 0.5: make a pit stop at the next pit entry (the env drives it)
    "pedal": (-1.0, 1.0),  # throttle and brake in one: + throttle, - brake (`pedal_split`)
}
DEFAULT_ACTIONS = ("steer", "pedal")
PEDALS = ("throttle", "brake")  # what the one pedal column stands for (not given with it)


def pedal_split(pedal: float) -> tuple[float, float]:
    """(throttle, brake) of one pedal column: above 0 throttle, below 0 brake, never both (a random
    policy on two columns presses both half the time and stays on the grid)."""
    return (pedal, 0.0) if pedal > 0.0 else (0.0, -pedal)


@dataclass(frozen=True)
class ObservationLayout:
    """Where each field sits in the flat vector (fields sorted by name, as gymnasium flattens)."""

    sizes: dict[str, int]

    @classmethod
    def make(cls, n_track_sensors: int) -> ObservationLayout:
        return cls({o.name: n_track_sensors if o.sensor == "edges" else len(o.state) or o.size
                    for o in OBSERVATIONS.values()})

    @property
    def slices(self) -> dict[str, slice]:
        out, at = {}, 0
        for name in sorted(self.sizes):
            out[name] = slice(at, at + self.sizes[name])
            at += self.sizes[name]
        return out

    @property
    def size(self) -> int:
        return sum(self.sizes.values())

    def index(self, name: str) -> int:
        return self.slices[name].start

    def dict_space(self, scaled: bool = False) -> spaces.Dict:
        """The observations in their units, or `scaled` (each in [-1, 1])."""
        def box(o: Observation) -> spaces.Box:
            low, high = (-SCALED_BOUND, SCALED_BOUND) if scaled else (o.low, o.high)
            return spaces.Box(low, high, shape=(self.sizes[o.name],), dtype=np.float32)
        return spaces.Dict({name: box(OBSERVATIONS[name]) for name in sorted(self.sizes)})

    def flat_space(self, scaled: bool = False) -> spaces.Box:
        return spaces.flatten_space(self.dict_space(scaled))  # type: ignore[return-value]

    def space(self, flat: bool, scaled: bool) -> spaces.Space:
        return self.flat_space(scaled) if flat else self.dict_space(scaled)


class Scaler:
    """The raw vector scaled to [-1, 1]: each number from the range it takes in the race
    (`Observation.span`, some from the race's track and car), clipped."""

    def __init__(self, layout: ObservationLayout) -> None:
        self.layout = layout
        self.race: RaceScale | None = None
        self.factor = np.ones(layout.size, dtype=np.float32)
        self.offset = np.zeros(layout.size, dtype=np.float32)

    def use(self, race: RaceScale) -> None:
        """Scale for this race (recomputed only when the track, car or laps change)."""
        if race == self.race:
            return
        for name, sl in self.layout.slices.items():
            low, high = OBSERVATIONS[name].span_in(race)
            half = 0.5 * (high - low) if high > low else 1.0
            self.factor[sl] = 1.0 / half
            self.offset[sl] = -(low + half) / half
        self.race = race

    def scaled(self, raw: np.ndarray) -> np.ndarray:
        out = raw * self.factor
        out += self.offset
        np.minimum(out, SCALED_BOUND, out=out)
        return np.maximum(out, -SCALED_BOUND, out=out)


class Observer:
    """Builds one step's observation as a fresh float32 vector (and, for the Dict form, its views),
    each number where OBSERVATIONS and the layout put it: in its units (`vector`), and as the
    learner sees it (`observation`: scaled to [-1, 1] unless `scaled` is off)."""

    def __init__(self, layout: ObservationLayout, flat: bool, scaled: bool = True) -> None:
        self.layout, self.flat = layout, flat
        sl = layout.slices
        self.size = layout.size
        read = [o for o in OBSERVATIONS.values() if o.state]
        computed = [o for o in OBSERVATIONS.values() if o.compute is not None]
        self.read_state = operator.attrgetter(*(f for o in read for f in o.state))  # one call for every field
        self.computes = tuple(o.compute for o in computed if o.compute is not None)
        self.scalar_at = np.array([i for o in read for i in range(sl[o.name].start, sl[o.name].stop)] +
                                  [sl[o.name].start for o in computed])
        sensors = {o.sensor: sl[o.name] for o in OBSERVATIONS.values() if o.sensor}
        self.edges, self.opponents = sensors["edges"], sensors["opponents"]
        self.lap_at = sl["lap"].start
        self.items = list(sl.items())
        space = layout.flat_space()
        self.low, self.high = space.low, space.high
        self.scaler = Scaler(layout) if scaled else None

    def vector(self, s: State, edges: np.ndarray, opponents: np.ndarray, laps_added: float = 0.0) -> np.ndarray:
        """The observation in its units; `laps_added` to TORCS's lap (a start along the lap: gym/start.py)."""
        out = np.empty(self.size, dtype=np.float32)
        out[self.scalar_at] = self.read_state(s) + tuple([compute(s) for compute in self.computes])
        out[self.lap_at] += laps_added
        out[self.edges] = edges
        out[self.opponents] = opponents
        np.minimum(out, self.high, out=out)  # np.clip's wrapper costs 3 us more a step than the two ufuncs
        return np.maximum(out, self.low, out=out)

    def observation(self, raw: np.ndarray) -> np.ndarray | dict[str, np.ndarray]:
        """The learner's observation of the raw vector (scaled with the race's `use`d ranges)."""
        return self.shaped(raw if self.scaler is None else self.scaler.scaled(raw))

    def shaped(self, vector: np.ndarray) -> np.ndarray | dict[str, np.ndarray]:
        """The vector as the env's observations come: flat, or a Dict of views."""
        if self.flat:
            return vector
        return {name: vector[sl] for name, sl in self.items}

    def use(self, race: RaceScale) -> None:
        if self.scaler is not None:
            self.scaler.use(race)


def action_space(names: tuple[str, ...], top_gear: int = 6) -> spaces.Box:
    low = [ACTION_RANGES[n][0] for n in names]
    high = [float(top_gear) if n == "gear" else ACTION_RANGES[n][1] for n in names]
    return spaces.Box(np.array(low, dtype=np.float32), np.array(high, dtype=np.float32), dtype=np.float32)


class ActionReader:
    """An action (one row of the action Box) as the drive step's numbers: out-of-range values are
    clipped to the range and NaN reads as 0 (clipped), so no action can make a fault.  An action of
    another shape, or of things that are not numbers, is refused (UsageError, also a ValueError)."""

    def __init__(self, names: tuple[str, ...]) -> None:
        self.columns = [(i, name, *ACTION_RANGES[name]) for i, name in enumerate(names)]
        self.shape = (len(names),)
        self.names = names

    def hint(self) -> str:
        return (f"give {len(self.names)} numbers, shape {self.shape} ({', '.join(self.names)}), "
                "e.g. env.action_space.sample()")

    def read(self, action) -> tuple[float, float, float, float, int, bool]:
        """(steer, throttle, brake, clutch, gear, pit); gear 1 and the rest 0 when not actions."""
        try:
            array = np.asarray(action, dtype=np.float64)
        except (ValueError, TypeError, OverflowError):
            raise UsageError(f"the action {action!r:.60} is not numbers; {self.hint()}") from None
        if array.shape != self.shape:
            raise UsageError(f"the action has shape {array.shape}; {self.hint()}")
        values = array.tolist()
        out = {}
        for i, name, lo, hi in self.columns:
            v = values[i]
            if v != v:
                v = 0.0
            out[name] = lo if v < lo else (hi if v > hi else v)
        gear = int(round(out["gear"])) if "gear" in out else 1
        throttle, brake = pedal_split(out["pedal"]) if "pedal" in out else (out.get("throttle", 0.0),
                                                                             out.get("brake", 0.0))
        return out.get("steer", 0.0), throttle, brake, out.get("clutch", 0.0), gear, out.get("pit", 0.0) >= 0.5
