"""The planned way through traffic (TutorialParams.planner): each car near predicted over the next
seconds from what it was seen doing (control/prediction.py), our path through them chosen among
sampled candidates (control/frenet_planner.py), re-planned every `replan_steps` drive steps.

- `OpponentTracks` remembers, per car and per 5 m of track, the to_middle and speed each car was
  last seen at there, and how much they vary lap to lap (a car seen at a place more than
  `REVISIT_S` ago is compared with what it does there now);
- `TrafficPlanner.step` returns the overtaking offset for this step (the plan's lateral quintic,
  in place of the tutorial's overtaking offset: racecraft's bounds still apply to it) and the
  share of our speed profile the plan drives at (1: the profile; less: waiting behind).

Only ever called with a car near (robot/opponents.py `nearby`): a race alone never gets here.
Lapped cars (a lap or more down, they do not expect us) are predicted with `lapped_spread_m` more
lateral spread; on lap 1, with no car's line known yet, every car's line is unknown and spreads
as such (prediction.SpreadParams.unseen_lateral_mps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from boxbox.control.frenet_planner import Cars, Plan, Planner, PlannerParams, Scene
from boxbox.control.prediction import SpreadParams, predict_fast
from boxbox.model.constants import DRIVE_STEP_S
from boxbox.robot.opponents import Nearby

REVISIT_S = 10.0  # a place seen again after this long is another lap: compared for the variability
VARIABILITY_GAIN = 0.05  # share of each new lap-to-lap difference in the running variability
MAX_CARS = 64  # car indices TORCS gives (at most 40 cars in a race)
AHEAD_SAMPLES = 24  # samples of the road ahead a plan reads
MAX_RATE_MPS = 5.0  # the offset's rate a plan starts from, at most (the tutorial's step: 0.1 m a step)


class OpponentTracks:
    """Each car's to_middle (m) and speed (m/s) per step_m of track where last seen (NaN: never),
    and its lap-to-lap variability across (m) and in speed (m/s)."""

    def __init__(self, track_length_m: float, step_m: float) -> None:
        if not (track_length_m > 0.0 and step_m > 0.0 and math.isfinite(track_length_m + step_m)):
            raise ValueError(f"track length and step must be positive, got {track_length_m} m and {step_m} m")
        self.length_m = track_length_m
        self.n = max(1, int(track_length_m / step_m))
        self.mid = np.full((MAX_CARS, self.n), np.nan)
        self.speed = np.full((MAX_CARS, self.n), np.nan)
        self.seen_s = np.full((MAX_CARS, self.n), -math.inf)
        self.lat_var = np.zeros(MAX_CARS)
        self.speed_var = np.zeros(MAX_CARS)

    def observe(self, now_s: float, my_dist_m: float, cars: list[Nearby]) -> None:
        """Record each car where it is now (my_dist_m: our distance from the start)."""
        scale = self.n / self.length_m
        for c in cars:
            k = c.index
            if not 0 <= k < MAX_CARS:
                continue
            j = int(((my_dist_m + c.dist_m) % self.length_m) * scale) % self.n
            if now_s - self.seen_s[k, j] > REVISIT_S:  # a lap ago (never seen: -inf, and NaN below)
                old_mid, old_v = self.mid[k, j], self.speed[k, j]
                if old_mid == old_mid:
                    self.lat_var[k] += VARIABILITY_GAIN * (abs(c.mid_m - old_mid) - self.lat_var[k])
                    self.speed_var[k] += VARIABILITY_GAIN * (abs(c.speed_mps - old_v) - self.speed_var[k])
            self.mid[k, j], self.speed[k, j], self.seen_s[k, j] = c.mid_m, c.speed_mps, now_s


@dataclass(frozen=True)
class Road:
    """Per sample of our racing line (step_m apart, closed lap): the line's to_middle, our speed
    profile, and the highest and lowest to_middle our centre may take (m)."""

    step_m: float
    line_d_m: np.ndarray
    left_m: np.ndarray
    right_m: np.ndarray


class TrafficPlanner:
    """Prediction and planner for the tutorial robot (see the module's docstring)."""

    def __init__(self, road: Road, track_length_m: float, width_m: float, length_m: float,
                 params: PlannerParams | None = None, spread: SpreadParams | None = None,
                 replan_steps: int = 5, lapped_spread_m: float = 1.0) -> None:
        self.road, self.length_track_m = road, track_length_m
        self.width_m, self.length_m = width_m, length_m
        self.planner = Planner(params or PlannerParams())
        self.spread = spread or SpreadParams()
        self.tracks = OpponentTracks(track_length_m, 5.0)
        self.replan_steps, self.lapped_spread_m = replan_steps, lapped_spread_m
        self.plan: Plan | None = None
        self._plan_s = 0.0
        self._steps = 0
        self._last_offset_m = 0.0
        self._grid = np.linspace(0.0, 1.0, AHEAD_SAMPLES)

    def step(self, now_s: float, my_dist_m: float, v: float, my_mid_m: float, offset_m: float,
             cars: list[Nearby], profile_mps: np.ndarray) -> tuple[float, float]:
        """(the overtaking offset for this step (m from the line), the share of the speed profile to
        drive at): re-planned every replan_steps steps, the plan's lateral quintic in between."""
        # the rate of the offset the robot drove (racecraft bounds the plan's: the plan's own rate is not it)
        rate = max(-MAX_RATE_MPS, min(MAX_RATE_MPS, (offset_m - self._last_offset_m) / DRIVE_STEP_S))
        self._last_offset_m = offset_m
        if self._steps % self.replan_steps == 0 or self.plan is None:
            self.tracks.observe(now_s, my_dist_m, cars)
            self.plan = self.planner.plan(self._scene(my_dist_m, v, my_mid_m, offset_m, rate, profile_mps),
                                          self._cars(my_dist_m, cars))
            self._plan_s = now_s
        self._steps += 1
        return self.plan.offset_at(now_s - self._plan_s + DRIVE_STEP_S), self.plan.speed_scale

    def reset(self) -> None:
        """Nobody near: the next car met is planned for afresh."""
        self.plan, self._steps, self.planner.last, self._last_offset_m = None, 0, None, 0.0

    def _scene(self, my_dist_m: float, v: float, my_mid_m: float, offset_m: float, rate_mps: float,
               profile_mps: np.ndarray) -> Scene:
        road, p = self.road, self.planner.p
        ahead = self._grid * (max(0.0, v) * p.horizon_s + 3.0 * p.horizon_s * p.accel_mps2 + 10.0)
        n = road.line_d_m.shape[0]
        j = ((my_dist_m + ahead) / road.step_m).astype(np.int64) % n
        jp = ((my_dist_m + ahead) / road.step_m).astype(np.int64) % profile_mps.shape[0]
        return Scene(v, my_mid_m, offset_m, rate_mps, self.length_m, self.width_m, profile_mps[jp],
                     road.line_d_m[j], road.left_m[j], road.right_m[j], ahead)

    def _cars(self, my_dist_m: float, cars: list[Nearby]) -> Cars:
        """The cars within reach of the plan, predicted."""
        reach = [c for c in cars if -3.0 * self.length_m < c.dist_m < 150.0 and 0 <= c.index < MAX_CARS]
        idx = np.array([c.index for c in reach], dtype=np.int64)
        s0 = np.array([(my_dist_m + c.dist_m) % self.length_track_m for c in reach])
        d0 = np.array([c.mid_m for c in reach])
        v0 = np.array([c.speed_mps for c in reach])
        widths = np.array([c.width_m or self.width_m for c in reach])
        lat = self.tracks.lat_var[idx] + np.array([self.lapped_spread_m if c.laps_ahead < 0 else 0.0 for c in reach])
        t = self.planner.t_s
        pred = predict_fast(s0, d0, v0, self.tracks.mid[idx], self.tracks.speed[idx], self.length_track_m, t,
                            lat, self.tracks.speed_var[idx], self.spread)
        return Cars(np.array([c.dist_m for c in reach]), widths, np.full(len(reach), self.length_m), idx, pred)
