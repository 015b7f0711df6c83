"""The env's observation and action spaces, every field with its unit.

Observations are a `Dict` of float32 `Box`es (`OBSERVATION_FIELDS`), or the same numbers as one
flat `Box` in the order `gymnasium.spaces.flatten` gives the `Dict` (its keys sorted by name).
Actions are one `Box`, its columns named by the env's `actions` option (`ACTION_RANGES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from boxbox.errors import UsageError
from boxbox.gym.sensors import OFF_TRACK, OPPONENT_SECTORS, RANGE_M
from boxbox.model import State

RADPS_TO_RPM = 60.0 / (2.0 * math.pi)

# name: (low, high, what it is); sizes other than 1 are given in `layout`.  The bounds are finite
# (learners scale by them) and generous; a value beyond them is clipped.
OBSERVATION_FIELDS: dict[str, tuple[float, float, str]] = {
    "angle_rad": (-math.pi, math.pi, "the track axis's direction minus the car's heading (+: track to the left)"),
    "damage": (0.0, 20_000.0, "TORCS's damage points (the car is out at 10000)"),
    "dist_from_start_m": (0.0, 100_000.0, "distance along the track from the start line"),
    "engine_rpm": (0.0, 30_000.0, "engine speed, revolutions per minute"),
    "fuel_l": (0.0, 1_000.0, "fuel in the tank, litres"),
    "gear": (-1.0, 10.0, "gear engaged: -1 reverse, 0 neutral, 1.. forward"),
    "lap": (0.0, 1_000.0, "the lap being driven (TORCS counts 0 before the first crossing of the line)"),
    "opponents_m": (0.0, RANGE_M, "nearest opponent per 10-degree sector, clockwise from straight behind"),
    "speed_mps": (-150.0, 150.0, "speed along the car's axis and across it (+ left), m/s"),
    "track_edges_m": (OFF_TRACK, RANGE_M, "range finders to the track edges at the sensor angles; -1 off the track"),
    "track_pos": (-50.0, 50.0, "offset from the track axis as a fraction of the half width: +1 left edge, -1 right"),
    "wheel_spin_radps": (-2_000.0, 2_000.0, "wheel spin, rad/s: front right, front left, rear right, rear left"),
}

# action name: (low, high)
ACTION_RANGES: dict[str, tuple[float, float]] = {
    "steer": (-1.0, 1.0),  # + left; 1 = full steering lock
    "throttle": (0.0, 1.0),
    "brake": (0.0, 1.0),
    "gear": (-1.0, 6.0),  # rounded to the nearest gear; the high end is the car's top gear
    "clutch": (0.0, 1.0),  # 1 = fully disengaged
    "pit": (0.0, 1.0),  # >= 0.5: make a pit stop at the next pit entry (the env drives it)
}
DEFAULT_ACTIONS = ("steer", "throttle", "brake")
SCALAR_FIELDS = ("angle_rad", "damage", "dist_from_start_m", "engine_rpm", "fuel_l", "gear", "lap", "track_pos")


@dataclass(frozen=True)
class ObservationLayout:
    """Where each field sits in the flat vector (fields sorted by name, as gymnasium flattens)."""

    sizes: dict[str, int]

    @classmethod
    def make(cls, n_track_sensors: int) -> ObservationLayout:
        sizes = {name: 1 for name in OBSERVATION_FIELDS}
        sizes.update(opponents_m=OPPONENT_SECTORS, speed_mps=2, track_edges_m=n_track_sensors, wheel_spin_radps=4)
        return cls(sizes)

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

    def dict_space(self) -> spaces.Dict:
        return spaces.Dict({name: spaces.Box(OBSERVATION_FIELDS[name][0], OBSERVATION_FIELDS[name][1],
                                             shape=(self.sizes[name],), dtype=np.float32)
                            for name in sorted(self.sizes)})

    def flat_space(self) -> spaces.Box:
        return spaces.flatten_space(self.dict_space())  # type: ignore[return-value]


class Observer:
    """Builds one step's observation as a fresh float32 vector (and, for the Dict form, its views)."""

    def __init__(self, layout: ObservationLayout, flat: bool) -> None:
        self.layout, self.flat = layout, flat
        sl = layout.slices
        self.size = layout.size
        self.scalar_at = np.array([sl[name].start for name in SCALAR_FIELDS] + [sl["speed_mps"].start,
                                  sl["speed_mps"].start + 1] + list(range(sl["wheel_spin_radps"].start,
                                                                          sl["wheel_spin_radps"].stop)))
        self.edges = sl["track_edges_m"]
        self.opponents = sl["opponents_m"]
        self.items = list(sl.items())
        space = layout.flat_space()
        self.low, self.high = space.low, space.high

    def vector(self, s: State, edges: np.ndarray, opponents: np.ndarray) -> np.ndarray:
        width = s.to_left_m + s.to_right_m
        track_pos = s.to_middle_m / (0.5 * width) if width > 0.0 else 0.0
        out = np.empty(self.size, dtype=np.float32)
        out[self.scalar_at] = (s.angle_rad, s.damage, s.dist_from_start_m, s.rpm * RADPS_TO_RPM, s.fuel_l, s.gear,
                               s.laps, track_pos, s.speed_x_mps, s.speed_y_mps,
                               s.spin_fr_rps, s.spin_fl_rps, s.spin_rr_rps, s.spin_rl_rps)
        out[self.edges] = edges
        out[self.opponents] = opponents
        np.minimum(out, self.high, out=out)  # np.clip's wrapper costs 3 us more a step than the two ufuncs
        return np.maximum(out, self.low, out=out)

    def observation(self, vector: np.ndarray) -> np.ndarray | dict[str, np.ndarray]:
        if self.flat:
            return vector
        return {name: vector[sl] for name, sl in self.items}


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
        return (out.get("steer", 0.0), out.get("throttle", 0.0), out.get("brake", 0.0), out.get("clutch", 0.0),
                gear, out.get("pit", 0.0) >= 0.5)
