"""The default reward and the reasons an episode ends.

Reward per drive step: the progress along the track in metres (the change of the distance from
the start line, wrapped at the line), less `damage_weight` per damage point taken.  A step with the
car's centre beyond a track edge (not while the env drives a pit stop) earns `off_track_progress`
of its forward progress (0: cutting a corner gains nothing; going backwards still counts) and
costs `off_track_m`: 0.02 m a
drive step, 1 m a second, so a spell off the track (at most `off_track_s`, 2 s, before the episode
ends) costs at most 2 m, what 0.1 s of driving at 20 m/s earns: driving is worth it even for a
learner that often leaves the track, where standing still earns 0 (docs/gym.md has the arithmetic).
A callable `reward_fn(previous_state, state, info) -> float` replaces it (info holds
`progress_m` and `pit`, whether the env drove the step).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from boxbox import validate
from boxbox.gym.start import LapCount
from boxbox.model import State
from boxbox.model.constants import DRIVE_STEP_S
from boxbox.model.state import CAR_STATE_DNF, CAR_STATE_FINISH

RewardFn = Callable[[State, State, dict], float]
STUCK_SPEED_MPS = 1.0  # slower than this counts as stuck

# termination reasons (info["termination"])
RACE_END, OUT, DAMAGE, OFF_TRACK, STUCK, FAULT = "race-end", "out", "damage", "off-track", "stuck", "fault"
CAR_ENDINGS = (OUT, DAMAGE, OFF_TRACK, STUCK)  # what the car did: these terminate, the others truncate


@dataclass(frozen=True)
class RewardWeights:
    damage_weight: float = 0.1  # metres of progress one damage point costs
    off_track_m: float = 0.02  # metres of progress a drive step off the track costs (1 m a second)
    off_track_progress: float = 0.0  # the share of forward progress off the track that counts

    def __post_init__(self) -> None:
        for name in ("damage_weight", "off_track_m", "off_track_progress"):  # frozen: set through object
            object.__setattr__(self, name, validate.finite_number(getattr(self, name), name=name))


def progress_m(before: State, after: State, length_m: float) -> float:
    """Metres gained along the track between two states (negative backwards), across the line too."""
    d = after.dist_from_start_m - before.dist_from_start_m
    if d < -0.5 * length_m:
        d += length_m
    elif d > 0.5 * length_m:
        d -= length_m
    return d


def off_track(s: State) -> bool:
    """The car's centre beyond an edge of the track."""
    return s.to_left_m < 0.0 or s.to_right_m < 0.0


def default_reward(before: State, after: State, progress: float, weights: RewardWeights,
                   excused: bool = False) -> float:
    """`excused`: the env drives (a pit stop): the pit lane is not off the track."""
    damage_m = weights.damage_weight * max(0.0, after.damage - before.damage)
    if not excused and off_track(after):
        counted = weights.off_track_progress * progress if progress > 0.0 else progress
        return counted - damage_m - weights.off_track_m
    return progress - damage_m


@dataclass
class Limits:
    """When an episode terminates besides the race ending: None switches a limit off."""

    max_damage: float | None = None  # damage points (TORCS puts the car out at 10000 anyway)
    off_track_s: float | None = 2.0  # continuously off the track this long
    stuck_s: float | None = 5.0  # continuously slower than 1 m/s this long

    def __post_init__(self) -> None:
        for name in ("max_damage", "off_track_s", "stuck_s"):  # a positive number, or None for no limit
            object.__setattr__(self, name, validate.positive_limit(getattr(self, name), name=name))


class Watch:
    """Counts the drive steps off the track and stuck, and says when a limit is reached."""

    def __init__(self, limits: Limits) -> None:
        self.limits = limits
        self.off_steps_max = _steps(limits.off_track_s)
        self.stuck_steps_max = _steps(limits.stuck_s)
        self.off_steps = self.stuck_steps = 0
        self.lap_count = LapCount()  # the episode's, from reset(): its race's end and the lap observed

    def reset(self, lap_count: LapCount = LapCount()) -> None:  # noqa: B008 (frozen: one shared value is safe)
        self.off_steps = self.stuck_steps = 0
        self.lap_count = lap_count

    def update(self, s: State, excused: bool = False) -> str | None:
        """The reason to end the episode after this drive step, or None.  `excused`: the env drives
        (a pit stop), the car may be in the pit lane or stand still."""
        state = int(s.car_state)
        if state & CAR_STATE_FINISH or self.lap_count.over(s):
            return RACE_END
        if state & CAR_STATE_DNF:
            return OUT
        if self.limits.max_damage is not None and s.damage >= self.limits.max_damage:
            return DAMAGE
        if excused:
            self.off_steps = self.stuck_steps = 0
            return None
        self.off_steps = self.off_steps + 1 if off_track(s) else 0
        if self.off_steps > self.off_steps_max:
            return OFF_TRACK
        slow = s.sim_time_s > 0.0 and math.hypot(s.speed_x_mps, s.speed_y_mps) < STUCK_SPEED_MPS
        self.stuck_steps = self.stuck_steps + 1 if slow else 0
        if self.stuck_steps > self.stuck_steps_max:
            return STUCK
        return None


def _steps(seconds: float | None) -> float:
    return math.inf if seconds is None else seconds / DRIVE_STEP_S
