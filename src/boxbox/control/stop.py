"""Stopping at a point with a constant deceleration, and a cheap speed tracker.

The stop controller follows the idea of the ART autonomous vehicle navigator's stop controller (UT
Austin's ART project: constant deceleration instead of an exponential decay): with D metres left at
speed V, braking at A = V^2 / (2 D) reaches the point
exactly as the speed reaches zero, after T = 2 D / V.  A is recomputed every cycle, so errors of the
lower speed loop are corrected on the way.  Everything here is called per drive step: plain floats.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

# The commanded speed asks for "A less in one second": a speed loop with a 1 s time constant
# then decelerates at about A.
_HORIZON_S = 1.0


class StopStatus(Enum):
    OK = "ok"  # still driving or braking
    FINISHED = "finished"  # at the point (within the threshold) and standing still


@dataclass(frozen=True, slots=True)
class StopResult:
    speed_mps: float  # commanded speed
    status: StopStatus
    decel_mps2: float  # A = V^2 / (2 D) of this cycle (inf at or past the point)


class Stop:
    """Constant-deceleration stop at a distance ahead; latches once it starts stopping.

    max_decel_mps2: start stopping as soon as the needed deceleration reaches this (choose it from the
      car's grip, e.g. 0.5 * mu * g, so the stop stays well inside what the tyres can do).
    min_stop_dist_m: start stopping at the latest this close, whatever the speed.
    latency_s: time until a command acts; the distance is shortened by speed * latency.
    max_creep_dist_m: when the car stopped short by at most this, it creeps on at creep_speed_mps.
    stopped_speed_mps: below this the car counts as standing.
    """

    __slots__ = ("max_decel_mps2", "min_stop_dist_m", "latency_s", "max_creep_dist_m", "creep_speed_mps",
                 "stopped_speed_mps", "stopping", "creeping", "initial_speed_mps")

    def __init__(self, max_decel_mps2: float, min_stop_dist_m: float = 5.0, latency_s: float = 0.02,
                 max_creep_dist_m: float = 10.0, creep_speed_mps: float = 1.0,
                 stopped_speed_mps: float = 0.1) -> None:
        if max_decel_mps2 <= 0.0:
            raise ValueError("max_decel_mps2 must be > 0")
        self.max_decel_mps2 = max_decel_mps2
        self.min_stop_dist_m = min_stop_dist_m
        self.latency_s = latency_s
        self.max_creep_dist_m = max_creep_dist_m
        self.creep_speed_mps = creep_speed_mps
        self.stopped_speed_mps = stopped_speed_mps
        self.stopping = False
        self.creeping = False
        self.initial_speed_mps = 0.0

    def reset(self) -> None:
        self.stopping = False
        self.creeping = False
        self.initial_speed_mps = 0.0

    def control(self, command_speed_mps: float, speed_mps: float, distance_m: float, threshold_m: float,
                topspeed_mps: float = 3.0) -> StopResult:
        """Speed command for this cycle.

        command_speed_mps: the speed wanted if it were not yet time to stop.
        distance_m: to the stop point along the path (negative once past it).
        threshold_m: close enough; within it the command is 0.
        topspeed_mps: lower bound of the speed cap taken when stopping starts.
        """
        v = speed_mps if speed_mps > 0.0 else 0.0
        d = distance_m - v * self.latency_s  # where the car will be when this command acts
        decel = v * v / (2.0 * d) if d > 0.0 else math.inf

        if not self.stopping:
            if d > self.min_stop_dist_m and decel < self.max_decel_mps2:
                return StopResult(command_speed_mps, StopStatus.OK, decel)
            self.stopping = True
            # never command more than the speed at the latch (or topspeed when slower)
            self.initial_speed_mps = max(topspeed_mps, v)

        if d <= threshold_m:  # arrived or past: stand
            self.creeping = False
            status = StopStatus.FINISHED if v <= self.stopped_speed_mps else StopStatus.OK
            return StopResult(0.0, status, decel)

        if self.creeping or v <= self.stopped_speed_mps:  # standing short of the point
            if d <= self.max_creep_dist_m:
                self.creeping = True
                return StopResult(min(command_speed_mps, self.creep_speed_mps), StopStatus.OK, decel)
            # Far short: a standing car cannot follow "speed - A"; let the caller drive on again
            # (the stop latches anew on the way).
            self.reset()
            return StopResult(command_speed_mps, StopStatus.OK, decel)

        speed = min(command_speed_mps, v - decel * _HORIZON_S, self.initial_speed_mps)
        return StopResult(speed if speed > 0.0 else 0.0, StopStatus.OK, decel)


class SpeedTracker:
    """Pedals that track a target speed: P on the speed error plus feed-forward acceleration.

    The wanted acceleration is (target - speed) / tau + target_accel + resistance(speed); pedal =
    wanted / what a full pedal gives.  With tau = 1 s the speed command of `Stop` ("A less in one
    second") turns into a deceleration of A.  resistance = roll + drag_k * v^2 holds the speed on
    the throttle without a steady error (both 0 by default).
    """

    __slots__ = ("full_accel_mps2", "full_brake_mps2", "tau_s", "roll_mps2", "drag_k_per_m")

    def __init__(self, full_accel_mps2: float = 5.0, full_brake_mps2: float = 10.0, tau_s: float = 1.0,
                 roll_mps2: float = 0.0, drag_k_per_m: float = 0.0) -> None:
        if full_accel_mps2 <= 0.0 or full_brake_mps2 <= 0.0 or tau_s <= 0.0:
            raise ValueError("full_accel_mps2, full_brake_mps2 and tau_s must be > 0")
        self.full_accel_mps2 = full_accel_mps2
        self.full_brake_mps2 = full_brake_mps2
        self.tau_s = tau_s
        self.roll_mps2 = roll_mps2
        self.drag_k_per_m = drag_k_per_m

    def control(self, target_speed_mps: float, speed_mps: float,
                target_accel_mps2: float = 0.0) -> tuple[float, float]:
        """(accel, brake), each in [0, 1]; at most one of them is non-zero."""
        want = (target_speed_mps - speed_mps) / self.tau_s + target_accel_mps2
        if target_speed_mps > 0.0:  # resistance only matters while moving on purpose
            want += self.roll_mps2 + self.drag_k_per_m * speed_mps * speed_mps
        if want >= 0.0:
            a = want / self.full_accel_mps2
            return (a if a < 1.0 else 1.0), 0.0
        b = -want / self.full_brake_mps2
        return 0.0, (b if b < 1.0 else 1.0)


STOP_FEEDBACK_S = 0.1  # time constant of the correction towards the constant-deceleration trajectory


class StopDriver:
    """Pedals that bring the car to rest at the stop point: `Stop` plus a `SpeedTracker`.

    Once the stop latches, it brakes at the deceleration A0 of the latch (feed-forward) plus a
    correction towards the trajectory v = sqrt(2 A0 D) of a constant deceleration: a real car's
    pedal-to-deceleration gain varies with speed and grip, so feed-forward alone stops short or long.
    """

    __slots__ = ("stop", "tracker", "feedback_s", "a0_mps2")

    def __init__(self, stop: Stop, tracker: SpeedTracker | None = None, feedback_s: float = STOP_FEEDBACK_S) -> None:
        self.stop = stop
        self.tracker = tracker if tracker is not None else SpeedTracker()
        self.feedback_s = feedback_s
        self.a0_mps2: float | None = None

    def reset(self) -> None:
        self.stop.reset()
        self.a0_mps2 = None

    def control(self, command_speed_mps: float, speed_mps: float, distance_m: float, threshold_m: float,
                topspeed_mps: float = 3.0) -> tuple[float, float, StopResult]:
        """(accel, brake, result); before the latch the pedals track command_speed_mps."""
        r = self.stop.control(command_speed_mps, speed_mps, distance_m, threshold_m, topspeed_mps)
        v = speed_mps
        if not self.stop.stopping:
            accel, brake = self.tracker.control(r.speed_mps, v)
            return accel, brake, r
        left = distance_m - v * self.stop.latency_s
        if left <= threshold_m:
            return 0.0, 1.0, r
        if r.speed_mps >= v:  # creeping up to the point
            accel, brake = self.tracker.control(r.speed_mps, v)
            return accel, brake, r
        if self.a0_mps2 is None:
            self.a0_mps2 = max(r.decel_mps2, 0.5)
        v_path = math.sqrt(2.0 * self.a0_mps2 * left)
        _, brake = self.tracker.control(v, v, -(self.a0_mps2 + (v - v_path) / self.feedback_s))
        return 0.0, brake, r
