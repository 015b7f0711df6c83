"""The race's time model: a budget per robot call, and race limits derived from them.

* **Step budget** (`--step-budget-ms`, default 200 ms): the wall time a Python robot may take to
  answer one drive step. The bridge enforces it: past it, the race is stopped (a hang).
* **Set-up budget** (`--setup-budget-s`, default 120 s): the same for `initial_fuel_l`, `on_track`,
  `pit_stop` and `on_race_end`.
* **Simulated-time limit**: a race may last `laps x track length / min_speed_mps` seconds of
  simulated time (an average of 5 m/s by default, far below any car that is racing). The robot host
  enforces it: a car that is stuck, or a robot that never drives off, cannot keep a race going.
* **Wall limit**: the sum of every budget the race could use in full: a start-up allowance, the
  set-up calls (2 before the start and at most a pit stop a lap, per Python car), and each step of
  the simulated-time limit (50 a second) taking every Python robot's step budget plus a
  millisecond per car for TORCS itself. A robot that keeps within its budgets is therefore never
  stopped for being slow overall; the wall limit only catches TORCS itself hanging.
* **Stall limit**: once the race is under way the robot host tells the launcher every
  HEARTBEAT_S of wall time that TORCS still calls it; silence for longer than a set-up budget, a
  step budget, a heartbeat and STALL_MARGIN_S together means TORCS stopped calling the robots
  (torcs-bin has been seen spinning at full CPU mid-race; the wall limit would wait hours).

All four can be set (RaceConfig: `step_budget_ms`, `setup_budget_ms`, `min_speed_mps`,
`wall_limit_s` to replace the derived wall limit); docs/reliability.md shows the figures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from boxbox.model.constants import DRIVE_STEP_S

STEP_S = DRIVE_STEP_S  # TORCS calls a robot's drive every 0.02 s of simulated time
MIN_SPEED_MPS = 5.0  # the slowest average a race is allowed (18 km/h)
START_S = 30.0  # processes starting, TORCS loading the track and cars
ENGINE_S_PER_CAR_STEP = 0.001  # TORCS's own work per car and step, with a wide margin (it is ~20 us)
UNKNOWN_TRACK_M = 25_000.0  # before the track's length is known (the longest installed: spring, 22.1 km)
SETUP_CALLS_BEFORE_START = 3  # connecting, initial_fuel_l, on_track
HEARTBEAT_S = 1.0  # the robot host says it is still being called this often (wall time)
STALL_MARGIN_S = 5.0  # scheduling on a busy machine, on top of the longest legitimate silence


@dataclass(frozen=True)
class TimeModel:
    step_budget_ms: float
    setup_budget_ms: float
    min_speed_mps: float = MIN_SPEED_MPS

    def sim_limit_s(self, laps: int, length_m: float) -> float:
        """Simulated time the race may last."""
        return laps * length_m / self.min_speed_mps

    def steps(self, laps: int, length_m: float) -> int:
        """Drive steps per car in a race that lasts its whole simulated-time limit."""
        return math.ceil(self.sim_limit_s(laps, length_m) / STEP_S)

    def start_limit_s(self, python_cars: int) -> float:
        """Wall time until the first drive step: start-up and every robot's set-up calls."""
        return START_S + python_cars * SETUP_CALLS_BEFORE_START * self.setup_budget_ms / 1000

    def stall_limit_s(self) -> float:
        """Wall time without a word from the robot host, once it is being called, after which
        TORCS has stopped calling it: the longest call (a set-up call, a pit stop's included), a
        step, the heartbeat's period and a margin."""
        return (self.setup_budget_ms + self.step_budget_ms) / 1000 + HEARTBEAT_S + STALL_MARGIN_S

    def wall_limit_s(self, laps: int, length_m: float | None, python_cars: int, cars: int) -> float:
        """Wall time the whole race may take when every call uses its full budget."""
        steps = self.steps(laps, UNKNOWN_TRACK_M if length_m is None else length_m)
        per_step_s = python_cars * self.step_budget_ms / 1000 + cars * ENGINE_S_PER_CAR_STEP
        pit_stops = python_cars * laps * self.setup_budget_ms / 1000
        return self.start_limit_s(python_cars) + pit_stops + steps * per_step_s
