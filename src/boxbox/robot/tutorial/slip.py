"""Wheel slip: ABS on the brake, traction control on the throttle (with the share of the grip the
turn leaves, and the drive force the axles hold where the tyre falls past its peak), and the
throttle guards at the steering lock and while the rear steps out."""

from __future__ import annotations

import math

import numpy as np

from boxbox.control import tyre
from boxbox.control.engine import engine_brake_share
from boxbox.control.traction import (
    SlipParams,
    abs_filter,
    abs_hold,
    combined_slip_room,
    drive_axles,
    drive_force_room_n,
    driven_wheel_speed_mps,
    spare_slip_ratio,
    tcl_from_slip,
    throttle_for_torque,
)
from boxbox.model import Car, State
from boxbox.model.car import FWD, RWD, STEERING_WHEELBASE_SHARE
from boxbox.model.constants import DRIVE_STEP_S, G_MPS2
from boxbox.model.skill import SkillLevel
from boxbox.robot.base import Robot
from boxbox.robot.params import TutorialParams
from boxbox.robot.racingline import RacingLine

LOCK_SHARE = 0.95  # |steer| from which the steering counts as at its lock
LOCK_MIN_SPEED_MPS = 10.0  # below this (leaving the grid onto the line) full lock is no sign of a slide


class WheelSlip(Robot):
    """ABS, traction control and the throttle guards."""

    # the plan of the track (plan.py) read here
    params: TutorialParams
    line: RacingLine
    n: int
    step_m: float
    _curv: list[float]
    _corner_mu: list[float]
    _k_per_mu: list[float]
    _ca_per_kg: float

    def _setup_slip(self, car: Car, p: TutorialParams) -> None:
        """ABS and traction control, and what the level's tyre lets the throttle use in a turn."""
        self.radii = (car.wheel_radius_fr_m, car.wheel_radius_fl_m, car.wheel_radius_rr_m, car.wheel_radius_rl_m)
        shape = (car.tyre_stiffness_rr, car.tyre_dynamic_friction_rr, car.tyre_elasticity_rr)
        peak = tyre.peak_slip(*shape)
        # a tyre whose force never peaks (dynamic friction 1: the buggy's) gives no slip ratio to aim
        # for: the tutorial's fixed slip (with the ratio the buggy hit g-track-1's wall every lap)
        self._peak_slip = peak if peak < tyre.MAX_SLIP else 0.0
        # where the level's tyre loses force past its peak (pro), the throttle is gone before the
        # driven wheels' slip has grown by the peak's ratio (mixed-2 at pro: a spin out of a hairpin
        # in first gear at 44 % slip, which the tutorial's 10 m/s range allowed at 16 m/s)
        holds = self._peak_slip > 0.0 and tyre.falls_past_peak(*shape, SkillLevel(car.skill_level).skid_factor)
        self._holds_peak = holds and len(car.torque_curve_nm) >= 2
        # the weight on the front axle is the CG's share of the wheelbase behind it
        # (in this order: the product rounds as the robot's measured figures had it)
        self._cg_to_rear_m = car.front_weight_share * STEERING_WHEELBASE_SHARE * car.length_m
        self._axles = drive_axles(car)
        self._drive_radius_m = car.wheel_radius_fr_m if car.drivetrain == FWD else car.wheel_radius_rr_m
        self.slip = SlipParams(abs_slip_mps=p.abs_slip_mps, abs_range_mps=p.abs_range_mps,
                               tcl_slip_mps=p.tcl_slip_mps, tcl_slip_ratio=p.tcl_slip_ratio,
                               tcl_range_mps=p.tcl_range_mps, tcl_range_ratio=peak if holds else math.inf,
                               abs_min_speed_mps=p.slip_min_speed_mps, tcl_min_speed_mps=p.slip_min_speed_mps,
                               abs_hold_over_mps=p.abs_hold_over_mps, abs_hold_share=p.abs_hold_share)
        self._abs_brake, self._abs_at_s = 0.0, -math.inf  # the brake the last drive step gave, and when
        self._profile_mps = math.inf  # the speed profile's target this drive step (_speed)

    def _traction(self, s: State, v: float, brake: float, accel: float, traffic: bool) -> tuple[float, float]:
        """ABS on the brake (its bang held off far over the target: abs_hold), or traction control on
        the throttle (never both)."""
        spins = (s.spin_fr_rps, s.spin_fl_rps, s.spin_rr_rps, s.spin_rl_rps)
        last = self._abs_brake if s.sim_time_s - self._abs_at_s < 1.5 * DRIVE_STEP_S else 0.0
        self._abs_at_s, self._abs_brake = s.sim_time_s, 0.0
        if brake > 0.0:
            filtered = abs_filter(brake, v, spins, self.radii, self.slip)
            # over the profile's own speed, not a target traffic lowered at once (a target lowered by
            # a share for a car ahead: g-track-1 from the back, held 19 m/s over it, 118 damage against 37)
            self._abs_brake = abs_hold(brake, filtered, last, v - self._profile_mps, self.slip)
            return self._abs_brake, 0.0
        if accel == 0.0 or v < self.slip.tcl_min_speed_mps:
            return 0.0, accel
        slip_mps = driven_wheel_speed_mps(spins, self.radii, self.car.drivetrain) - v
        if slip_mps <= self.slip.tcl_slip_mps:  # within the least slip allowed: no turn share needed
            return 0.0, accel
        if traffic:
            # off the line among cars the turn's share is not the line's: the tutorial's 2 m/s (with
            # the slip ratio, 30 field races lost 35 places and took 85k damage, not 46k: racecraft.md)
            return 0.0, tcl_from_slip(accel, v, slip_mps, self.slip, 0.0)
        v2 = v * v
        share = v2 * self._k_per_mu[int(s.dist_from_start_m / self.step_m) % self.n] / (G_MPS2 + v2 * self._ca_per_kg)
        room = spare_slip_ratio(self._peak_slip, share)
        if self.car.drivetrain == RWD:
            # the rear axle's own lateral slip, measured: the body's side speed plus the yaw's at the
            # axle (car1-ow1 out of e-track-2's 37 m/s right-hander at 13 deg body slip spun with 27 %
            # wheelspin, which the turn's share alone allowed)
            room = min(room, combined_slip_room(self._peak_slip, self._rear_side_slip(s, v)))
        return 0.0, tcl_from_slip(accel, v, slip_mps, self.slip, room)

    def _drive_room(self, s: State, v: float, accel: float) -> float:
        """Where the level's tyre loses force past its peak (pro): no more throttle than the drive force
        the axles can hold beside the turn (control/traction.py: drive_force_room_n, with the load the
        force moves rearwards off the steering front), through the engine's torque at part throttle,
        which the engine brake lowers (g-track-1's long turn at pro, full throttle at 44 m/s, spun;
        with the rear axle's static load alone and the torque taken as linear in the throttle, dirt-2
        at pro came out of its slow turns on 0.4 throttle at 3 % wheelspin)."""
        gear = int(s.gear)
        if not self._holds_peak or accel == 0.0 or gear < 1 or v < self.slip.tcl_min_speed_mps:
            return accel
        i = int(s.dist_from_start_m / self.step_m) % self.n
        room_n = drive_force_room_n(self._axles, self._corner_mu[i], v, self._curv[i])
        car = self.car
        torque_nm = float(np.interp(s.rpm, car.torque_curve_radps, car.torque_curve_nm))
        full_n = torque_nm * car.gear_ratio(gear) / self._drive_radius_m
        if full_n <= room_n:
            return accel
        brake = engine_brake_share(s.rpm, car.engine_tickover_radps, car.engine_revs_max_radps, car.engine_brake_coeff)
        return min(accel, throttle_for_torque(room_n / full_n, brake))

    def _rear_side_slip(self, s: State, v: float) -> float:
        """The rear axle's lateral slip: the body's side speed plus the yaw's at the axle, over the speed."""
        return (s.speed_y_mps - self._cg_to_rear_m * s.yaw_rate_rps) / v

    def _release_engine_brake(self, s: State, v: float, brake: float, accel: float) -> float:
        """Coasting where the level's tyre loses force past its peak (pro), with the driven rear sliding
        sideways at or past it (combined_slip_room 0: no grip left along the tyre): the throttle at which
        the engine drives nothing, rather than its brake dragging the sliding rear round (mixed-1 at
        pro: off the throttle in a first-gear S-bend at 22 m/s, the rear slid out, 347 damage)."""
        if (not self._holds_peak or accel > 0.0 or brake > 0.0 or self.car.drivetrain != RWD or s.gear < 1
                or v < self.slip.tcl_min_speed_mps
                or combined_slip_room(self._peak_slip, self._rear_side_slip(s, v)) > 0.0):
            return accel
        car = self.car
        return throttle_for_torque(0.0, engine_brake_share(s.rpm, car.engine_tickover_radps,
                                                           car.engine_revs_max_radps, car.engine_brake_coeff))

    def _guard_throttle(self, s: State, v: float, steer: float, accel: float) -> float:
        """Less throttle when the tyres have no grip to spare: at the steering lock (lock guard) and
        while the rear steps out (spin guard)."""
        if accel == 0.0:
            return accel
        p = self.params
        line_k = self.line.curvature_at(s.dist_from_start_m)
        if abs(steer) >= LOCK_SHARE and v > LOCK_MIN_SPEED_MPS:
            # counter-steering at the lock (steer against the line's turn): the rear is out
            accel = min(accel, p.counter_lock_accel if steer * line_k < 0.0 else p.lock_accel)
        # the car turns faster than its line and against the steering: power would spin it
        # (dirt-2's S-bends at 13 m/s in first gear)
        excess = s.yaw_rate_rps - v * line_k
        if excess * steer < 0.0 and abs(excess) > p.spin_yaw_rate_rps:
            accel = 0.0
        return accel
