"""Where an episode starts: a point along the track drawn from the seed, and a short launch.

TORCS places the cars from the race file's starting grid (its race engine: the pole `distance to
start` metres behind the start line, the others behind it, `torcs/racefile.py`), so the env writes
the distance that puts the learning car at the drawn point of the lap; every other car of the grid
stays where the grid puts it, behind.  A track whose own file sets the grid (alpine-1, corkscrew,
spring, wheel-2: TORCS reads the track's "Starting Grid" over the race file's) starts from its grid.
TORCS places every car on the track's axis direction at rest (the race file's "initial speed" is
braked away during the start countdown: 10 m/s there left the car at rest at 0 s, turned 0.21 rad),
so the speed and heading perturbation is a launch: the first drive steps, with a drawn throttle and
steering, driven in the race's set-up (gym/race.py: a spare race drives them ahead, while the last
episode runs), and the episode begins after them.

A start along the lap is a point of the race from the grid (`LapCount`): TORCS counts a car on lap 0
until it first crosses the start line, so a car put down along the lap would be seen on lap 0 where
the grid's car is on lap 1, and would race a lap more.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boxbox.model import State
from boxbox.torcs.racefile import GRID_TO_START_M, grid_offset_m

# drive steps: up to 1 s; car1-trb1 from rest at full throttle makes 1.6 m/s in 0.5 s, 4.2 m/s in 1 s
# (0.4 throttle: 1.5 m/s in 1 s)
LAUNCH_MAX_STEPS = 50
LAUNCH_THROTTLE = (0.5, 1.0)
LAUNCH_STEER = 0.5  # of full lock: up to about 0.05 rad of heading by the end of the launch (car1-trb1)
EDGE_MARGIN_M = 1.0  # every car of the grid this far from the start line (before it, the engine's search loops)


@dataclass(frozen=True)
class Start:
    """An episode's start: `fraction` of the lap where the learning car (the first one) stands
    (None: the grid's own place), and the launch the reset drives before the first observation."""

    fraction: float | None = None
    launch_steps: int = 0
    launch_throttle: float = 0.0
    launch_steer: float = 0.0


GRID_START = Start()


def draw_start(rng: np.random.Generator) -> Start:
    """A start anywhere along the lap, with a launch of 0 to LAUNCH_MAX_STEPS drive steps."""
    return Start(float(rng.random()), int(rng.integers(0, LAUNCH_MAX_STEPS + 1)),
                 float(rng.uniform(*LAUNCH_THROTTLE)), float(rng.uniform(-LAUNCH_STEER, LAUNCH_STEER)))


def grid_to_start_m(fraction: float | None, length_m: float, slot_index: int, cars: int) -> float:
    """The race file's `distance to start` that puts the car of grid slot `slot_index` (0: the pole)
    `fraction` of the way along the stretch of the lap it can stand on: the pole at least
    EDGE_MARGIN_M behind the start line and the last of the `cars` at least EDGE_MARGIN_M past it.
    The grid's own distance when `fraction` is None or the grid is longer than the track."""
    ours, last = grid_offset_m(slot_index), grid_offset_m(cars - 1)
    low = last - ours + EDGE_MARGIN_M  # where the car may stand, metres from the start line
    high = length_m - ours - EDGE_MARGIN_M
    if fraction is None or high < low:
        return GRID_TO_START_M
    at_m = low + fraction * (high - low)
    return length_m - at_m - ours


@dataclass(frozen=True)
class LapCount:
    """The laps as the env counts them.  From the grid, TORCS's own.  From a start along the lap
    (`along`), the car is on lap 1 until it first crosses the line (TORCS says 0) and its race is
    over at the line that ends its `laps`-th lap (TORCS's a lap later): every start is a point of
    the grid's race.  Counted as TORCS counts, PPO's deterministic lap from the grid (lap 1 from the
    line on) met states it had rarely trained in, starts along the lap being on lap 0 until the line
    (docs/gym.md, Varied episodes)."""

    laps: int = 1
    along: bool = False

    @property
    def added(self) -> float:
        """The laps the env's count adds to TORCS's (the `lap` observation's)."""
        return 1.0 if self.along else 0.0

    def over(self, s: State) -> bool:
        """The race is over for the car at this state as the env counts (TORCS's own end aside)."""
        return self.along and s.laps >= self.laps


def lap_count(laps: int, grid_to_start_m: float) -> LapCount:
    """The count for a race of `laps` whose grid the race file puts `grid_to_start_m` behind the
    line (moved from the grid's own place: a start along the lap)."""
    return LapCount(laps, grid_to_start_m != GRID_TO_START_M)
