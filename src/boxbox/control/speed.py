"""Speed limits: the grip limit in a turn, per-segment limits of a track, and a braking-aware profile.

`mu` is the total friction (surface friction times tyre mu) as in braking.py.
Per-call functions (`allowed_speed`, `SpeedProfile.speed_at`) use floats and `math` only; numpy is
used only while building per-track tables.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from boxbox.control.braking import BrakeModel, entry_speed_function
from boxbox.control.carmodel import CarModel
from boxbox.model.constants import G_MPS2 as G
from boxbox.model.track import STRAIGHT, Track

DEFAULT_MAX_SPEED_MPS = 100.0
QUARTER_TURN_RAD = math.pi / 2.0
# The defaults of segment_speed_limits and SpeedProfile.from_track fit a car on the track's middle
# line steered by steer_to_line's defaults (docs/robots.md): no turn is cut (full_arc_rad 0), and
# 70% of the grip, as that law settles outside the line in fast turns.  Such a car (the documented
# parts with their defaults, 1 lap of e-track-2, 2026-12-01) took damage 10,590 and no lap with the
# whole grip and turns under a quarter turn taken as cut, 1,633 with the cut at 70%, 553 at 80%
# without it, 0 at 70% without it.
MIDDLE_LINE_MU_SCALE = 0.7


def allowed_speed(
    radius_m: float, mu: float, model: CarModel, max_speed_mps: float = DEFAULT_MAX_SPEED_MPS,
    vertical_curvature_1pm: float = 0.0, bank_rad: float = 0.0,
) -> float:
    """Highest speed through a turn of radius_m on a road banked by bank_rad into the turn:
    sqrt(g r (mu cos b + sin b) / (1 - r mu (CA / m + kv))).

    Banking into the turn turns part of gravity into side force (sin b) and leaves cos b of it as
    load; b < 0, a road falling away outwards, does the opposite; b = 0 is sqrt(mu g r / (1 - r mu
    (CA / m + kv))).  The load that the turn's own acceleration would add through the bank (a
    rigid point mass's mu sin b in the denominator) is left out, as the simplix robots do: with it,
    michigan's 7.7 degree turn promised 71 m/s where car1-trb1 slid into the wall at full lock at
    60.  CA is the downforce the weaker axle corners on (model.ca_corner, see carmodel.py).
    Downforce grows with v^2 like the needed side force, so where the denominator reaches 0 any
    speed holds: then (and for r = inf) the result is max_speed_mps, which also caps every other
    result (pass math.inf for no cap).  `vertical_curvature_1pm` (kv, + in a dip, - over a crest)
    adds v^2 kv per kg to the tyres' load like downforce does: a dip carries the car faster, a
    crest slower.
    """
    if math.isinf(radius_m):
        return max_speed_mps
    lateral_g = mu if bank_rad == 0.0 else mu * math.cos(bank_rad) + math.sin(bank_rad)
    denom = 1.0 - radius_m * mu * (model.ca_corner / model.mass_kg + vertical_curvature_1pm)
    if denom <= 0.0:
        return max_speed_mps
    return min(max_speed_mps, math.sqrt(max(0.0, G * radius_m * lateral_g) / denom))


def crest_speed(vertical_curvature_1pm: float, model: CarModel, load_share: float = 0.5,
                max_speed_mps: float = DEFAULT_MAX_SPEED_MPS) -> float:
    """Highest speed over a crest that keeps `load_share` of the car's weight on its tyres.

    Over a crest the road falls away: the load per kg is g + v^2 (CA / m + kv) with kv < 0, and at
    load 0 the car takes off (and lands with damage).  Dips and flat road: max_speed_mps.
    """
    lift_per_v2 = -(vertical_curvature_1pm + model.ca / model.mass_kg)
    if lift_per_v2 <= 0.0:
        return max_speed_mps
    return min(max_speed_mps, math.sqrt((1.0 - load_share) * G / lift_per_v2))


def bump_speed(roughness_1pm: float, bump_accel_mps2: float, max_speed_mps: float = DEFAULT_MAX_SPEED_MPS) -> float:
    """Highest speed over short bumps (a washboard of a few metres' wavelength) of the given
    short-wave vertical curvature: the one where v^2 |kv| reaches `bump_accel_mps2`.

    Unlike a long dip, which the suspension follows, bumps a car length apart shake it at its own
    frequency: at dirt-2's washboard (0.45 m high, 10 m apart) 15 m/s bottomed the car out on
    every bump.  Smooth road (roughness 0): max_speed_mps.
    """
    if roughness_1pm <= 0.0:
        return max_speed_mps
    return min(max_speed_mps, math.sqrt(bump_accel_mps2 / roughness_1pm))


def _turn_arc_fractions(seg_type: np.ndarray, arc_rad: np.ndarray, full_arc_rad: float) -> np.ndarray:
    """Per segment: the arc of the whole turn it belongs to / full_arc_rad, at most 1 (1 on straights;
    1 everywhere when full_arc_rad is 0: no turn is cut).

    A turn is a maximal run of consecutive segments turning the same way (radii may differ);
    runs wrap around the start line.
    """
    n = len(seg_type)
    frac = np.ones(n)
    if n == 0 or full_arc_rad <= 0.0:
        return frac
    # start scanning at a segment whose predecessor differs, so no run is cut by the start line
    changes = [i for i in range(n) if seg_type[i] != seg_type[i - 1]]
    first = changes[0] if changes else 0
    run: list[int] = []

    def close(run: list[int]) -> None:
        if run and seg_type[run[0]] != STRAIGHT:
            total = float(sum(arc_rad[k] for k in run))
            frac[run] = min(1.0, total / full_arc_rad)

    for k in range(n):
        i = (first + k) % n
        if run and seg_type[i] != seg_type[run[-1]]:
            close(run)
            run = []
        run.append(i)
    close(run)
    return frac


def segment_speed_limits(
    track: Track,
    model: CarModel,
    *,
    mu_scale: float = MIDDLE_LINE_MU_SCALE,
    max_speed_mps: float = DEFAULT_MAX_SPEED_MPS,
    full_arc_rad: float = 0.0,
    short_turn_exponent: float = 1.0,
    width_fraction: float = 0.0,
) -> np.ndarray:
    """Allowed speed per segment (m/s); straights get max_speed_mps.

    The defaults assume a car on the middle line (MIDDLE_LINE_MU_SCALE): every turn at its
    middle-line radius, 70% of the grip.  A line that cuts turns passes `full_arc_rad` (e.g.
    QUARTER_TURN_RAD): a turn whose total arc is below it is cut, so its radius is enlarged:
    r' = (r + width_fraction * width) / (arc / full_arc_rad) ** short_turn_exponent.  mu per
    segment is friction * model.mu * mu_scale.
    """
    s = track.seg
    seg_type = np.asarray(s["type"])
    frac = _turn_arc_fractions(seg_type, np.asarray(s["arc_rad"], dtype=float), full_arc_rad)
    limits = np.full(len(seg_type), float(max_speed_mps))
    for i in range(len(seg_type)):
        if seg_type[i] == STRAIGHT:
            continue
        radius_m = float(s["radius_m"][i]) + width_fraction * float(s["width_m"][i])
        radius_m = radius_m / frac[i] ** short_turn_exponent if frac[i] > 0.0 else math.inf
        mu = float(s["friction"][i]) * model.mu * mu_scale
        limits[i] = allowed_speed(radius_m, mu, model, max_speed_mps)
    return limits


MAX_LATERAL_SHARE = 0.9  # keep at least sqrt(1 - 0.81) = 44% of the braking grip in any turn


class SpeedProfile:
    """Target speed around a closed lap: below every limit and always reachable by braking.

    Samples are `step_m` apart (sample i at i * step_m, the lap is n * step_m long). The profile
    is the largest speeds with v[i] <= limit[i] and v[i] <= max_entry_speed(v[i+1], step_m, mu[i])
    (exact braking model), around the loop: a slow turn just after the start line makes the
    car brake at the end of the lap.
    """

    def __init__(
        self,
        limit_mps: Sequence[float] | np.ndarray,
        mu: float | Sequence[float] | np.ndarray,
        model: CarModel,
        step_m: float = 2.0,
        *,
        max_speed_mps: float = DEFAULT_MAX_SPEED_MPS,
        curvature_1pm: Sequence[float] | np.ndarray | None = None,
        corner_mu: float | Sequence[float] | np.ndarray | None = None,
        brake_method: BrakeModel | str = BrakeModel.EXACT,
        vertical_curvature_1pm: Sequence[float] | np.ndarray | None = None,
    ) -> None:
        """curvature_1pm and corner_mu (optional, per sample): share the tyres' grip between
        cornering and braking (friction circle), so the car brakes less where it also turns.
        vertical_curvature_1pm (optional, per sample, + in a dip): braking grip follows the tyres'
        load, less over a crest, more in a dip."""
        limit = np.minimum(np.asarray(limit_mps, dtype=float), max_speed_mps)
        if limit.ndim != 1 or len(limit) == 0:
            raise ValueError("limit_mps must be a non-empty 1-d sequence")
        if step_m <= 0.0:
            raise ValueError("step_m must be positive")
        self.model = model
        self.step_m = float(step_m)
        self.n_samples = len(limit)
        self.length_m = self.n_samples * self.step_m
        self.limits_mps = limit
        self.mu = np.broadcast_to(np.asarray(mu, dtype=float), limit.shape).copy()
        lateral = None
        if curvature_1pm is not None:
            k = np.abs(np.broadcast_to(np.asarray(curvature_1pm, dtype=float), limit.shape))
            cmu = np.broadcast_to(np.asarray(self.mu if corner_mu is None else corner_mu, dtype=float), limit.shape)
            lateral = (k.tolist(), cmu.tolist())
        self.brake_method = BrakeModel(brake_method)
        vertical = None
        if vertical_curvature_1pm is not None:
            vertical = np.broadcast_to(np.asarray(vertical_curvature_1pm, dtype=float), limit.shape).tolist()
        speeds = self._backward_pass(limit.tolist(), self.mu.tolist(), model, self.step_m, lateral,
                                     entry_speed_function(self.brake_method), vertical)
        self._speeds: list[float] = speeds + [speeds[0]]  # one extra so speed_at can wrap without a branch
        self._inv_step = 1.0 / self.step_m
        self.target_speeds = np.array(speeds)

    @staticmethod
    def _backward_pass(limit: list[float], mu: list[float], model: CarModel, step_m: float,
                       lateral: tuple[list[float], list[float]] | None = None,
                       max_entry_speed=None, vertical: list[float] | None = None) -> list[float]:
        n = len(limit)
        max_entry_speed = max_entry_speed or entry_speed_function(BrakeModel.EXACT)
        ca_per_kg = model.ca / model.mass_kg
        corner_ca_per_kg = model.ca_corner / model.mass_kg
        speeds = list(limit)
        # The slowest sample can never be forced lower (everything is >= the smallest limit), so a
        # pass backwards from it settles the loop; the loop repeats only as a safeguard.
        start = min(range(n), key=limit.__getitem__)
        for _ in range(n + 1):
            changed = False
            for k in range(1, n + 1):
                i = (start - k) % n
                v_next = speeds[(i + 1) % n]
                mu_brake = mu[i]
                v_sq = v_next * v_next
                flat_load = G + ca_per_kg * v_sq  # per kg, as the braking model counts it
                load = flat_load
                if vertical is not None and vertical[i] != 0.0:
                    # the braking model assumes a flat road: scale its grip by the load here
                    load = max(0.1 * G, flat_load + vertical[i] * v_sq)
                    mu_brake *= load / flat_load
                if lateral is not None and lateral[0][i] > 0.0:
                    # grip left for braking once the turn takes its share: sqrt(1 - used^2)
                    # (the weaker axle's load: the turn's share as allowed_speed counts it)
                    corner_load = max(0.1 * G, load + (corner_ca_per_kg - ca_per_kg) * v_sq)
                    used = v_sq * lateral[0][i] / (lateral[1][i] * corner_load)
                    mu_brake *= math.sqrt(1.0 - min(used, MAX_LATERAL_SHARE) ** 2)
                v = min(limit[i], max_entry_speed(v_next, step_m, mu_brake, model))
                if v < speeds[i]:
                    speeds[i] = v
                    changed = True
            if not changed:
                break
        return speeds

    def cap(self, ceiling_mps: np.ndarray) -> None:
        """Lower each sample to at most `ceiling_mps` (m/s, one per sample): a ceiling from another
        model of the car, itself reachable by braking, keeps the profile reachable."""
        if len(ceiling_mps) != self.n_samples:
            raise ValueError(f"the ceiling needs {self.n_samples} samples, not {len(ceiling_mps)}")
        capped = np.minimum(self.target_speeds, ceiling_mps)
        self.target_speeds = capped
        self._speeds = capped.tolist() + [float(capped[0])]

    @property
    def distances_m(self) -> np.ndarray:
        return np.arange(self.n_samples) * self.step_m

    def speed_at(self, dist_m: float) -> float:
        """Target speed at a distance from the start line (any lap), linear between samples."""
        x = (dist_m % self.length_m) * self._inv_step
        i = int(x)
        if i >= self.n_samples:  # float rounding just below the lap length
            i = self.n_samples - 1
        v0 = self._speeds[i]
        return v0 + (self._speeds[i + 1] - v0) * (x - i)

    @classmethod
    def from_curvature(
        cls,
        curvature_1pm: Sequence[float] | np.ndarray,
        mu: float | Sequence[float] | np.ndarray,
        model: CarModel,
        step_m: float = 2.0,
        *,
        max_speed_mps: float = DEFAULT_MAX_SPEED_MPS,
    ) -> SpeedProfile:
        """Profile of a racing line given by its curvature (1/m, any sign) per sample; mu is total."""
        k = np.abs(np.asarray(curvature_1pm, dtype=float))
        mus = np.broadcast_to(np.asarray(mu, dtype=float), k.shape)
        limit = [
            allowed_speed(1.0 / ki if ki > 0.0 else math.inf, float(m), model, max_speed_mps)
            for ki, m in zip(k.tolist(), mus.tolist(), strict=False)
        ]
        return cls(limit, mus, model, step_m, max_speed_mps=max_speed_mps)

    @classmethod
    def from_track(
        cls,
        track: Track,
        model: CarModel,
        step_m: float = 2.0,
        *,
        mu_scale: float = MIDDLE_LINE_MU_SCALE,
        max_speed_mps: float = DEFAULT_MAX_SPEED_MPS,
        **limit_options: float,
    ) -> SpeedProfile:
        """Profile from the per-segment limits of `segment_speed_limits` (options passed on; its
        defaults assume the middle line, no turn cut, 70% of the grip).

        The step is adjusted so a whole number of samples fills the lap. Each sample takes the
        lowest limit and friction of all segments within one step either side, so `speed_at`,
        interpolating between two samples, respects every segment between them (a turn starting
        or ending between two samples limits both).
        """
        seg_limits = segment_speed_limits(
            track, model, mu_scale=mu_scale, max_speed_mps=max_speed_mps, **limit_options
        ).tolist()
        seg_mu = (np.asarray(track.seg["friction"], dtype=float) * model.mu * mu_scale).tolist()
        starts = np.asarray(track.seg["start_dist_m"], dtype=float).tolist()
        n_seg = len(starts)
        lap_m = track.length_m
        n = max(1, round(lap_m / step_m))
        step = lap_m / n
        limit = [0.0] * n
        mu = [0.0] * n
        for i in range(n):
            # walk the segments overlapping [d - step, d + step], unwrapping across the start line
            lo_m, hi_m = (i - 1) * step, (i + 1) * step
            j = track.segment_at(lo_m) + math.floor(lo_m / lap_m) * n_seg  # negative: the previous lap
            v_min, mu_min = math.inf, math.inf
            while True:
                k = j % n_seg
                if starts[k] + (j // n_seg) * lap_m >= hi_m:
                    break
                v_min = min(v_min, seg_limits[k])
                mu_min = min(mu_min, seg_mu[k])
                j += 1
            limit[i] = v_min
            mu[i] = mu_min
        return cls(limit, mu, model, step, max_speed_mps=max_speed_mps)
