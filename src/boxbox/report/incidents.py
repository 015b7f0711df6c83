"""A race's incidents, found in its recording (RUN_DIR/recording.parquet) and its result.

From the recording (every car, 10 times a simulated second): every damage jump (who took it and
the cars within a car's length then), off-track spells, spins, passes (two cars swapping places
for good), pit stops; from the result: the robot fault that stopped the race, a race stopped
otherwise (Ctrl-C, a stall), and each pit stop a Python car asked for and did not make.  Each is
listed with the time, the lap, the place on the track (distance from the start line) and the cars
involved (TORCS car indices, the one it happened to first).  `Frames` holds the recording as one
row per sample and one column per car, which the replay viewer embeds too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from boxbox.report.damage import MERGE_S, damage_rises

NEAR_SLACK_M = 1.0  # "within a car's length": centres at most the longer car's length plus this apart
OFF_MERGE_S = 1.0  # off-track moments this close are one spell
OFF_MIN_S = 0.2  # a spell shorter than this (two samples) is not listed
SPIN_RAD = math.pi / 2  # a car turned further than this from the track's direction has spun
SPIN_MERGE_S = 3.0
PASS_HOLD_S = 2.0  # a swap of places counts when the new order holds this long
STOP_GAP_S = 1.0  # a Python car's drive steps stop for longer than this in the pit lane: standing in its box

KINDS = ("contact", "damage", "off-track", "spin", "pass", "pit-stop", "missed-stop", "fault", "stopped")


@dataclass(frozen=True)
class RaceIncident:
    kind: str  # one of KINDS
    time_s: float  # simulated time it began
    lap: int  # the lap of the first car in `cars` then (TORCS's count)
    dist_m: float  # where on the track: that car's distance from the start line (NaN: not known)
    cars: tuple[int, ...]  # TORCS car indices, the car it happened to (or the one passing) first
    damage: int = 0  # damage points taken (damage, contact)
    duration_s: float = 0.0  # how long it lasted (spells, stops)
    detail: str = ""  # more, in words (without the cars' names)

    def to_json(self) -> dict:
        return {"kind": self.kind, "time_s": round(self.time_s, 2), "lap": self.lap,
                "dist_m": None if math.isnan(self.dist_m) else round(self.dist_m, 1), "cars": list(self.cars),
                "damage": self.damage, "duration_s": round(self.duration_s, 2), "detail": self.detail}


@dataclass
class Frames:
    """The recording as a grid: `times` (S samples) and per column an (S, C) array, NaN where a car
    was not seen at a sample; `cars` are the TORCS car indices of the C columns."""

    times: np.ndarray
    cars: list[int]
    cols: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def from_columns(cls, c: dict[str, np.ndarray]) -> Frames:
        times, sample = np.unique(np.asarray(c["time_s"], dtype=float), return_inverse=True)
        cars = sorted(int(x) for x in np.unique(c["car"]))
        col = np.searchsorted(cars, np.asarray(c["car"], dtype=int))
        grid = {}
        for name, values in c.items():
            if name in ("car", "time_s"):
                continue
            a = np.full((len(times), len(cars)), np.nan)
            a[sample, col] = np.asarray(values, dtype=float)
            grid[name] = a
        return cls(times=times, cars=cars, cols=grid)

    def seen(self) -> np.ndarray:
        return np.isfinite(self.cols["lap"])

    def flag(self, name: str) -> np.ndarray:
        """A boolean column, False where the car was not seen."""
        return np.nan_to_num(self.cols[name]) > 0.5

    def at(self, name: str, s: int, k: int) -> float:
        return float(self.cols[name][s, k])


def _runs(mask: np.ndarray, times: np.ndarray, merge_s: float) -> list[tuple[int, int]]:
    """(first, last) sample of each run of True, runs less than merge_s apart joined."""
    idx = np.flatnonzero(mask)
    if not len(idx):
        return []
    runs, start = [], idx[0]
    for a, b in zip(idx[:-1], idx[1:], strict=True):
        if times[b] - times[a] > merge_s + 1e-9:
            runs.append((int(start), int(a)))
            start = b
    runs.append((int(start), int(idx[-1])))
    return runs


def _lap(f: Frames, s: int, k: int) -> int:
    v = f.at("lap", s, k)
    return int(v) if math.isfinite(v) else 0


def _near_cars(f: Frames, s: int, k: int, lengths: dict[int, float]) -> list[int]:
    """The cars whose centre was within a car's length of car column k's at sample s or the one before."""
    near = []
    for j, car in enumerate(f.cars):
        if j == k:
            continue
        reach = max(lengths.get(car, 4.5), lengths.get(f.cars[k], 4.5)) + NEAR_SLACK_M
        gaps = [math.hypot(f.at("x_m", t, j) - f.at("x_m", t, k), f.at("y_m", t, j) - f.at("y_m", t, k))
                for t in (s - 1, s) if t >= 0]
        if any(g <= reach for g in gaps):
            near.append(car)
    return near


def damage_incidents(f: Frames, lengths: dict[int, float]) -> list[RaceIncident]:
    """Every jump of a car's damage (rises under MERGE_S apart are one): a contact when other cars
    were within a car's length, else damage (a barrier, a kerb, the car's own landing)."""
    out = []
    for k, car in enumerate(f.cars):
        for rise in damage_rises(f.times, f.cols["damage"][:, k], MERGE_S):
            first, last, taken = rise.first, rise.last, rise.damage
            near = _near_cars(f, first, k, lengths)
            speed = f.at("speed_mps", first, k) * 3.6
            out.append(RaceIncident("contact" if near else "damage", float(f.times[first]), _lap(f, first, k),
                                f.at("dist_m", first, k), (car, *near), damage=taken,
                                duration_s=float(f.times[last] - f.times[first]), detail=f"at {speed:.0f} km/h"))
    return out


def off_track_incidents(f: Frames) -> list[RaceIncident]:
    """Each spell with the car's centre beyond a track edge (the pit lane excepted)."""
    out = []
    off = f.flag("off_track") & ~f.flag("out")
    for k, car in enumerate(f.cars):
        for first, last in _runs(off[:, k], f.times, OFF_MERGE_S):
            length = float(f.times[last] - f.times[first])
            if length + 1e-9 < OFF_MIN_S:
                continue
            side = "left" if f.at("to_middle_m", first, k) > 0 else "right"
            out.append(RaceIncident("off-track", float(f.times[first]), _lap(f, first, k), f.at("dist_m", first, k),
                                (car,), duration_s=length, detail=f"off the {side} edge for {length:.1f} s"))
    return out


def spin_incidents(f: Frames) -> list[RaceIncident]:
    """Each spell with a car turned more than SPIN_RAD from the track's direction (outside the pit)."""
    out = []
    heading = np.abs(np.nan_to_num(f.cols["heading_to_track_rad"]))
    spun = (heading > SPIN_RAD) & ~f.flag("in_pit") & ~f.flag("in_pit_lane") & ~f.flag("out")
    for k, car in enumerate(f.cars):
        for first, last in _runs(spun[:, k], f.times, SPIN_MERGE_S):
            worst = float(np.degrees(heading[first:last + 1, k].max()))
            out.append(RaceIncident("spin", float(f.times[first]), _lap(f, first, k), f.at("dist_m", first, k), (car,),
                                duration_s=float(f.times[last] - f.times[first]),
                                detail=f"turned up to {worst:.0f} deg from the track's direction"))
    return out


def _held_swaps(rel: np.ndarray, times: np.ndarray) -> list[int]:
    """Samples where the held order of two cars (rel: +1 / -1, 0 not known) changes for good: the
    new order lasts PASS_HOLD_S (or to the end of the recording)."""
    known = np.flatnonzero(rel != 0)
    if not len(known):
        return []
    r, t = rel[known], times[known]
    change = np.flatnonzero(r[1:] != r[:-1]) + 1
    held, out = r[0], []
    for n, i in enumerate(change):
        until = t[change[n + 1]] if n + 1 < len(change) else math.inf
        if r[i] != held and until - t[i] >= PASS_HOLD_S:
            out.append(int(known[i]))
            held = r[i]
    return out


def pass_incidents(f: Frames) -> list[RaceIncident]:
    """Two cars swapping places in the race for good (the car now ahead first); a car out of the
    race is not passed, a car in the pit lane is (said so)."""
    place = f.cols["place"]
    out_ = f.flag("out")
    pit = f.flag("in_pit") | f.flag("in_pit_lane")
    found = []
    for a in range(len(f.cars)):
        for b in range(a + 1, len(f.cars)):
            live = np.isfinite(place[:, a]) & np.isfinite(place[:, b]) & ~out_[:, a] & ~out_[:, b]
            rel = np.where(live, np.sign(np.nan_to_num(place[:, b] - place[:, a])), 0.0)  # +1: a ahead
            for s in _held_swaps(rel, f.times):
                ahead, behind = (a, b) if rel[s] > 0 else (b, a)
                note = " (in the pit lane)" if pit[s, behind] or pit[s, ahead] else ""
                found.append(RaceIncident("pass", float(f.times[s]), _lap(f, s, ahead), f.at("dist_m", s, ahead),
                                      (f.cars[ahead], f.cars[behind]),
                                      detail=f"for place {int(place[s, ahead])}{note}"))
    return found


def pit_stop_incidents(f: Frames) -> list[RaceIncident]:
    """Each stop in a pit box: the race engine holding the car (seen by a Python car), or a Python
    car's own drive steps pausing in the pit lane (TORCS does not drive a car it holds)."""
    out = []
    held = f.flag("in_pit")
    for k, car in enumerate(f.cars):
        spells = _runs(held[:, k], f.times, STOP_GAP_S)
        seen = np.flatnonzero(f.seen()[:, k])
        gaps = np.flatnonzero(np.diff(f.times[seen]) > STOP_GAP_S) if len(seen) > 1 else np.zeros(0, int)
        for g in gaps:
            s0, s1 = int(seen[g]), int(seen[g + 1])
            if f.flag("in_pit_lane")[s0, k] and not held[s0:s1 + 1, k].any():
                spells.append((s0, s1))
        for first, last in spells:
            stand = float(f.times[last] - f.times[first])
            out.append(RaceIncident("pit-stop", float(f.times[first]), _lap(f, first, k), f.at("dist_m", first, k),
                                (car,), duration_s=stand, detail=f"standing about {stand:.1f} s"))
    return out


def _python_car(meta: dict, result: dict, robot_index: int) -> int | None:
    """The TORCS car index of the Python car with this robot index."""
    for p in meta.get("python", []):
        if int(p.get("robot_index", -1)) == robot_index:
            return int(p["car"])
    for d in result.get("drivers", []):
        if d.get("module") == "boxbox" and int(d.get("idx", -1)) == robot_index and d.get("car_index", -1) >= 0:
            return int(d["car_index"])
    return None


def _where(f: Frames, car: int | None, time_s: float) -> tuple[int, float, int]:
    """(sample, distance from the start line, lap) of a car at a time: its last sample up to then."""
    s = max(0, int(np.searchsorted(f.times, time_s, side="right")) - 1)
    if car is None or car not in f.cars:
        return s, math.nan, 0
    k = f.cars.index(car)
    seen = np.flatnonzero(f.seen()[: s + 1, k])
    s = int(seen[-1]) if len(seen) else s
    return s, f.at("dist_m", s, k), _lap(f, s, k)


def _missed_stop_time(f: Frames, car: int, lap: int, pit: dict | None) -> float:
    """When the car passed its pit on that lap: its first sample of the lap in the pit zone (from
    pit entry to exit), else the first of the lap, else the end."""
    if car not in f.cars:
        return float(f.times[-1])
    k = f.cars.index(car)
    on_lap = np.flatnonzero(f.cols["lap"][:, k] == lap)
    if not len(on_lap):
        return float(f.times[-1])
    if pit:
        d = f.cols["dist_m"][on_lap, k]
        entry, exit_ = float(pit["entry_m"]), float(pit["exit_m"])
        zone = (d >= entry) & (d <= exit_) if entry <= exit_ else (d >= entry) | (d <= exit_)
        if zone.any():
            return float(f.times[on_lap[np.argmax(zone)]])
    return float(f.times[on_lap[0]])


def result_incidents(f: Frames, meta: dict, result: dict, fault: dict | None) -> list[RaceIncident]:
    """What the result says: the fault or other end that stopped the race, and missed pit stops."""
    out = []
    pit = (meta.get("track") or {}).get("pit")
    for d in result.get("drivers", []):
        car = d.get("car_index", -1)
        if car is None or car < 0:
            car = _python_car(meta, result, int(d.get("idx", -1))) if d.get("module") == "boxbox" else None
        for miss in d.get("missed_pit_stops") or []:
            if car is None:
                continue
            t = _missed_stop_time(f, int(car), int(miss.get("lap", 0)), pit)
            _, dist, _ = _where(f, int(car), t)
            out.append(RaceIncident("missed-stop", t, int(miss.get("lap", 0)), dist, (int(car),),
                                detail=f"{miss.get('reason', '')}: {miss.get('detail', '')}"))
    error = (result.get("error") or "").strip()
    if fault:
        car = _python_car(meta, result, int(fault.get("robot_index", -1)))
        t = min(float(fault.get("sim_time_s") or f.times[-1]), float(f.times[-1]))
        _, dist, lap = _where(f, car, t)
        out.append(RaceIncident("fault", t, lap, dist, () if car is None else (car,),
                            detail=str(fault.get("message", "")).splitlines()[0] if fault.get("message") else ""))
    elif error:
        out.append(RaceIncident("stopped", float(f.times[-1]), 0, math.nan, (), detail=error.splitlines()[0]))
    return out


def find_incidents(columns: dict[str, np.ndarray], meta: dict, result: dict | None = None,
                   fault: dict | None = None) -> list[RaceIncident]:
    """Every incident of a recorded race, in time order (columns and meta: a recording's;
    result: result.json's content; fault: fault.json's)."""
    if not len(columns.get("time_s", ())):
        return []
    f = Frames.from_columns(columns)
    lengths = {int(k): float(v.get("length_m", 4.5)) for k, v in meta.get("cars", {}).items()}
    found = (damage_incidents(f, lengths) + off_track_incidents(f) + spin_incidents(f) + pass_incidents(f)
             + pit_stop_incidents(f) + result_incidents(f, meta, result or {}, fault))
    return sorted(found, key=lambda i: (i.time_s, KINDS.index(i.kind)))


def describe(i: RaceIncident, names: dict[int, str]) -> str:
    """The incident in words, with the cars' names (names: TORCS car index -> name)."""
    who = [names.get(c, f"car {c}") for c in i.cars]
    first = who[0] if who else "the race"
    if i.kind == "contact":
        return f"{first} took {i.damage} damage {i.detail}, {' and '.join(who[1:])} within a car's length"
    if i.kind == "damage":
        return f"{first} took {i.damage} damage {i.detail}, no car within a car's length"
    if i.kind == "pass":
        return f"{first} passed {who[1]} {i.detail}"
    if i.kind == "spin":
        return f"{first} spun: {i.detail}"
    if i.kind == "pit-stop":
        return f"{first} stopped in its pit, {i.detail}"
    if i.kind == "missed-stop":
        return f"{first} asked for a pit stop and did not make it: {i.detail}"
    if i.kind == "fault":
        return f"{first}: the robot's fault stopped the race: {i.detail}"
    if i.kind == "stopped":
        return f"the race stopped: {i.detail}"
    return f"{first} {i.detail}"
