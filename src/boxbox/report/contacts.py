"""Why a car took its damage: each damage incident of one car put down to a cause (issue #51).

From the car's damage series (telemetry: every drive step) and the race recording (every car, 10
times a simulated second): each rise of the damage count (rises under MERGE_S apart are one
incident) gets the other car involved (the nearest whose centre was within a car's length on the
map, one whose own damage rose then first), where it was in our car's frame (ahead, behind, or
alongside), the speed we closed on it at, whether one of the two was lapping the other, and whether
either changed line in the BEFORE_S before: moved towards the other by more than LINE_CHANGE_M off
the line that car usually drives there (its median offset from the track's middle over the race,
per LINE_BIN_M of track).  Damage with no car near is the wall or the road, or the end of a contact
just before (AFTER_S), with or without a car within NEAR_M.

`cause` sorts an incident into one of CAUSES; `NOT_AVOIDABLE` are those that nothing but not being
there avoids (hit from behind on our own line).  Pure functions over plain arrays: `load_race` reads
a run dir, the `boxbox contacts` command prints the table over many.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from boxbox.report.damage import MERGE_S, damage_rises
from boxbox.report.incidents import Frames

REACH_SLACK_M = 1.0  # "within a car's length": centres at most the longer car's length plus this apart
ALONG_MAX_M = 20.0  # and no further apart along the track (a car across a hairpin is not in the contact)
BEFORE_S = 1.0  # a change of line is judged over this long before the first hit
LINE_CHANGE_M = 0.5  # a move towards the other car this far off the car's usual line is a change of line
SIDE_SHARE = 0.75  # centres closer lengthwise than this share of the two cars' mean length: alongside
AFTER_S = 3.0  # damage with no car near this soon after a contact is that contact's (a spin, the wall)
LINE_BIN_M = 5.0  # the usual line: a car's median offset from the middle per this much track
CLOSING_S = 0.2  # the speeds compared are of this long before the first hit (the hit evens them out)
OTHER_HIT_S = 0.3  # the other car's damage rising this close to our first hit: it was in the contact
NEAR_M = 20.0  # alone with another car's centre within this: perhaps making room for it
LOW_DAMAGE = 300  # issue #51's race "under 300 damage"
# how we hit the car ahead (`ahead_rows`): the car ahead sliding, more than SLIDE_RAD (11.5 degrees)
# off the track's heading (its racing line's own angle is under it), or we in a turn, our sideways
# acceleration TURNING_MPS2 or more at some sample of the BEFORE_S before (about a half of car1-trb1's grip)
SLIDE_RAD = 0.2
TURNING_MPS2 = 8.0
EARLY_SLIDE_S = 0.5  # a slide that began this long before the hit left time to brake

BEHIND_HELD = "hit from behind, our line held"
BEHIND_MOVED = "hit from behind, we changed line"
AHEAD = "we hit the car ahead"
SIDE_IT = "side by side, it changed line"
SIDE_WE = "side by side, we changed line"
SIDE_NEITHER = "side by side, neither changed line"
AFTER = "alone, just after a contact"
ALONE_NEAR = "alone, a car near"
ALONE = "alone, no car near"
CAUSES = (BEHIND_HELD, BEHIND_MOVED, AHEAD, SIDE_IT, SIDE_WE, SIDE_NEITHER, AFTER, ALONE_NEAR, ALONE)
NOT_AVOIDABLE = frozenset({BEHIND_HELD})  # short of not being there
NOT_OURS = frozenset({BEHIND_HELD, SIDE_IT})  # the other car moved into us or hit us from behind


@dataclass(frozen=True)
class Contact:
    """One damage incident of our car."""

    time_s: float  # first hit
    lap: int  # our lap then (TORCS's count: 1 is the first)
    dist_m: float  # our distance from the start line
    damage: int  # points taken in it
    kind: str  # "ahead" (we hit it), "behind" (it hit us), "side" (alongside), "alone" (no car near)
    other: int = -1  # TORCS car index of the other car (-1: none)
    ahead_m: float = math.nan  # its centre ahead of ours, in our car's frame (- behind)
    left_m: float = math.nan  # its centre left of ours, in our car's frame (- right)
    closing_mps: float = math.nan  # our speed less its, CLOSING_S before the first hit
    we_slowed_mps: float = math.nan  # how much our speed fell over the BEFORE_S before the first hit
    lapping: str = ""  # "we lap it", "it laps us" or ""
    we_moved_m: float = math.nan  # our move off our usual line towards it over BEFORE_S (- away)
    it_moved_m: float = math.nan  # its move off its usual line towards us
    other_damage: int = 0  # what the other car took in the same moments
    after: str = ""  # alone: the cause of the contact AFTER_S before, else ""
    nearest_m: float = math.nan  # the nearest other car's centre from ours
    headway_s: float = math.nan  # the bumper gap along the track BEFORE_S before the hit, over our speed then
    turning_mps2: float = math.nan  # our highest sideways acceleration over the BEFORE_S before
    it_slid_s: float = math.nan  # how long the other car had been sliding (SLIDE_RAD) at the hit (0: not)

    @property
    def cause(self) -> str:
        """One of CAUSES."""
        if self.kind == "alone":
            return AFTER if self.after else (ALONE_NEAR if self.nearest_m <= NEAR_M else ALONE)
        we = self.we_moved_m > LINE_CHANGE_M
        if self.kind == "behind":
            return BEHIND_MOVED if we else BEHIND_HELD
        if self.kind == "ahead":
            return AHEAD
        if we:
            return SIDE_WE
        return SIDE_IT if self.it_moved_m > LINE_CHANGE_M else SIDE_NEITHER

    @property
    def root_cause(self) -> str:
        """The cause, or for damage just after a contact the contact's."""
        return self.after or self.cause

    def to_json(self) -> dict:
        out = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in asdict(self).items()}
        return {**out, "cause": self.cause}


def usual_lines(f: Frames, track_length_m: float, bin_m: float = LINE_BIN_M) -> np.ndarray:
    """Per LINE_BIN_M of track (rows) and car (columns), the car's median offset from the middle
    there over the recording (NaN where never seen)."""
    n = max(1, int(math.ceil(track_length_m / bin_m)))
    out = np.full((n, len(f.cars)), np.nan)
    for k in range(len(f.cars)):
        dist, mid = f.cols["dist_m"][:, k], f.cols["to_middle_m"][:, k]
        ok = np.isfinite(dist) & np.isfinite(mid)
        b = (dist[ok] // bin_m).astype(int) % n
        order = np.argsort(b, kind="stable")
        b, m = b[order], mid[ok][order]
        cuts = np.flatnonzero(np.diff(b)) + 1
        for group_b, group_m in zip(np.split(b, cuts), np.split(m, cuts), strict=True):
            if len(group_b):
                out[group_b[0], k] = float(np.median(group_m))
    return out


def at_time(f: Frames, name: str, t: float) -> np.ndarray:
    """Column `name` of every car at time t, linear between the samples either side (NaN where a
    car was not seen at both)."""
    i = int(np.clip(np.searchsorted(f.times, t), 1, len(f.times) - 1))
    t0, t1 = f.times[i - 1], f.times[i]
    w = 0.0 if t1 <= t0 else float(np.clip((t - t0) / (t1 - t0), 0.0, 1.0))
    a = f.cols[name]
    return np.asarray(a[i - 1] * (1.0 - w) + a[i] * w, dtype=float)


def _off_line(f: Frames, lines: np.ndarray, t: float, bin_m: float = LINE_BIN_M) -> np.ndarray:
    """Every car's offset from its usual line at time t (+ left)."""
    dist = np.nan_to_num(at_time(f, "dist_m", t))
    rows = (dist // bin_m).astype(int) % len(lines)
    return at_time(f, "to_middle_m", t) - lines[rows, np.arange(len(f.cars))]


def _wrapped(d: np.ndarray, track_length_m: float) -> np.ndarray:
    return (d + track_length_m / 2.0) % track_length_m - track_length_m / 2.0


def _damage_rise(f: Frames, k: int, t0: float, t1: float) -> float:
    """Car column k's damage rise from just before t0 to t1 (10 Hz samples)."""
    i0 = max(0, int(np.searchsorted(f.times, t0)) - 1)
    i1 = int(np.searchsorted(f.times, t1, side="right"))
    d = f.cols["damage"][i0:i1 + 1, k]
    d = d[np.isfinite(d)]
    return float(d.max() - d[0]) if len(d) else 0.0


def _other_car(f: Frames, us: int, t: float, track_length_m: float, lengths: dict[int, float]) -> int:
    """Column of the car in the contact at t (-1: none within a car's length): of those near at t or
    a sample before, the nearest among those whose own damage rose then, else the nearest."""
    best: tuple[bool, float, int] | None = None
    for when in (t, t - 0.1):
        gap = _gaps(f, us, when, track_length_m)
        for k, car in enumerate(f.cars):
            reach = max(lengths.get(car, 4.5), lengths.get(f.cars[us], 4.5)) + REACH_SLACK_M
            if k == us or not gap[k] <= reach:
                continue
            hit = _damage_rise(f, k, t - OTHER_HIT_S, t + OTHER_HIT_S) > 0.0
            key = (not hit, float(gap[k]), k)
            best = key if best is None or key < best else best
    return -1 if best is None else best[2]


def _gaps(f: Frames, us: int, t: float, track_length_m: float) -> np.ndarray:
    """Every car's centre from ours at time t on the map (m; the track's frame stretches distances
    in a turn); inf for a car further than ALONG_MAX_M along the track (across a hairpin)."""
    x, y = at_time(f, "x_m", t), at_time(f, "y_m", t)
    raced = at_time(f, "dist_raced_m", t)
    along = _wrapped(raced - raced[us], track_length_m)
    return np.where(np.abs(along) <= ALONG_MAX_M, np.hypot(x - x[us], y - y[us]), np.inf)


def _car_frame(f: Frames, us: int, k: int, t: float) -> tuple[float, float]:
    """Car column k's centre from ours at time t in our car's frame: (ahead, left), m."""
    x, y = at_time(f, "x_m", t), at_time(f, "y_m", t)
    yaw = float(f.cols["yaw_rad"][int(np.argmin(np.abs(f.times - t))), us])  # the nearest sample's
    dx, dy = float(x[k] - x[us]), float(y[k] - y[us])
    return dx * math.cos(yaw) + dy * math.sin(yaw), -dx * math.sin(yaw) + dy * math.cos(yaw)


def _nearest_m(f: Frames, us: int, t: float, track_length_m: float) -> float:
    """The nearest other car's centre from ours at time t (inf: none seen)."""
    gap = _gaps(f, us, t, track_length_m)
    gap[us] = np.inf
    return float(np.nan_to_num(gap, nan=np.inf).min())


def _lapping(raced_gap_m: float, track_length_m: float) -> str:
    if raced_gap_m < -track_length_m / 2.0:
        return "we lap it"
    return "it laps us" if raced_gap_m > track_length_m / 2.0 else ""


def classify(f: Frames, us: int, k: int, c: Contact, lines: np.ndarray, track_length_m: float,
              lengths: dict[int, float]) -> Contact:
    """Contact c (its time, place and damage) with the other car's part (column k, ours us): kind,
    where it was, speeds, lapping, who changed line (other_damage left as it is)."""
    t = c.time_s
    raced = at_time(f, "dist_raced_m", t)
    ahead, left = _car_frame(f, us, k, t)
    mean_len = (lengths.get(f.cars[us], 4.5) + lengths.get(f.cars[k], 4.5)) / 2.0
    kind = "side" if abs(ahead) < SIDE_SHARE * mean_len else ("ahead" if ahead > 0 else "behind")
    before = float(at_time(f, "to_middle_m", t - BEFORE_S)[k] - at_time(f, "to_middle_m", t - BEFORE_S)[us])
    now = float(at_time(f, "to_middle_m", t)[k] - at_time(f, "to_middle_m", t)[us])
    side = 1.0 if (before if math.isfinite(before) and before != 0.0 else now) >= 0.0 else -1.0  # where it came from
    moved = (_off_line(f, lines, t) - _off_line(f, lines, t - BEFORE_S)) * side
    speed = at_time(f, "speed_mps", t - CLOSING_S)
    slowed = float(at_time(f, "speed_mps", t - BEFORE_S)[us] - at_time(f, "speed_mps", t)[us])
    lapping = _lapping(float(raced[k] - raced[us]), track_length_m)
    return replace(c, kind=kind, other=f.cars[k], ahead_m=ahead, left_m=left, closing_mps=float(speed[us] - speed[k]),
                   we_slowed_mps=slowed, lapping=lapping, we_moved_m=float(moved[us]), it_moved_m=float(-moved[k]),
                   headway_s=_headway_s(f, us, k, t - BEFORE_S, track_length_m, mean_len),
                   turning_mps2=_turning_mps2(f, us, t), it_slid_s=_slid_s(f, k, t))


def _headway_s(f: Frames, us: int, k: int, t: float, track_length_m: float, mean_len_m: float) -> float:
    """Car column k's bumper gap ahead of ours along the track at time t over our speed then (s)."""
    raced, speed = at_time(f, "dist_raced_m", t), at_time(f, "speed_mps", t)
    gap_m = float(_wrapped(raced[k:k + 1] - raced[us], track_length_m)[0]) - mean_len_m
    return gap_m / float(speed[us]) if float(speed[us]) > 1.0 else math.nan


def _turning_mps2(f: Frames, us: int, t: float) -> float:
    """Our highest sideways acceleration (yaw rate times speed, m/s^2) at the samples of the BEFORE_S before t."""
    i0, i1 = max(1, int(np.searchsorted(f.times, t - BEFORE_S))), int(np.searchsorted(f.times, t, side="right"))
    if i1 <= i0:
        return math.nan
    yaw = np.unwrap(np.nan_to_num(f.cols["yaw_rad"][i0 - 1:i1, us]))
    rate = np.diff(yaw) / np.diff(f.times[i0 - 1:i1])
    return float(np.nanmax(np.abs(rate * f.cols["speed_mps"][i0:i1, us])))


def _slid_s(f: Frames, k: int, t: float) -> float:
    """How long before t car column k had been more than SLIDE_RAD off the track's heading without a
    break (0: not sliding at t; NaN: a recording without the heading)."""
    if "heading_to_track_rad" not in f.cols:
        return math.nan
    i = int(np.clip(np.searchsorted(f.times, t), 0, len(f.times) - 1))
    sliding = np.abs(np.nan_to_num(f.cols["heading_to_track_rad"][:i + 1, k])) > SLIDE_RAD
    if not sliding[-1]:
        return 0.0
    calm = np.flatnonzero(~sliding)
    first = int(calm[-1]) + 1 if len(calm) else 0
    return float(f.times[i] - f.times[first])


def find_contacts(f: Frames, car: int, time_s: np.ndarray, damage: np.ndarray, track_length_m: float,
                  lengths: dict[int, float]) -> list[Contact]:
    """Every damage incident of TORCS car `car` (its damage series: time_s, damage), classified
    against the recording f (lengths: TORCS car index -> car length, m)."""
    if car not in f.cars or not len(f.times) > 1:
        return []
    us = f.cars.index(car)
    lines = usual_lines(f, track_length_m)
    t_all = np.asarray(time_s, dtype=float)
    out: list[Contact] = []
    last_contact: tuple[float, str] | None = None  # (its last hit, its cause)
    for rise in damage_rises(t_all, damage, MERGE_S):
        t, t_end, taken = float(t_all[rise.first]), float(t_all[rise.last]), rise.damage
        alone = Contact(t, int(np.nan_to_num(at_time(f, "lap", t)[us])), float(at_time(f, "dist_m", t)[us]), taken,
                        "alone", nearest_m=_nearest_m(f, us, t, track_length_m))
        k = _other_car(f, us, t, track_length_m, lengths)
        if k < 0:
            out.append(replace(alone, after=last_contact[1] if last_contact and t - last_contact[0] <= AFTER_S else ""))
            continue
        c = replace(classify(f, us, k, alone, lines, track_length_m, lengths),
                    other_damage=int(round(_damage_rise(f, k, t - OTHER_HIT_S, t_end + OTHER_HIT_S))))
        out.append(c)
        last_contact = (t_end, c.root_cause)
    return out


# --- a run dir, and many -----------------------------------------------------------------------
@dataclass
class RaceContacts:
    """One race's contacts of its (first) Python car."""

    run_dir: str
    track: str
    car: int  # TORCS car index of the Python car
    damage: int  # its damage points summed over the incidents
    contacts: list[Contact]

    def to_json(self) -> dict:
        return {"run_dir": self.run_dir, "track": self.track, "car": self.car, "damage": self.damage,
                "contacts": [c.to_json() for c in self.contacts]}


def load_race(run_dir: Path) -> RaceContacts:
    """The contacts of the first Python car of a run dir (recording.parquet, telemetry.parquet for
    its damage step by step when there, result.json for the track's name)."""
    from boxbox.torcs.recording import load_recording

    rec = load_recording(run_dir / "recording.parquet")
    meta = rec.meta
    python = meta.get("python") or []
    if not python:
        raise ValueError(f"{run_dir}: the recording has no Python car")
    car = int(python[0]["car"])
    f = Frames.from_columns(rec.columns)
    series = _damage_series(run_dir, rec.columns, car, int(python[0].get("robot_index", 0)))
    length = float((meta.get("track") or {}).get("length_m") or np.nanmax(rec.columns["dist_m"]))
    lengths = {int(k): float(v.get("length_m", 4.5)) for k, v in (meta.get("cars") or {}).items()}
    contacts = find_contacts(f, car, *series, length, lengths)
    try:
        track = str(json.loads((run_dir / "result.json").read_text()).get("track", ""))
    except (OSError, ValueError):
        track = str((meta.get("track") or {}).get("name", ""))
    return RaceContacts(str(run_dir), track, car, sum(c.damage for c in contacts), contacts)


def _damage_series(run_dir: Path, columns: dict, car: int, robot_index: int) -> tuple[np.ndarray, np.ndarray]:
    """(time_s, damage) of the car: every drive step from the telemetry, else the recording's samples."""
    from boxbox.torcs.telemetry import load_telemetry

    path = run_dir / "telemetry.parquet"
    if path.exists():
        c = load_telemetry(path).car(robot_index)
        if len(c.get("time_s", ())):
            return np.asarray(c["time_s"], dtype=float), np.asarray(c["damage"], dtype=float)
    mine = np.asarray(columns["car"]) == car
    return np.asarray(columns["time_s"], dtype=float)[mine], np.asarray(columns["damage"], dtype=float)[mine]


def bench_run_dirs(bench_json: dict) -> list[Path]:
    """The robot's run dirs of a `bench-field --json` file (one run, or several lengths and repeats)."""
    runs = bench_json.get("runs") or [bench_json]
    return [Path(r["run_dir"]) for run in runs for r in run.get("rows", [])
            if r.get("role") == "robot" and r.get("run_dir") and not r.get("error")]


def cause_rows(races: list[RaceContacts]) -> list[dict]:
    """Per cause (CAUSES; damage just after a contact counted as its own row): incidents, damage,
    its share of all, on lap 1, while lapping or being lapped, the other cars' damage in them, and
    the races of LOW_DAMAGE or more in which it was the largest cause."""
    every = [c for r in races for c in r.contacts]
    total = sum(c.damage for c in every) or 1
    led = {cause: 0 for cause in CAUSES}
    for r in races:
        if r.damage >= LOW_DAMAGE:
            led[max(CAUSES, key=lambda cause: sum(c.damage for c in r.contacts if c.cause == cause))] += 1
    rows = []
    for cause in CAUSES:
        mine = [c for c in every if c.cause == cause]
        dmg = sum(c.damage for c in mine)
        rows.append({"cause": cause, "incidents": len(mine), "damage": dmg, "share": dmg / total,
                     "lap1": sum(c.damage for c in mine if c.lap <= 1),
                     "lapping": sum(c.damage for c in mine if c.lapping),
                     "others_damage": sum(c.other_damage for c in mine), "races_led": led[cause]})
    return rows


AHEAD_HOW = (f"the car ahead sliding, from {EARLY_SLIDE_S} s or more before",
             f"the car ahead sliding, from under {EARLY_SLIDE_S} s before",
             "in a turn, the car ahead not sliding", "on a straight, the car ahead not sliding")


def _how(c: Contact) -> str:
    if c.it_slid_s >= EARLY_SLIDE_S:
        return AHEAD_HOW[0]
    if c.it_slid_s > 0.0:
        return AHEAD_HOW[1]
    return AHEAD_HOW[2] if c.turning_mps2 >= TURNING_MPS2 else AHEAD_HOW[3]


def ahead_rows(races: list[RaceContacts]) -> list[dict]:
    """Our nose into the car ahead, by how (AHEAD_HOW): incidents, damage, on lap 1, and the median
    headway (bumper gap over our speed, BEFORE_S before the hit) and closing speed."""
    mine = [c for r in races for c in r.contacts if c.cause == AHEAD]
    rows = []
    for how in AHEAD_HOW:
        group = [c for c in mine if _how(c) == how]
        headway = [c.headway_s for c in group if math.isfinite(c.headway_s)]
        rows.append({"how": how, "incidents": len(group), "damage": sum(c.damage for c in group),
                     "lap1": sum(c.damage for c in group if c.lap <= 1),
                     "headway_s": float(np.median(headway)) if headway else math.nan,
                     "closing_mps": float(np.median([c.closing_mps for c in group])) if group else math.nan})
    return rows


# what-ifs: the damage left when the incidents a predicate picks are taken away
SCENARIOS: dict[str, str] = {
    "now": "as raced",
    "no lap 1": "without lap 1's damage",
    "no lapping": "without damage taken lapping a car or being lapped",
    "no own hits": "without ours: into the car ahead, we changed line, alone",
    "not ours only": "only: hit from behind on our line, side by side and it changed line",
    "unavoidable only": "only: hit from behind on our line",
}
OWN_HITS = frozenset({AHEAD, SIDE_WE, BEHIND_MOVED, ALONE_NEAR, ALONE})


def _kept(c: Contact, scenario: str) -> bool:
    if scenario == "no lap 1":
        return c.lap > 1
    if scenario == "no lapping":
        return not c.lapping
    if scenario == "no own hits":
        return c.root_cause not in OWN_HITS
    if scenario == "not ours only":
        return c.root_cause in NOT_OURS
    if scenario == "unavoidable only":
        return c.root_cause in NOT_AVOIDABLE
    return True


def scenario_rows(races: list[RaceContacts]) -> list[dict]:
    """Per scenario (SCENARIOS): the damage left in all and the races under LOW_DAMAGE with it."""
    rows = []
    for name, what in SCENARIOS.items():
        left = [sum(c.damage for c in r.contacts if _kept(c, name)) for r in races]
        rows.append({"scenario": name, "what": what, "damage": sum(left),
                     "under_low": sum(d < LOW_DAMAGE for d in left), "races": len(races)})
    return rows
