"""Where each other car will be over the next seconds, with how sure that is, on plain arrays.

A car is predicted along the track (s, metres from the start line) and across it (d, its
to_middle: metres from the track's middle, + to the left), over a few seconds at fixed times:

- along: at the speed it was seen doing at each place before (its observed speed profile),
  scaled by how much faster or slower than that it goes now (a car held up stays held up); where
  it was never seen, at its speed of now;
- across: on the line it was seen on at each place before, coming back to it from where it is now
  with the time constant `return_s` (a car pushed aside drifts back); where its line is unknown it
  keeps its lateral position;
- the spread (one standard deviation, m): along, it grows with time from an unknown change of
  speed (`longitudinal_mps` t) and a car braking or accelerating off its profile
  (`brake_mps2` t^2 / 2), plus what the car was seen to vary lap to lap; across, it grows with
  time (`lateral_mps` t, more where its line is unknown: a car that turns in where we have not seen
  it) plus its lap-to-lap lateral variability, up to `max_lateral_m`.

Every car at once (numpy arrays of shape (cars, times)): a prediction of ten cars over 16 times
costs some tens of microseconds.  No robot reads it yet: it is kept for the braking and yielding
behind and beside cars that will (the traffic planner that read it measured worse than the tutorial's
overtaking and was retired: docs/racecraft.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# passes of the speed-along-the-profile integration (the first from the speed of now; a second moves s < 1 %)
PASSES = 1


@dataclass(frozen=True)
class SpreadParams:
    """How unsure a prediction is (standard deviations; see the module's docstring)."""

    lateral_m: float = 0.3  # across, at t = 0 (m): its position of now, give or take
    lateral_mps: float = 0.3  # across, growth (m/s) on a line seen before
    unseen_lateral_mps: float = 0.6  # across, growth (m/s) where its line is not known
    max_lateral_m: float = 2.0  # across, at most (m)
    longitudinal_m: float = 0.5  # along, at t = 0 (m)
    longitudinal_mps: float = 0.5  # along, growth (m/s) from an unknown speed change
    brake_mps2: float = 1.5  # along, growth t^2 / 2 (m/s^2): a car braking off its profile
    return_s: float = 1.0  # a car off its remembered line comes back to it with this time constant (s)
    # its speed against its profile's no higher than this (a car seen once at a crawl, in a crash,
    # is not predicted to go many times that speed where it crawled)
    ratio_hi: float = 1.5


@dataclass(frozen=True)
class Prediction:
    """Each car over the times t_s (s, from now): arrays of shape (cars, times)."""

    t_s: np.ndarray
    travel_m: np.ndarray  # distance it covers along the track from now (m)
    d_m: np.ndarray  # its to_middle (m, + left)
    sigma_s_m: np.ndarray  # spread along (m, one standard deviation)
    sigma_d_m: np.ndarray  # spread across (m)


def horizon_times(horizon_s: float, dt_s: float) -> np.ndarray:
    """0, dt_s, 2 dt_s, ... up to horizon_s (s), both > 0, dt_s no more than horizon_s."""
    if not (math.isfinite(horizon_s) and math.isfinite(dt_s) and 0.0 < dt_s <= horizon_s):
        raise ValueError(f"horizon and step must be finite with 0 < step <= horizon, got {horizon_s} s and {dt_s} s")
    return np.arange(int(round(horizon_s / dt_s)) + 1) * dt_s


def _check(s0_m: np.ndarray, d0_m: np.ndarray, v0_mps: np.ndarray, lines_d_m: np.ndarray,
           speeds_mps: np.ndarray, track_length_m: float, t_s: np.ndarray) -> None:
    n = s0_m.shape[0]
    if s0_m.ndim != 1 or d0_m.shape != (n,) or v0_mps.shape != (n,):
        raise ValueError(f"s0, d0 and v0 must be 1-d of one length, got {s0_m.shape}, {d0_m.shape}, {v0_mps.shape}")
    if lines_d_m.ndim != 2 or lines_d_m.shape[0] != n or speeds_mps.shape != lines_d_m.shape or lines_d_m.shape[1] < 1:
        raise ValueError(f"lines and speeds must be (cars, track steps) with {n} cars, "
                         f"got {lines_d_m.shape} and {speeds_mps.shape}")
    if not (math.isfinite(track_length_m) and track_length_m > 0.0):
        raise ValueError(f"track length must be positive, got {track_length_m} m")
    if not (np.all(np.isfinite(s0_m)) and np.all(np.isfinite(d0_m)) and np.all(np.isfinite(v0_mps))):
        raise ValueError("each car's s0, d0 and speed must be finite (drop a car TORCS lost)")
    if np.any(v0_mps < 0.0):
        raise ValueError("speeds must be >= 0 m/s (a car moving backwards counts as stopped)")
    if t_s.ndim != 1 or t_s.size < 1 or t_s[0] != 0.0 or np.any(np.diff(t_s) <= 0.0) or not np.all(np.isfinite(t_s)):
        raise ValueError("times must start at 0 s and increase (horizon_times)")


def _cells(s_m: np.ndarray, track_length_m: float, steps: int) -> np.ndarray:
    """The index of the track step each distance (m, any lap) falls in."""
    return (np.mod(s_m, track_length_m) * (steps / track_length_m)).astype(np.int64) % steps


def _travel(s0_m: np.ndarray, v0_mps: np.ndarray, speeds_mps: np.ndarray, track_length_m: float,
            t_s: np.ndarray, p: SpreadParams) -> np.ndarray:
    """Distance covered (m), shape (cars, times): along the observed speed profile scaled to the
    car's speed of now; at its speed of now where the profile is unknown (NaN)."""
    n, steps = s0_m.shape[0], speeds_mps.shape[1]
    flat, rows = speeds_mps.ravel(), np.arange(n)[:, None] * steps  # flat indexing: 5x quicker than 2-d
    seen0 = flat[rows[:, 0] + _cells(s0_m, track_length_m, steps)]
    usable = seen0 > 1.0  # NaN compares False: not seen there
    ratio = np.minimum(p.ratio_hi, v0_mps / np.where(usable, seen0, 1.0))
    ratio = np.where(usable, ratio, 1.0)[:, None]
    travel = v0_mps[:, None] * t_s[None, :]
    half_dt = 0.5 * np.diff(t_s)[None, :]
    for _ in range(PASSES):
        seen = flat[rows + _cells(s0_m[:, None] + travel, track_length_m, steps)]
        v = np.where(seen >= 0.0, ratio * seen, v0_mps[:, None])
        v[:, 0] = v0_mps
        travel = np.zeros((n, t_s.shape[0]))
        np.cumsum((v[:, 1:] + v[:, :-1]) * half_dt, axis=1, out=travel[:, 1:])
    return travel


def predict(s0_m: np.ndarray, d0_m: np.ndarray, v0_mps: np.ndarray, lines_d_m: np.ndarray,
            speeds_mps: np.ndarray, track_length_m: float, t_s: np.ndarray,
            lateral_var_m: np.ndarray | None = None, speed_var_mps: np.ndarray | None = None,
            p: SpreadParams = SpreadParams()) -> Prediction:
    """Each car's travel, lateral position and spreads over the times t_s (s, from 0, rising).

    s0_m: each car's distance from the start line (m); d0_m: its to_middle (m, + left); v0_mps: its
    speed (m/s, >= 0); lines_d_m, speeds_mps: shape (cars, steps), the to_middle (m) and speed (m/s)
    each car was seen at on each of `steps` equal steps of the track (NaN: not seen there);
    track_length_m: the lap (m); lateral_var_m, speed_var_mps: each car's observed lap-to-lap
    variability across (m) and in speed (m/s), 0 when not given.  ValueError on bad shapes or values.
    """
    s0_m, d0_m, v0_mps = (np.asarray(a, dtype=float) for a in (s0_m, d0_m, v0_mps))
    lines_d_m, speeds_mps, t_s = np.asarray(lines_d_m, float), np.asarray(speeds_mps, float), np.asarray(t_s, float)
    _check(s0_m, d0_m, v0_mps, lines_d_m, speeds_mps, track_length_m, t_s)
    n = s0_m.shape[0]
    lat_var = np.zeros(n) if lateral_var_m is None else np.asarray(lateral_var_m, float)
    spd_var = np.zeros(n) if speed_var_mps is None else np.asarray(speed_var_mps, float)
    if lat_var.shape != (n,) or spd_var.shape != (n,) or not (np.all(lat_var >= 0.0) and np.all(spd_var >= 0.0)) \
            or not np.all(np.isfinite(lat_var + spd_var)):
        raise ValueError(f"variabilities must be {n} finite values >= 0")
    return predict_fast(s0_m, d0_m, v0_mps, lines_d_m, np.clip(speeds_mps, 0.0, None), track_length_m, t_s,
                        lat_var, spd_var, p)


def predict_fast(s0_m: np.ndarray, d0_m: np.ndarray, v0_mps: np.ndarray, lines_d_m: np.ndarray,
                 speeds_mps: np.ndarray, track_length_m: float, t_s: np.ndarray, lat_var: np.ndarray,
                 spd_var: np.ndarray, p: SpreadParams) -> Prediction:
    """predict() without its checks, for a caller that built every array itself (the drive step):
    float arrays of the shapes predict() names, speeds >= 0 or NaN, variabilities given."""
    n = s0_m.shape[0]
    travel = _travel(s0_m, v0_mps, speeds_mps, track_length_m, t_s, p)
    steps = lines_d_m.shape[1]
    line_t = lines_d_m.ravel()[np.arange(n)[:, None] * steps + _cells(s0_m[:, None] + travel, track_length_m, steps)]
    line0 = line_t[:, :1]
    base0 = np.where(np.isfinite(line0), line0, d0_m[:, None])
    known = np.isfinite(line_t)
    base = np.where(known, line_t, base0)
    fade = np.exp(-t_s / p.return_s)[None, :]
    d = base + (d0_m[:, None] - base0) * fade
    t = t_s[None, :]
    growth = np.where(known, p.lateral_mps, p.unseen_lateral_mps)
    sigma_d = np.minimum(p.max_lateral_m, p.lateral_m + growth * t + lat_var[:, None] * (1.0 - fade))
    sigma_s = p.longitudinal_m + (p.longitudinal_mps + spd_var[:, None]) * t + 0.5 * p.brake_mps2 * t * t
    return Prediction(t_s, travel, d, np.broadcast_to(sigma_s, travel.shape), sigma_d)
