"""Where a car took its damage: the rises of TORCS's damage count in the telemetry, merged into
incidents (a car rubbing along another or a barrier hits it many times a second)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MERGE_S = 1.0  # hits this close in time are one incident


@dataclass(frozen=True)
class Incident:
    """One incident: the hits from time_s on, none more than MERGE_S after the one before."""

    lap: int  # the lap it began on (0: before the start line)
    dist_m: float  # distance from the start line at the first hit (m)
    time_s: float  # race time at the first hit (s)
    damage: int  # damage points taken in it (TORCS's count; 10,000 puts a car out)
    speed_mps: float  # our speed at the first hit (m/s; < 0 reversing)
    hits: int  # steps on which the count rose
    x_m: float  # where the first hit was, for the map (m)
    y_m: float


def damage_incidents(c: dict[str, np.ndarray], merge_s: float = MERGE_S) -> list[Incident]:
    """The incidents of one car's telemetry `c` (columns time_s, lap, dist_m, speed_mps, damage,
    x_m, y_m, one row per step).  A fall of the count (a repair in the pits) is not a hit."""
    if not merge_s >= 0.0:
        raise ValueError(f"merge_s must be a number of seconds >= 0, not {merge_s!r}")
    need = ("time_s", "lap", "dist_m", "speed_mps", "damage", "x_m", "y_m")
    missing = [k for k in need if k not in c]
    if missing:
        raise ValueError(f"telemetry lacks the column(s) {', '.join(missing)}")
    dmg = np.nan_to_num(np.asarray(c["damage"], dtype=float))
    rise = np.diff(dmg, prepend=dmg[:1])
    hits = np.flatnonzero(rise > 0.0)
    t = np.asarray(c["time_s"], dtype=float)
    out: list[Incident] = []
    start = 0
    for k in range(1, len(hits) + 1):
        if k < len(hits) and t[hits[k]] - t[hits[k - 1]] <= merge_s:
            continue
        first, group = hits[start], hits[start:k]
        out.append(Incident(lap=int(c["lap"][first]), dist_m=float(c["dist_m"][first]), time_s=float(t[first]),
                            damage=int(round(float(rise[group].sum()))), speed_mps=float(c["speed_mps"][first]),
                            hits=len(group), x_m=float(c["x_m"][first]), y_m=float(c["y_m"][first])))
        start = k
    return out


def damage_by_lap(incidents: list[Incident]) -> dict[int, int]:
    """Damage points taken per lap (the lap each incident began on), laps in order."""
    out: dict[int, int] = {}
    for i in sorted(incidents, key=lambda i: i.lap):
        out[i.lap] = out.get(i.lap, 0) + i.damage
    return out
