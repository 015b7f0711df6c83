"""ABS and traction control from wheel slip (m/s), with the shipped tutorial robot's numbers.

Wheel tuples are in TORCS order: front right, front left, rear right, rear left; spins in rad/s
(`wheel_spin_rps`: radians per second, as TORCS reports them), radii in m.
Called per drive step: floats only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from boxbox.control.carmodel import axle_downforce_coefficients
from boxbox.model.car import AWD, FWD, RWD, Car
from boxbox.model.constants import G_MPS2

Wheels = tuple[float, float, float, float]


@dataclass(frozen=True)
class SlipParams:
    abs_slip_mps: float = 2.0  # ABS acts above this slip
    abs_range_mps: float = 5.0  # brake is released fully at abs_slip + abs_range
    abs_min_speed_mps: float = 3.0  # below this wheel speeds say little: leave the brake alone
    # where the car runs more than this over its target speed (every bit of braking counts), a full
    # release straight after a step at full pressure keeps abs_hold_share of it (abs_hold; inf: never)
    abs_hold_over_mps: float = math.inf
    abs_hold_share: float = 0.5
    tcl_slip_mps: float = 2.0
    # and above this share of the car's speed: a tyre's force peaks at a slip *ratio* (simuv2's
    # magic formula), so a fixed 2 m/s cuts the throttle far below the peak at speed
    tcl_slip_ratio: float = 0.0
    tcl_range_mps: float = 10.0
    tcl_min_speed_mps: float = 3.0
    # the range as a share of the car's speed, where less: where the level's tyre force falls past its
    # peak (pro), the throttle is gone by the time the slip has grown by the peak's slip ratio
    # (control/tyre.py: holds_peak); inf: the fixed range alone
    tcl_range_ratio: float = math.inf


DEFAULT_SLIP = SlipParams()


def abs_filter(
    brake: float, speed_mps: float, wheel_spin_rps: Wheels, wheel_radii_m: Wheels, params: SlipParams = DEFAULT_SLIP
) -> float:
    """Brake reduced by (slip - 2) / 5 when the wheels turn slower than the car by more than 2 m/s."""
    if speed_mps < params.abs_min_speed_mps:
        return brake
    wheels_mps = (
        wheel_spin_rps[0] * wheel_radii_m[0]
        + wheel_spin_rps[1] * wheel_radii_m[1]
        + wheel_spin_rps[2] * wheel_radii_m[2]
        + wheel_spin_rps[3] * wheel_radii_m[3]
    ) * 0.25
    slip_mps = speed_mps - wheels_mps
    if slip_mps > params.abs_slip_mps:
        brake -= (slip_mps - params.abs_slip_mps) / params.abs_range_mps
        if brake < 0.0:
            brake = 0.0
    return brake


FULL_BRAKE = 0.9  # a drive step at this brake or more was at full pressure (abs_hold)


def abs_hold(requested: float, brake: float, last_brake: float, over_mps: float,
             params: SlipParams = DEFAULT_SLIP) -> float:
    """The ABS's `brake` (abs_filter of `requested`), kept at abs_hold_share of the last drive step's
    brake where that was full pressure and the ABS would now release more, while the car runs
    `over_mps` > abs_hold_over_mps over its target speed.  Where the brakes lock the front wheels
    within one drive step the tutorial's ABS bangs: full pressure, slip past 15 %, released fully,
    the wheels spin up, full again (car1-stock1 into street-1's hairpin from 81 m/s: 19 m/s^2, up
    to 13 m/s over its target, 13 too fast at the turn); held at half after a full step the brake
    swings between about 0.45 and 0.95 (22.7 m/s^2).  Only far over the target: where the car keeps
    to its plan the bang costs nothing the plan did not allow for (docs/tutorial-robot.md item 25)."""
    held = params.abs_hold_share * last_brake
    if over_mps > params.abs_hold_over_mps and last_brake >= FULL_BRAKE and brake < held:
        return min(requested, held)
    return brake


def driven_wheel_speed_mps(wheel_spin_rps: Wheels, wheel_radii_m: Wheels, drivetrain: int) -> float:
    """Mean surface speed of the driven wheels: RWD rear, FWD front, AWD all four."""
    front = (wheel_spin_rps[0] * wheel_radii_m[0] + wheel_spin_rps[1] * wheel_radii_m[1]) * 0.5
    rear = (wheel_spin_rps[2] * wheel_radii_m[2] + wheel_spin_rps[3] * wheel_radii_m[3]) * 0.5
    if drivetrain == RWD:
        return rear
    if drivetrain == FWD:
        return front
    if drivetrain == AWD:
        return (front + rear) * 0.5
    raise ValueError(f"unknown drivetrain {drivetrain!r}")


def tcl_filter(
    accel: float,
    speed_mps: float,
    wheel_spin_rps: Wheels,
    wheel_radii_m: Wheels,
    drivetrain: int,
    params: SlipParams = DEFAULT_SLIP,
    max_ratio: float = math.inf,
) -> float:
    """Throttle reduced by (slip - allowed) / 10 when the driven wheels outrun the car by more than the
    allowed slip: 2 m/s, or tcl_slip_ratio (at most `max_ratio`) x the car's speed where that is
    more. `max_ratio`: the slip the turn leaves the tyre (spare_slip_ratio)."""
    if speed_mps < params.tcl_min_speed_mps:
        return accel
    slip_mps = driven_wheel_speed_mps(wheel_spin_rps, wheel_radii_m, drivetrain) - speed_mps
    return tcl_from_slip(accel, speed_mps, slip_mps, params, max_ratio)


def tcl_from_slip(accel: float, speed_mps: float, slip_mps: float, params: SlipParams = DEFAULT_SLIP,
                  max_ratio: float = math.inf) -> float:
    """tcl_filter for a known slip of the driven wheels (m/s) at a speed of at least
    tcl_min_speed_mps: a slip at or below tcl_slip_mps never cuts, whatever `max_ratio`."""
    ratio = params.tcl_slip_ratio if params.tcl_slip_ratio < max_ratio else max_ratio
    allowed_mps = max(params.tcl_slip_mps, ratio * speed_mps)
    if slip_mps > allowed_mps:
        range_mps = params.tcl_range_mps
        if params.tcl_range_ratio * speed_mps < range_mps:
            range_mps = params.tcl_range_ratio * speed_mps
        accel -= (slip_mps - allowed_mps) / range_mps
        if accel < 0.0:
            accel = 0.0
    return accel


def spare_slip_ratio(peak_slip: float, lateral_share: float) -> float:
    """The longitudinal slip ratio a tyre has left beside a turn that takes `lateral_share` (0..1) of
    its grip: simuv2's tyre force follows the combined slip sqrt(sx^2 + sy^2), which peaks at
    `peak_slip`, so with sy ~ share x peak the rest is peak x sqrt(1 - share^2) (a heavy car spun on
    g-track-1's long turn with the throttle's full slip there)."""
    spare = 1.0 - lateral_share * lateral_share
    return peak_slip * math.sqrt(spare) if spare > 0.0 else 0.0


def combined_slip_room(peak_slip: float, lateral_slip: float) -> float:
    """The longitudinal slip ratio (slip / the car's speed, as the traction control counts it) that
    keeps a driven tyre's combined slip at its peak, given the lateral slip it has now (its side speed
    / the car's speed: measured, not assumed as spare_slip_ratio does).  simuv2 divides both slip
    speeds by the wheel's surface speed where that is the larger (a spinning wheel), so with the
    ratio r the combined slip is sqrt(r^2 + sy^2) / (1 + r) <= peak; 0 once the tyre slides
    sideways past its peak, where any wheelspin turns its force forward and the car spins."""
    p2, sy2 = peak_slip * peak_slip, lateral_slip * lateral_slip
    if sy2 >= p2:
        return 0.0
    if p2 >= 1.0:  # a peak at slip 1 or more: the wheel's own speed bounds the combined slip first
        return math.inf
    # the larger root of (1 - p^2) r^2 - 2 p^2 r + sy^2 - p^2 = 0
    return (p2 + math.sqrt(p2 * p2 - (1.0 - p2) * (sy2 - p2))) / (1.0 - p2)


def throttle_for_torque(torque_share: float, brake_share: float) -> float:
    """The throttle (0..1) whose torque is `torque_share` of the full torque, given the engine brake's
    share (engine_brake_share): at 0.4 of the full torque with a share of 0.25 it is 0.52, not 0.4."""
    return min(1.0, max(0.0, (torque_share + brake_share) / (1.0 + brake_share)))


@dataclass(frozen=True)
class Axle:
    """One axle as the drive force sees it: its static load, its downforce, its share of the drive
    force, and the load it gains per newton of drive force (the force at the road pitches the car:
    gc height / wheelbase, + on the rear axle, - on the front)."""

    weight_n: float
    downforce_ca: float  # N per (m/s)^2
    force_share: float  # 0 for an axle that is not driven
    load_per_force: float


def axle_force_room_n(mu: float, load_n: float, lateral_n: float, force_share: float, load_per_force: float) -> float:
    """The most drive force F (N) one axle allows: its tyres hold the turn's lateral_n beside their
    share of F within the friction circle of their load, (share F)^2 + lateral^2 <= (mu (load + d F))^2
    with d = load_per_force.  inf where the axle sets no limit; 0 where it cannot hold the turn even
    without drive force.  An axle that is not driven limits F only by the load F takes off it (a
    rear-driven car's front, which must still steer)."""
    mu2 = mu * mu
    a = force_share * force_share - mu2 * load_per_force * load_per_force
    b = -2.0 * mu2 * load_n * load_per_force
    c = lateral_n * lateral_n - mu2 * load_n * load_n
    if c > 0.0:
        return 0.0
    if a > 0.0:  # beyond the larger root the circle is exceeded
        return (-b + math.sqrt(b * b - 4.0 * a * c)) / (2.0 * a)
    if a == 0.0:
        return -c / b if b > 0.0 else math.inf
    # a < 0: the load grows with F faster than the force's share needs, or F only takes load off
    disc = b * b - 4.0 * a * c
    return (-b + math.sqrt(disc)) / (2.0 * a) if b > 0.0 and disc > 0.0 else math.inf


def drive_force_room_n(axles: tuple[Axle, ...], mu: float, speed_mps: float, curvature_1pm: float) -> float:
    """The most drive force (N) the car can put down at this speed in a turn of this curvature: each
    axle carries the turn's lateral force in proportion to its static load, and holds it beside its
    share of the drive force on its load with the downforce and what the drive force moves onto it."""
    v2 = speed_mps * speed_mps
    room = math.inf
    for axle in axles:
        lateral_n = axle.weight_n * v2 * abs(curvature_1pm) / G_MPS2
        load_n = axle.weight_n + axle.downforce_ca * v2
        room = min(room, axle_force_room_n(mu, load_n, lateral_n, axle.force_share, axle.load_per_force))
    return room


def drive_axles(car: Car) -> tuple[Axle, Axle]:
    """The car's (front, rear) axles for drive_force_room_n: the static load by the front weight share
    (of the car without fuel), each axle's downforce, the drive force split by the drivetrain (half
    each for all-wheel drive) and the load it moves rearwards, gc height / wheelbase per newton."""
    front_ca, rear_ca = axle_downforce_coefficients(car)
    front_w = car.front_weight_share * car.mass_kg * G_MPS2
    rear_w = car.mass_kg * G_MPS2 - front_w
    shift = car.gc_height_m / car.wheelbase_m if car.wheelbase_m > 0.0 else 0.0
    front_share = {RWD: 0.0, FWD: 1.0, AWD: 0.5}[car.drivetrain]
    return (Axle(front_w, front_ca, front_share, -shift), Axle(rear_w, rear_ca, 1.0 - front_share, shift))
