"""The pit brake filter: brake for the pit entry, keep the pit speed limit, stop at the own box.

Rebuilt over plain numbers from the TORCS robot tutorial's pit brake filter (chapter "Pit
stops"; bt's driver.cpp, filterBPit).  Positions are pit-path coordinates `s`:
metres along the track from the pit entry, negative (metres to go) while approaching it; the caller
maps distances from the start line (see robot.pitpath.PitPath.signed_coord).  The braking distance
is injected: brakedist(v_from_mps, v_to_mps, mu) -> metres.

Three fixes over the tutorial's filter (docs/pits.md: the tutorial's choices, retired, and their figures):
  1. the braking grip is the pit lane's own friction (e.g. PitPath.surface_friction times tyre mu)
     * surface_mu_scale, not a constant times the friction under the car;
  2. the entry is braked for only as needed to meet the speeds the pit path allows (entry_constraints,
     e.g. PitPath.entry_speed_constraints), the speed limit at its start and a stop at the box;
  3. pushed past the box by more than half a box length + GIVE_UP_MARGIN_M, or standing near the box
     uncaptured for longer than give_up_timeout_s -> stop holding the brakes, report gave_up (retry
     next lap).
stop_mode "constant-decel" replaces the tutorial's bang-bang final stop by control.stop.Stop.

Per drive step: floats only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from boxbox.control.stop import SpeedTracker, Stop, StopDriver, StopStatus
from boxbox.model.constants import G_MPS2

PIT_LOOKAHEAD_M = 6.0  # steering lookahead on the pit path: the turn into the box is tight
GIVE_UP_MARGIN_M = 2.0  # pushed this far past the box's end: the stop is given up

TORCS_CAPTURE_SPEED_MPS = 1.0  # the race engine captures a car slower than this in its box

BrakeDist = Callable[[float, float, float], float]

# phases (telemetry)
FREE = "free"  # nothing to do: input brake passes
ENTRY = "entry"  # braking for the pit entry
LIMIT = "limit"  # braking to / holding the speed limit before the box
LANE = "lane"  # in the pit lane on the way to the box, no braking needed yet
STOP = "stop"  # braking to stand at the box
HOLD = "hold"  # at or past the box centre, or captured: full brake
EXIT = "exit"  # on the pit path without a stop wanted: hold the limit until its end
GAVE_UP = "gave-up"  # the stop failed; brakes released (limit still held)


@dataclass(frozen=True, slots=True)
class PitBrakeResult:
    brake: float  # [0, 1]
    phase: str
    target_speed_mps: float | None = None  # speed the robot should not exceed (None: no pit limit)
    gave_up: bool = False


class PitBrakeFilter:
    """Per-track pit brake filter.  Positions in pit-path coordinates (see module doc).

    brakedist: (v_from_mps, v_to_mps, mu) -> metres.
    limit_start_m, box_m, limit_end_m: speed limit start, own box centre, speed limit end.
    speed_limit_mps: the speed to hold (already with a margin below the rule).
    pit_mu: the pit lane's own friction (surface friction times tyre mu); surface_mu_scale: the share
    of it the pit rules brake with.
    stop_max_decel_mps2: deceleration of the constant-decel stop (default 0.5 * pit_mu * g).
    `mu` is the total friction (surface friction times tyre mu) as brakedist expects it.
    """

    def __init__(self, brakedist: BrakeDist, *, limit_start_m: float, box_m: float, limit_end_m: float,
                 speed_limit_mps: float, box_length_m: float = 15.0, pit_mu: float = 1.0,
                 surface_mu_scale: float = 0.9, entry_constraints: Sequence[tuple[float, float]] = (),
                 stop_mode: str = "bang-bang", stop_threshold_m: float = 0.5,
                 stop_max_decel_mps2: float | None = None, tracker: SpeedTracker | None = None,
                 give_up_timeout_s: float = 5.0) -> None:
        if stop_mode not in ("bang-bang", "constant-decel"):
            raise ValueError(f"stop_mode must be 'bang-bang' or 'constant-decel', got {stop_mode!r}")
        if not limit_start_m <= box_m + box_length_m or not box_m <= limit_end_m:
            raise ValueError("expected limit_start_m <= box_m (+ box length) <= limit_end_m")
        self.brakedist = brakedist
        self.limit_start_m = limit_start_m
        self.box_m = box_m
        self.limit_end_m = limit_end_m
        self.speed_limit_mps = speed_limit_mps
        self.box_length_m = box_length_m
        self.pit_mu = pit_mu
        self.surface_mu_scale = surface_mu_scale
        self.mu = pit_mu * surface_mu_scale  # the braking grip of every pit rule
        # only constraints before the box matter; in path order, so the nearest binding one is reported
        self.entry_constraints = tuple(sorted((float(s), float(v)) for s, v in entry_constraints if s < box_m))
        self.stop_mode = stop_mode
        self.stop_threshold_m = stop_threshold_m
        # constant-decel stop: half the pit lane's grip unless told
        decel = 0.5 * pit_mu * G_MPS2 if stop_max_decel_mps2 is None else stop_max_decel_mps2
        self.stop = Stop(decel)
        self.tracker = tracker if tracker is not None else SpeedTracker()
        self.stop_driver = StopDriver(self.stop, self.tracker)
        self.give_up_past_m = box_length_m / 2.0 + GIVE_UP_MARGIN_M
        self.give_up_near_m = box_length_m / 2.0
        self.give_up_timeout_s = give_up_timeout_s
        self.gave_up = False
        self.standing_s = 0.0

    def reset(self) -> None:
        """Forget the current attempt (called by itself when the stop is no longer wanted)."""
        self.gave_up = False
        self.standing_s = 0.0
        self.stop_driver.reset()

    def filter(self, brake: float, speed_mps: float, s_m: float, stop_wanted: bool, on_path: bool,
               in_pit: bool = False, dt_s: float = 0.02) -> PitBrakeResult:
        """Brake for this step.

        brake: the robot's own brake; speed_mps: current speed; s_m: position (negative before the
        entry); stop_wanted: a stop is planned and not yet done; on_path: the car drives the pit path;
        in_pit: captured by the race engine
        (State.in_pit; pass it, or the give-up timeout counts the standing time of the stop itself);
        dt_s: time since the last call (for the give-up timeout).
        With stop_mode "constant-decel" the robot should also track target_speed_mps with its
        throttle (e.g. a SpeedTracker): the stop may ask to creep up to the box.
        """
        if not stop_wanted:
            if self.gave_up or self.standing_s or self.stop.stopping:
                self.reset()
        elif not on_path and (self.gave_up or s_m >= 0.0):
            # given up and off the path, or driving past the pit: the next attempt is next lap
            if self.gave_up or self.standing_s or self.stop.stopping:
                self.reset()

        if stop_wanted and not self.gave_up:
            if on_path:
                if in_pit:  # captured: keep still while the crew works
                    self.standing_s = 0.0
                    return PitBrakeResult(1.0, HOLD, 0.0)
                if self._check_give_up(speed_mps, s_m, dt_s):
                    self.gave_up = True
                    self.stop_driver.reset()
                else:
                    return self._to_box(brake, speed_mps, s_m, True)
            elif s_m < 0.0:
                return self._to_box(brake, speed_mps, s_m, False)

        if not on_path:
            return PitBrakeResult(brake, FREE)
        # leaving (or given up): hold the limit until its end, as the tutorial's filter does on the way out
        phase = GAVE_UP if self.gave_up else EXIT
        limit = self.speed_limit_mps
        if s_m < self.limit_end_m:
            return PitBrakeResult(1.0 if speed_mps > limit else brake, phase, limit, self.gave_up)
        return PitBrakeResult(brake, phase, None, self.gave_up)

    def _to_box(self, brake: float, v: float, s: float, on_path: bool) -> PitBrakeResult:
        """A stop wanted, approaching the entry (on_path False, s < 0) or on the pit path.

        The rules that want full brakes are checked first (any of them wins, as in the tutorial's
        filter); then the constant-deceleration stop, if selected."""
        mu = self.mu
        bd = self.brakedist
        limit = self.speed_limit_mps
        full = ""
        target: float | None = None
        for s_c, v_c in self.entry_constraints:
            if s_c > s and v > v_c and bd(v, v_c, mu) > s_c - s:
                full, target = ENTRY, v_c
                break
        if not full:
            if s < self.limit_start_m:
                if v > limit and bd(v, limit, mu) > self.limit_start_m - s:
                    full, target = LIMIT, limit
            elif v > limit:
                full, target = LIMIT, limit
        if not full and self.stop_mode == "bang-bang":
            if s >= self.box_m:  # at or past the centre: stand on the brakes
                full, target = HOLD, 0.0
            elif bd(v, 0.0, mu) > self.box_m - s:
                full, target = STOP, 0.0

        if self.stop_mode == "constant-decel":
            # run every step while a stop is wanted so the latch happens at the right moment
            command = limit if s >= self.limit_start_m else math.inf
            _, b, r = self.stop_driver.control(command, v, self.box_m - s, self.stop_threshold_m, topspeed_mps=limit)
            if self.stop.stopping and not full:
                if b >= 1.0:  # at the box
                    return PitBrakeResult(1.0, HOLD if r.status is StopStatus.FINISHED else STOP, 0.0)
                return PitBrakeResult(b, STOP, r.speed_mps)

        if full:
            return PitBrakeResult(1.0, full, target)
        if on_path:
            return PitBrakeResult(brake, LANE, limit if s >= self.limit_start_m else None)
        return PitBrakeResult(brake, FREE)

    def _check_give_up(self, v: float, s: float, dt_s: float) -> bool:
        if s - self.box_m > self.give_up_past_m:
            return True
        if v < TORCS_CAPTURE_SPEED_MPS and abs(self.box_m - s) <= self.give_up_near_m:
            self.standing_s += dt_s
        else:
            self.standing_s = 0.0
        return self.standing_s > self.give_up_timeout_s


__all__ = ["EXIT", "ENTRY", "FREE", "GAVE_UP", "GIVE_UP_MARGIN_M", "HOLD", "LANE", "LIMIT", "PIT_LOOKAHEAD_M",
           "STOP", "BrakeDist", "PitBrakeFilter", "PitBrakeResult"]
