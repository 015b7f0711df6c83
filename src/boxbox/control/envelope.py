"""A safety envelope for driving in traffic: Responsibility-Sensitive Safety (RSS) on plain numbers.

Shalev-Shwartz, Shammah, Shashua, "On a Formal Model of Safe and Scalable Self-driving Cars", 2017
(arXiv:1708.06374): a rear car that keeps at least the safe distance behind a car ahead, and
brakes when it has less, never hits it; two cars alongside that keep the safe lateral distance
and brake their lateral speed when they have less never touch.

Longitudinal, with a racing prior in place of RSS's fixed worst case for the car ahead:
- `rss_gap_m`: RSS's d_min (we react after rho_s, accelerating at most accel_mps2, then brake at
  b_min; the car ahead brakes at up to b_max);
- `front_speeds_mps`: the lowest speed the car ahead may have at each step of the track ahead of
  it: no lower than its recorded speed there (or its speed now, if lower), and slowing from there
  no harder than its tyres allow (b_max); without a record, RSS's b_max braking from now;
- `safe_gap_m`: the bumper gap our brakes need behind it: a step of reaction plus, for each point
  x ahead of it, our braking distance down to its speed there less x.  If we can be no faster than
  it at every point it has passed, we reach each point after it (a car that needs more time for
  every metre never catches up), so no contact.  With a constant b_max >= our deceleration it
  equals `rss_gap_m`;
- `max_safe_speed_mps`: the proper response: the most speed we may hold now for the gap we have
  (above it, brake).

Lateral: `rss_lateral_gap_m` (RSS's safe lateral distance) and `lateral_room_m`: how much further
towards a car that overlaps us lengthwise we may move and keep that distance (< 0: move away).

Speeds in m/s, distances in metres, decelerations as positive m/s^2.  The braking model is
injected (control/braking.py's brake_distance and max_entry_speed for a car, or a constant
deceleration) as brakedist(v_from_mps, v_to_mps) -> m and entry_speed(v_to_mps, dist_m) -> m/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from boxbox.model.constants import DRIVE_STEP_S

BrakeDist = Callable[[float, float], float]
EntrySpeed = Callable[[float, float], float]


def _check(**values: float) -> None:
    """ValueError naming the first value that is negative or not finite."""
    for name, value in values.items():
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")


def _reaction(speed_mps: float, reaction_s: float, accel_mps2: float) -> tuple[float, float]:
    """(metres driven, speed at the end) while we react, accelerating at accel_mps2."""
    return speed_mps * reaction_s + 0.5 * accel_mps2 * reaction_s ** 2, speed_mps + accel_mps2 * reaction_s


def rss_gap_m(rear_mps: float, front_mps: float, b_min_mps2: float, b_max_mps2: float,
              reaction_s: float = DRIVE_STEP_S, accel_mps2: float = 0.0) -> float:
    """RSS's safe longitudinal distance d_min (m):
    max(0, v_r rho + a rho^2 / 2 + (v_r + rho a)^2 / (2 b_min) - v_f^2 / (2 b_max))."""
    _check(rear_mps=rear_mps, front_mps=front_mps, reaction_s=reaction_s, accel_mps2=accel_mps2)
    if not (b_min_mps2 > 0.0 and b_max_mps2 > 0.0 and math.isfinite(b_min_mps2 + b_max_mps2)):
        raise ValueError(f"decelerations must be finite and > 0, got b_min {b_min_mps2}, b_max {b_max_mps2}")
    driven_m, v_mps = _reaction(rear_mps, reaction_s, accel_mps2)
    return max(0.0, driven_m + v_mps ** 2 / (2.0 * b_min_mps2) - front_mps ** 2 / (2.0 * b_max_mps2))


def front_speeds_mps(front_mps: float, b_max_mps2: float, step_m: float, reach_m: float,
                     recorded_mps: np.ndarray | None = None) -> np.ndarray:
    """The lowest speed (m/s) the car ahead may have at 0, step_m, 2 step_m, ... reach_m ahead of
    its place now.  recorded_mps: its speeds recorded at those points on its earlier laps (NaN or
    past the array's end: no record there); None: no record (lap 1, a car not seen there), so RSS's
    worst case, braking at b_max from now.  Where a record exists it drives no slower than the lower
    of its record and its speed now; it never slows harder than b_max."""
    _check(front_mps=front_mps, reach_m=reach_m)
    if not (b_max_mps2 > 0.0 and step_m > 0.0 and math.isfinite(b_max_mps2 + step_m)):
        raise ValueError(f"b_max and step must be finite and > 0, got {b_max_mps2} m/s^2 and {step_m} m")
    n = int(math.ceil(reach_m / step_m)) + 1
    floor = np.zeros(n)
    if recorded_mps is not None:
        record = np.asarray(recorded_mps, dtype=float)[:n]
        if np.any(record < 0.0) or np.any(np.isinf(record)):
            raise ValueError("recorded speeds must be finite and >= 0 (NaN: not recorded there)")
        floor[:len(record)] = np.nan_to_num(np.minimum(record, front_mps), nan=0.0)
    floor[0] = front_mps
    lowest_sq = floor ** 2
    for i in range(1, n):  # slowing from any point no harder than b_max
        lowest_sq[i] = max(lowest_sq[i], lowest_sq[i - 1] - 2.0 * b_max_mps2 * step_m)
    return np.sqrt(lowest_sq)


def _cells(front_speeds: np.ndarray) -> list[float]:
    """The slower end's speed of each step of the grid, the last step's 0: past the last point the
    car ahead may stand (so reach_m should be at least our own stopping distance)."""
    speeds = np.asarray(front_speeds, dtype=float)
    if speeds.ndim != 1 or len(speeds) == 0 or not (np.all(np.isfinite(speeds)) and np.all(speeds >= 0.0)):
        raise ValueError("front_speeds must be a non-empty 1-d array of finite speeds >= 0 (see front_speeds_mps)")
    return np.minimum(speeds, np.append(speeds[1:], 0.0)).tolist()


def safe_gap_m(my_speed_mps: float, front_speeds: np.ndarray, step_m: float, brakedist: BrakeDist,
               reaction_s: float = DRIVE_STEP_S, accel_mps2: float = 0.0) -> float:
    """The bumper gap (m) we need behind a car whose lowest speeds ahead of it are front_speeds
    (front_speeds_mps): we react for reaction_s (one drive step), then brake so that at each point
    x it reaches we are no faster than it was there: the most, over the points x where it may be
    slower than us, of the reaction's metres + brakedist(v, its speed at x) - x (RSS's max(0, ...)),
    each step of the grid taken at its near end's place and its slower end's speed."""
    _check(my_speed_mps=my_speed_mps, reaction_s=reaction_s, accel_mps2=accel_mps2)
    driven_m, v_mps = _reaction(my_speed_mps, reaction_s, accel_mps2)
    need_m = 0.0  # points where it is no slower than we can be ask for no gap
    for i, u_mps in enumerate(_cells(front_speeds)):
        if v_mps > u_mps:
            need_m = max(need_m, driven_m + brakedist(v_mps, u_mps) - i * step_m)
    return need_m


def max_safe_speed_mps(gap_m: float, front_speeds: np.ndarray, step_m: float, entry_speed: EntrySpeed,
                       reaction_s: float = DRIVE_STEP_S, accel_mps2: float = 0.0) -> float:
    """The proper response: the most speed (m/s) whose safe_gap_m fits in gap_m (entry_speed is
    brakedist's inverse).  Held at or below it, any throttle up to accel_mps2 keeps the gap safe for
    a step; above it, brake.  The reaction's metres are taken at a first, higher guess of the speed,
    so the answer errs low by a hair.  gap_m < 0 (overlapping): no faster than the car ahead."""
    _check(reaction_s=reaction_s, accel_mps2=accel_mps2)
    if not math.isfinite(gap_m):
        raise ValueError(f"gap_m must be a finite number, got {gap_m!r}")
    cell_mps = _cells(front_speeds)

    def highest(room_m: float) -> float:  # where the room is gone, no faster than the car ahead there
        most_mps = math.inf
        for i, u_mps in enumerate(cell_mps):
            if u_mps < most_mps:  # entry_speed(u, ...) >= u: a faster point cannot lower it
                most_mps = min(most_mps, entry_speed(u_mps, max(0.0, room_m + i * step_m)))
        return most_mps

    guess_mps = highest(gap_m)  # no reaction: too high, so its reaction metres are too many
    driven_m, _ = _reaction(guess_mps, reaction_s, accel_mps2)
    return max(0.0, highest(gap_m - driven_m) - accel_mps2 * reaction_s)


def rss_lateral_gap_m(my_toward_mps: float, other_toward_mps: float, b_lat_mps2: float, margin_m: float,
                      reaction_s: float = DRIVE_STEP_S, accel_lat_mps2: float = 0.0) -> float:
    """RSS's safe lateral distance (m) between two cars alongside: each reacts after reaction_s,
    accelerating towards the other by up to accel_lat_mps2, then brakes its lateral speed at
    b_lat_mps2.  Lateral speeds are each car's towards the other (+) or away (-); the braking
    travel keeps its sign (v |v| / 2b): a car moving away adds room rather than taking it."""
    _check(b_lat_mps2=b_lat_mps2, margin_m=margin_m, reaction_s=reaction_s, accel_lat_mps2=accel_lat_mps2)
    if not (b_lat_mps2 > 0.0 and math.isfinite(my_toward_mps + other_toward_mps)):
        raise ValueError(f"need b_lat > 0 and finite lateral speeds, got {b_lat_mps2}, "
                         f"{my_toward_mps}, {other_toward_mps}")
    travel_m = 0.0
    for v_mps in (my_toward_mps, other_toward_mps):
        driven_m, v_end_mps = _reaction(v_mps, reaction_s, accel_lat_mps2)
        travel_m += driven_m + v_end_mps * abs(v_end_mps) / (2.0 * b_lat_mps2)
    return margin_m + max(0.0, travel_m)


def lateral_room_m(gap_m: float, my_toward_mps: float, other_toward_mps: float, b_lat_mps2: float,
                   margin_m: float, reaction_s: float = DRIVE_STEP_S, accel_lat_mps2: float = 0.0) -> float:
    """How much further (m) we may move towards a car that overlaps us lengthwise, beyond where our
    lateral speed now carries us, and keep rss_lateral_gap_m to it; < 0: the gap is already short
    by that much, so brake the lateral speed towards it (and give room if it keeps coming)."""
    _check(gap_m=gap_m)
    return gap_m - rss_lateral_gap_m(my_toward_mps, other_toward_mps, b_lat_mps2, margin_m, reaction_s,
                                     accel_lat_mps2)


__all__ = ["BrakeDist", "EntrySpeed", "front_speeds_mps", "lateral_room_m", "max_safe_speed_mps", "rss_gap_m",
           "rss_lateral_gap_m", "safe_gap_m"]
