"""Where a car took its damage: the rises of TORCS's damage count in the telemetry, merged into
incidents (a car rubbing along another or a barrier hits it many times a second)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MERGE_S = 1.0  # hits this close in time are one incident
# the steps' times are sums of floats: two hits MERGE_S apart may read a hair more (1.0000000002 s)
MERGE_ROUNDING_S = 1e-9
NEAR_M = 15.0  # another car this close (centre to centre) at the first hit is named as the nearest
MOVED_S = 0.5  # who moved over towards the other is judged over this long before the first hit


@dataclass(frozen=True)
class DamageIncident:
    """One incident: the hits from time_s on, none more than MERGE_S after the one before."""

    lap: int  # the lap it began on (0: before the start line)
    dist_m: float  # distance from the start line at the first hit (m)
    time_s: float  # race time at the first hit (s)
    damage: int  # damage points taken in it (TORCS's count; 10,000 puts a car out)
    speed_mps: float  # our speed at the first hit (m/s; < 0 reversing)
    hits: int  # steps on which the count rose
    x_m: float  # where the first hit was, for the map (m)
    y_m: float
    # the nearest other car at the first hit (telemetry near_*): its TORCS car index (-1: none, or a
    # file written before the column), and its centre ahead of ours and to our left, in our car's frame (m)
    near_car: int = -1
    near_ahead_m: float = float("nan")
    near_left_m: float = float("nan")
    # sideways moves towards each other over the MOVED_S before the first hit, across the road (m, +
    # towards the other car; NaN: not known, e.g. another car was nearest then): ours from our
    # to_middle, its from ours plus where it was to our left (our car's frame: near enough across the
    # road while both point along it)
    we_moved_in_m: float = float("nan")
    it_moved_in_m: float = float("nan")

    @property
    def near_m(self) -> float:
        """Centre-to-centre distance to the nearest other car (m; NaN: none known)."""
        return float(np.hypot(self.near_ahead_m, self.near_left_m))


def damage_incidents(c: dict[str, np.ndarray], merge_s: float = MERGE_S) -> list[DamageIncident]:
    """The incidents of one car's telemetry `c` (columns time_s, lap, dist_m, speed_mps, damage,
    x_m, y_m, one row per step; near_car, near_ahead_m, near_left_m when recorded).  A fall of the
    count (a repair in the pits) is not a hit."""
    if not merge_s >= 0.0:
        raise ValueError(f"merge_s must be a number of seconds >= 0, not {merge_s!r}")
    need = ("time_s", "lap", "dist_m", "speed_mps", "damage", "x_m", "y_m")
    missing = [k for k in need if k not in c]
    if missing:
        raise ValueError(f"telemetry lacks the column(s) {', '.join(missing)}")
    t = np.asarray(c["time_s"], dtype=float)
    n = len(t)
    near = np.asarray(c.get("near_car", np.full(n, -1)), dtype=int)
    ahead = np.asarray(c.get("near_ahead_m", np.full(n, np.nan)), dtype=float)
    left = np.asarray(c.get("near_left_m", np.full(n, np.nan)), dtype=float)
    mid = np.asarray(c.get("to_middle_m", np.full(n, np.nan)), dtype=float)
    return [DamageIncident(lap=int(c["lap"][r.first]), dist_m=float(c["dist_m"][r.first]), time_s=float(t[r.first]),
                     damage=r.damage, speed_mps=float(c["speed_mps"][r.first]), hits=r.hits,
                     x_m=float(c["x_m"][r.first]), y_m=float(c["y_m"][r.first]), near_car=int(near[r.first]),
                     near_ahead_m=float(ahead[r.first]), near_left_m=float(left[r.first]),
                     **_moved_in(t, r.first, near, left, mid))
            for r in damage_rises(t, c["damage"], merge_s)]


@dataclass(frozen=True)
class DamageRise:
    """The rises of a damage count merged into one incident: rows `first` to `last` (the first and
    the last hit), `hits` rows on which the count rose, `damage` points taken in all."""

    first: int
    last: int
    hits: int
    damage: int


def damage_rises(time_s: np.ndarray, damage: np.ndarray, merge_s: float = MERGE_S) -> list[DamageRise]:
    """The incidents of a damage series (time_s, damage per row): each rise of the count is a hit,
    hits under merge_s apart are one incident.  A fall of the count (a repair in the pits) is not a
    hit; rows where the count is not known (NaN: a car not seen) are skipped, the rise counted from
    the row before them.  The one rule of the race report, the incidents and the contacts."""
    t = np.asarray(time_s, dtype=float)
    d = np.asarray(damage, dtype=float)
    known = np.flatnonzero(np.isfinite(d))
    rise = np.diff(d[known])
    hits, gains = known[1:][rise > 0.0], rise[rise > 0.0]
    out: list[DamageRise] = []
    start = 0
    for k in range(1, len(hits) + 1):
        if k < len(hits) and t[hits[k]] - t[hits[k - 1]] <= merge_s + MERGE_ROUNDING_S:
            continue
        out.append(DamageRise(int(hits[start]), int(hits[k - 1]), k - start, int(round(float(gains[start:k].sum())))))
        start = k
    return out


def _moved_in(t: np.ndarray, first: int, near: np.ndarray, left: np.ndarray, mid: np.ndarray) -> dict[str, float]:
    """we_moved_in_m and it_moved_in_m of the incident whose first hit is at row `first` (see DamageIncident)."""
    before = int(np.searchsorted(t, t[first] - MOVED_S))
    if near[first] < 0 or near[before] != near[first] or before == first:
        return {}
    side = 1.0 if left[first] >= 0.0 else -1.0  # the other car is on this side of us
    we = (mid[first] - mid[before]) * side
    it = -((mid[first] + left[first]) - (mid[before] + left[before])) * side
    return {"we_moved_in_m": float(we), "it_moved_in_m": float(it)}


def damage_by_lap(incidents: list[DamageIncident]) -> dict[int, int]:
    """Damage points taken per lap (the lap each incident began on), laps in order."""
    out: dict[int, int] = {}
    for i in sorted(incidents, key=lambda i: i.lap):
        out[i.lap] = out.get(i.lap, 0) + i.damage
    return out


def nearest_text(i: DamageIncident, names: dict[int, str], near_m: float = NEAR_M) -> str:
    """The nearest other car at the incident's first hit in words ("bt 2: 3.1 m ahead, 1.8 m
    left"), or that none was within near_m; names: TORCS car index -> driver name."""
    if i.near_car < 0 or not i.near_m <= near_m:
        return f"none within {near_m:g} m"
    ahead = f"{abs(i.near_ahead_m):.1f} m {'ahead' if i.near_ahead_m >= 0.0 else 'behind'}"
    side = f"{abs(i.near_left_m):.1f} m {'left' if i.near_left_m >= 0.0 else 'right'}"
    return f"{names.get(i.near_car, f'car {i.near_car}')}: {ahead}, {side}"


def moved_text(i: DamageIncident, near_m: float = NEAR_M) -> str:
    """Who moved over towards the other in the MOVED_S before the first hit, in words ("we 3.2 m,
    it -1.2 m": we moved 3.2 m towards it, it 1.2 m away), or "" when not known or no car was near."""
    if i.near_car < 0 or not i.near_m <= near_m or i.we_moved_in_m != i.we_moved_in_m:
        return ""
    return f"we {i.we_moved_in_m:.1f} m, it {i.it_moved_in_m:.1f} m"
