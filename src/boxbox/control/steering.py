"""Steering laws: the tutorial's look-ahead point and a path-tracking law for racing lines.

Both return the steer command in [-1, 1] (1 = full lock to the left).  Angles in radians.
"""

from __future__ import annotations

import math

TWO_PI = 2.0 * math.pi


def wrap_angle(a: float) -> float:
    return (a + math.pi) % TWO_PI - math.pi


def clamp_steer(steer: float) -> float:
    return -1.0 if steer < -1.0 else (1.0 if steer > 1.0 else steer)


def steer_to_point(x_m: float, y_m: float, yaw_rad: float, target_x_m: float, target_y_m: float,
                   steer_lock_rad: float) -> float:
    """The tutorial: steer by the angle to a target point ahead, as a fraction of the lock.

    With a long look-ahead the car cuts inside a curved line (by roughly look-ahead^2 x curvature / 2).
    """
    angle = wrap_angle(math.atan2(target_y_m - y_m, target_x_m - x_m) - yaw_rad)
    return clamp_steer(angle / steer_lock_rad)


def steer_to_line(heading_error_rad: float, lateral_error_m: float, curvature_1pm: float, speed_mps: float,
                  yaw_rate_rps: float, wheelbase_m: float, steer_lock_rad: float, lateral_gain: float = 2.0,
                  yaw_damping_s: float = 0.05, soft_speed_mps: float = 5.0,
                  understeer_rad_per_mps2: float = 0.0) -> float:
    """Track a line: feed-forward for its curvature, plus corrections for heading and distance.

    heading_error_rad: line heading minus car yaw; lateral_error_m: line offset minus car offset
    (+ when the line is to the car's left); the last term damps yaw rate beyond what the line needs.
    The distance term is divided by speed (a Stanley-type law) so the correction takes about the same
    distance at any speed, which keeps it stable at 80 m/s.  `understeer_rad_per_mps2` adds steer
    in proportion to the lateral acceleration the line asks for (v^2 k): the tyres' slip angles,
    which a car that understeers needs on top of the geometric angle; without it the car settles
    outside its line in every turn and only the distance term pulls it back.
    """
    feed_forward = (math.atan(wheelbase_m * curvature_1pm)
                    + understeer_rad_per_mps2 * speed_mps * speed_mps * curvature_1pm)
    correction = math.atan(lateral_gain * lateral_error_m / (abs(speed_mps) + soft_speed_mps))
    damping = yaw_damping_s * (speed_mps * curvature_1pm - yaw_rate_rps)
    return clamp_steer((feed_forward + heading_error_rad + correction + damping) / steer_lock_rad)
