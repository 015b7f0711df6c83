"""A local planner in the track's own coordinates (s along it, d across it): candidate paths through
the predicted cars, scored by progress against the risk of contact, on plain arrays.

After the sampling planners in Frenet coordinates (Werling et al. 2010; TUM's Frenetix) and the
race-car local planner of Stahl et al. (2019): each candidate is one lateral manoeuvre and one speed
over the horizon, here

- lateral: the offset from our racing line goes from where it is now (with its rate) to an end
  offset in `lateral_s` on a quintic (the minimum-jerk blend: position, rate and acceleration
  continuous at both ends), then holds it;
- speed: our speed profile ahead, times a scale (1: the profile; less: waiting behind), reached from
  our speed of now at no more than `accel_mps2` / `decel_mps2`.

A candidate's cost is the distance it loses against the fastest (progress), plus `risk_m` times its
risk of contact, plus small costs for being off the line and for changing the plan.  The risk with
a car at a time is the probability that the two cars' rectangles (with `gap_m` and `length_gap_m`
to spare) overlap, the other car's place being normal about its prediction with its spread, along
and across independently; a candidate's risk is the largest over the times with each car, weighted
less the further ahead in time (a later conflict is re-planned before it comes), summed over the
cars.  A candidate that leaves the drivable width is charged by how far.  Commitment: once the
chosen path passes a car on one side, the other side costs `switch_m` more until the risk on the
chosen side passes `commit_risk` or the car is passed.  A speed below the profile is chosen only
when every path at the profile's speed risks more than `wait_risk`: the robot's brakes for the car
ahead keep the gap behind it anyway.

Cost: the candidates are arrays of (offsets x speeds) against (cars x times), 12 x 4 x 10 x 16
numbers, in some sixty numpy operations: a few hundred microseconds a plan (control/prediction.py
predicts the cars), so the robot re-plans every few drive steps (robot/planning.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from boxbox.control.prediction import Prediction


@dataclass(frozen=True)
class PlannerParams:
    horizon_s: float = 3.0  # how far ahead paths are planned (s)
    dt_s: float = 0.2  # time step of the plan (s)
    lateral_s: float = 1.0  # a candidate reaches its end offset in this long (s)
    offsets: int = 11  # end offsets sampled across the drivable width, plus the one of now
    speed_scales: tuple[float, ...] = (1.0, 0.9, 0.75, 0.5)  # of our speed profile
    accel_mps2: float = 6.0  # our speed rises no faster than this (m/s^2)
    decel_mps2: float = 12.0  # ... and falls no faster than this
    gap_m: float = 0.5  # lateral clearance wanted beyond the two cars' half widths (m)
    length_gap_m: float = 1.0  # ... and lengthwise beyond a car length (m)
    risk_m: float = 60.0  # metres of progress a certain contact costs
    late_weight: float = 0.5  # a contact at the horizon weighs this share of one now
    behind_weight: float = 0.5  # a car behind us weighs this share (it is the one that must avoid)
    offset_m_per_m: float = 2.0  # cost of each metre of end offset from the line (it is slower)
    change_m_per_m: float = 0.5  # cost of each metre the end offset moves from the last plan's
    edge_m_per_m: float = 50.0  # cost of each metre beyond the drivable width
    switch_m: float = 20.0  # cost of passing a committed-to car on its other side
    commit_risk: float = 0.3  # ... unless the best on the committed side risks more than this
    commit_lengths: float = 1.0  # a pass is over once the car is this many lengths behind
    start_lengths: float = 3.0  # ... and under way once aside of a car within this many lengths ahead
    # a slower speed is chosen only when every path at the profile's speed risks more than this: the
    # brakes for the car ahead (robot/opponents.py) keep the gap when we follow; a plan's slower speed
    # for the whole horizon only loses time behind a car that a path at speed clears
    wait_risk: float = 0.5


@dataclass(frozen=True)
class Scene:
    """What a plan needs of us and the road, in the track's coordinates (see plan())."""

    v_mps: float  # our speed
    d_m: float  # our to_middle (m, + left)
    offset_m: float  # our offset from the racing line now (m)
    offset_rate_mps: float  # ... its rate (m/s)
    length_m: float  # our car's length and width (m)
    width_m: float
    profile_mps: np.ndarray  # our speed profile ahead at ahead_m (m/s)
    line_d_m: np.ndarray  # our racing line's to_middle ahead at ahead_m (m)
    left_m: np.ndarray  # the highest to_middle our centre may take ahead at ahead_m (m)
    right_m: np.ndarray  # ... the lowest (m)
    ahead_m: np.ndarray  # distances ahead of us those are sampled at (m, rising from 0)


@dataclass(frozen=True)
class Cars:
    """The other cars relative to us: their gap now and prediction (control/prediction.py)."""

    dist_m: np.ndarray  # centre to centre along the track now (m, + ahead), shape (cars,)
    width_m: np.ndarray  # their widths (m)
    length_m: np.ndarray  # their lengths (m)
    index: np.ndarray  # their car indices (for the commitment)
    pred: Prediction  # over the plan's times


@dataclass(frozen=True)
class Plan:
    """The chosen candidate: its end offset (m from the line), its speed scale, risk and cost, and
    the lateral polynomial to follow until the next plan (offset_at)."""

    end_offset_m: float
    speed_scale: float
    risk: float
    cost_m: float
    start_offset_m: float
    start_rate_mps: float
    lateral_s: float
    committed: int = -1  # the car index being passed (-1: none)
    side: float = 0.0  # the side we pass it on (+1 its left, -1 its right)

    def offset_at(self, t_s: float) -> float:
        """The offset (m) t_s after the plan was made (the quintic, then its end offset)."""
        x = min(1.0, max(0.0, t_s / self.lateral_s))
        x3 = x * x * x
        blend = x3 * (10.0 - 15.0 * x + 6.0 * x * x)
        rate_part = x - 6.0 * x3 + 8.0 * x3 * x - 3.0 * x3 * x * x
        return self.start_offset_m + (self.end_offset_m - self.start_offset_m) * blend \
            + self.start_rate_mps * self.lateral_s * rate_part


def normal_cdf(x: np.ndarray) -> np.ndarray:
    """The standard normal's distribution function, by its logistic approximation (within 0.01)."""
    return 1.0 / (1.0 + np.exp(-1.702 * np.clip(x, -20.0, 20.0)))


def overlap_probability(gap_m: np.ndarray, reach_m: np.ndarray, sigma_m: np.ndarray) -> np.ndarray:
    """The probability that a centre-to-centre distance predicted at gap_m (m) with spread sigma_m
    (one standard deviation, m, > 0) is within reach_m of zero (the two cars overlap)."""
    inv = 1.0 / sigma_m
    return normal_cdf((reach_m - gap_m) * inv) - normal_cdf((-reach_m - gap_m) * inv)


def blend_bases(t_s: np.ndarray, lateral_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The quintic's two bases at t_s (s): h(x) = 10x^3 - 15x^4 + 6x^5 takes the offset from its start to
    its end, g(x) = x - 6x^3 + 8x^4 - 3x^5 carries the starting rate (times lateral_s), x = t / lateral_s
    held at 1 after: both with zero rate and acceleration at the end."""
    if not (math.isfinite(lateral_s) and lateral_s > 0.0):
        raise ValueError(f"lateral_s must be positive, got {lateral_s}")
    x = np.clip(np.asarray(t_s, dtype=float) / lateral_s, 0.0, 1.0)
    return x ** 3 * (10.0 - 15.0 * x + 6.0 * x * x), x - 6.0 * x ** 3 + 8.0 * x ** 4 - 3.0 * x ** 5


@dataclass
class Planner:
    """The planner with what it keeps between plans: the last plan and the pass committed to."""

    p: PlannerParams = field(default_factory=PlannerParams)

    def __post_init__(self) -> None:
        p = self.p
        self.t_s = np.arange(int(round(p.horizon_s / p.dt_s)) + 1) * p.dt_s
        self.h, self.g = blend_bases(self.t_s, p.lateral_s)
        self.weight_t = 1.0 - (1.0 - p.late_weight) * self.t_s / p.horizon_s
        self.scales = np.asarray(p.speed_scales, dtype=float)
        self.last: Plan | None = None

    def _our_travel(self, sc: Scene) -> np.ndarray:
        """Our distance covered (m), shape (scales, times): the profile ahead times each scale, from our
        speed at the accel and decel limits."""
        p, t = self.p, self.t_s
        ahead = sc.v_mps * t  # first guess of where we are
        prof = np.interp(ahead, sc.ahead_m, sc.profile_mps)
        v = self.scales[:, None] * prof[None, :]
        v = np.clip(v, sc.v_mps - p.decel_mps2 * t, sc.v_mps + p.accel_mps2 * t)
        v = np.maximum(v, 0.0)
        travel = np.zeros(v.shape)
        np.cumsum(0.5 * (v[:, 1:] + v[:, :-1]) * np.diff(t), axis=1, out=travel[:, 1:])
        return travel

    def _end_offsets(self, sc: Scene) -> np.ndarray:
        """The end offsets tried (m from the line): evenly across the width at the end of the lateral
        move, and the offset of now."""
        at = sc.v_mps * self.p.lateral_s
        line = float(np.interp(at, sc.ahead_m, sc.line_d_m))
        lo = float(np.interp(at, sc.ahead_m, sc.right_m)) - line
        hi = float(np.interp(at, sc.ahead_m, sc.left_m)) - line
        if lo > hi:
            lo = hi = 0.5 * (lo + hi)
        return np.append(np.linspace(lo, hi, self.p.offsets), sc.offset_m)

    def plan(self, sc: Scene, cars: Cars) -> Plan:
        """The lowest-cost candidate (see the module's docstring) for the scene and cars, remembered for
        the next plan's change cost and commitment."""
        p = self.p
        ends = self._end_offsets(sc)
        lateral = sc.offset_m + (ends[:, None] - sc.offset_m) * self.h[None, :] \
            + sc.offset_rate_mps * p.lateral_s * self.g[None, :]  # (offsets, times)
        travel = self._our_travel(sc)  # (scales, times)
        line = np.interp(travel, sc.ahead_m, sc.line_d_m)  # (scales, times)
        d_me = line[None, :, :] + lateral[:, None, :]  # (offsets, scales, times)
        edge = np.maximum(d_me - np.interp(travel, sc.ahead_m, sc.left_m)[None], 0.0) \
            + np.maximum(np.interp(travel, sc.ahead_m, sc.right_m)[None] - d_me, 0.0)
        risk, side = self._risk(sc, cars, travel, d_me)  # (offsets, scales), side of the nearest car ahead
        progress = travel[:, -1].max() - travel[:, -1]
        cost = progress[None, :] + p.risk_m * risk + p.edge_m_per_m * edge.max(axis=2) \
            + p.offset_m_per_m * np.abs(ends)[:, None]
        if self.last is not None:
            cost = cost + p.change_m_per_m * np.abs(ends - self.last.end_offset_m)[:, None]
        committed, committed_side = self._commitment(cars)
        if committed >= 0:
            other = side[committed] != committed_side  # (offsets,) sides of the committed car
            keep = ~other[:, None] & np.ones_like(cost, dtype=bool)
            if keep.any() and risk[keep].min() <= p.commit_risk:
                cost = cost + p.switch_m * other[:, None]
        if risk[:, 0].min() <= p.wait_risk:  # a path at full speed is safe enough: only those (scale 1 first)
            cost[:, 1:] = np.inf
        i, j = np.unravel_index(int(np.argmin(cost)), cost.shape)
        return self._chosen(sc, cars, ends, side, int(i), int(j), float(risk[i, j]), float(cost[i, j]))

    def _risk(self, sc: Scene, cars: Cars, travel: np.ndarray, d_me: np.ndarray) -> tuple[np.ndarray, dict]:
        """Each candidate's risk (offsets, scales) and, per car index, the side of it (+1 left, -1
        right) each end offset passes it on."""
        p = self.p
        if cars.dist_m.size == 0:
            return np.zeros(d_me.shape[:2]), {}
        pred = cars.pred
        s_other = cars.dist_m[:, None] + pred.travel_m  # (cars, times), relative to our position now
        ds = s_other[None, :, :] - travel[:, None, :]  # (scales, cars, times)
        reach_s = (0.5 * (sc.length_m + cars.length_m) + p.length_gap_m)[None, :, None]
        over_s = overlap_probability(ds, reach_s, pred.sigma_s_m[None])  # (scales, cars, times)
        dd = pred.d_m[None, None, :, :] - d_me[:, :, None, :]  # (offsets, scales, cars, times)
        reach_d = (0.5 * (sc.width_m + cars.width_m) + p.gap_m)[:, None]  # (cars, 1)
        over_d = overlap_probability(dd, reach_d[None, None], pred.sigma_d_m[None, None])
        weight = np.where(cars.dist_m < 0.0, p.behind_weight, 1.0)[:, None] * self.weight_t[None, :]
        # the worst moment with each car, summed over the cars: a contact none of the candidates can
        # avoid (a car touching behind now) adds the same to each and hides no other car's
        risk = (over_d * (over_s * weight[None])[None]).max(axis=3).sum(axis=2)
        end_side = np.sign(d_me[:, 0, -1][:, None] - pred.d_m[:, -1][None, :])  # (offsets, cars)
        return risk, {int(k): end_side[:, n] for n, k in enumerate(cars.index.tolist())}

    def _commitment(self, cars: Cars) -> tuple[int, float]:
        """(car index, side) of a pass under way, or (-1, 0): the last plan's, while that car is still
        in sight and not yet commit_lengths behind us."""
        last = self.last
        if last is None or last.committed < 0:
            return -1, 0.0
        where = np.flatnonzero(cars.index == last.committed)
        k = where[0] if where.size else 0
        if where.size == 0 or not -self.p.commit_lengths < cars.dist_m[k] / cars.length_m[k] < self.p.start_lengths:
            return -1, 0.0
        return last.committed, last.side

    def _chosen(self, sc: Scene, cars: Cars, ends: np.ndarray, side: dict, i: int, j: int, risk: float,
                cost: float) -> Plan:
        """The plan for candidate (i, j), committed to passing the nearest car ahead within the horizon's
        reach when it moves us aside of that car."""
        committed, committed_side = self._commitment(cars)
        if committed < 0:
            ahead = np.flatnonzero((cars.dist_m > 0.0) & (cars.dist_m < self.p.start_lengths * cars.length_m))
            if ahead.size and abs(ends[i]) > 0.5:
                k = int(ahead[np.argmin(cars.dist_m[ahead])])
                committed, committed_side = int(cars.index[k]), float(side[int(cars.index[k])][i])
        plan = Plan(float(ends[i]), float(self.scales[j]), risk, cost, sc.offset_m, sc.offset_rate_mps,
                    self.p.lateral_s, committed, committed_side)
        self.last = plan
        return plan
