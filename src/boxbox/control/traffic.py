"""Traffic on plain numbers: where another car will be, whether to brake for it, where to pass.

Everything is one-dimensional along the track (distance ahead, speeds) plus a lateral position
(metres from the track's middle, + to the left), so it can be checked by hand:

- `min_gap_m`: the closest two cars come in the next seconds when we brake for the one ahead
  (after a reaction time) and it slows towards the speed it is predicted to need;
- `brake_for`: a brake command from that gap (time-to-collision braking, in place of a fixed gap);
- `room`: the band of lateral positions left to us by cars alongside;
- `pass_side`: which side of a slower car to pass on, or None when neither side has room.
The constant-deceleration kinematics are the textbook ones (distance = v t - a t^2 / 2).
"""

from __future__ import annotations

import math

PREDICT_DT_S = 0.05  # time step of the prediction


def closing_time_s(gap_m: float, my_speed_mps: float, other_speed_mps: float) -> float:
    """Seconds until the bumpers meet at today's speeds (inf when not closing)."""
    closing = my_speed_mps - other_speed_mps
    if closing <= 0.0:
        return math.inf
    return max(0.0, gap_m) / closing


def predicted_speed_mps(speed_mps: float, target_mps: float, decel_mps2: float, t_s: float) -> float:
    """The other car's speed after t_s, slowing at decel_mps2 towards target_mps (never speeding up:
    a car ahead that accelerates only opens the gap)."""
    if speed_mps <= target_mps:
        return speed_mps
    return max(target_mps, speed_mps - decel_mps2 * t_s)


def min_gap_m(gap_m: float, my_speed_mps: float, other_speed_mps: float, other_target_mps: float,
              my_decel_mps2: float, other_decel_mps2: float, reaction_s: float, horizon_s: float) -> float:
    """The smallest bumper gap over the horizon when we keep our speed for reaction_s, then brake at
    my_decel_mps2 down to the other car's speed (no further), while it slows towards
    other_target_mps at other_decel_mps2."""
    gap, v, t = gap_m, my_speed_mps, 0.0
    u = other_speed_mps
    lowest = gap
    while t < horizon_s:
        t += PREDICT_DT_S
        u_next = predicted_speed_mps(other_speed_mps, other_target_mps, other_decel_mps2, t)
        v_next = v if t <= reaction_s else max(min(v, u_next), v - my_decel_mps2 * PREDICT_DT_S)
        gap += 0.5 * (u + u_next - v - v_next) * PREDICT_DT_S
        v, u = v_next, u_next
        lowest = min(lowest, gap)
        if v <= u and gap > lowest:
            break  # matched its speed and the gap opens again: the closest point is behind us
    return lowest


def brake_for(lowest_gap_m: float, margin_m: float, band_m: float) -> float:
    """Brake command from the predicted closest gap: none above margin + band, full at the margin."""
    if lowest_gap_m >= margin_m + band_m:
        return 0.0
    return min(1.0, (margin_m + band_m - lowest_gap_m) / band_m)


def room(my_mid_m: float, others: list[tuple[float, float]], width_m: float, gap_m: float,
         left_edge_m: float, right_edge_m: float) -> tuple[float, float]:
    """(lowest, highest) lateral position left to our centre by cars alongside, each given as
    (its lateral position, its width): a car to our right pushes the lowest up to its position +
    half the two widths + gap_m; one to our left the highest down. Within the edges; when the cars
    leave less than nothing, the middle of what they leave."""
    lo, hi = right_edge_m, left_edge_m
    for mid, other_width in others:
        apart = 0.5 * (width_m + other_width) + gap_m
        if mid < my_mid_m:
            lo = max(lo, mid + apart)
        else:
            hi = min(hi, mid - apart)
    if lo > hi:
        lo = hi = 0.5 * (lo + hi)
    return lo, hi


def pass_side(other_mid_m: float, width_m: float, other_width_m: float, gap_m: float, left_edge_m: float,
              right_edge_m: float, inside_sign: float, my_mid_m: float | None = None) -> tuple[float, float] | None:
    """(side, target lateral position) to pass a car at other_mid_m: +1 left, -1 right; None when
    neither side leaves our width plus gap_m.  The side with more room, but the inside of the coming
    turn (inside_sign: +1 left turn, -1 right, 0 none) when it has room: it is the shorter way and
    the braking zone is where a pass is made.  my_mid_m: we are too close behind it to cross its
    path, so only the side we are on counts."""
    apart = 0.5 * (width_m + other_width_m) + gap_m
    left_room = left_edge_m - (other_mid_m + apart)
    right_room = (other_mid_m - apart) - right_edge_m
    sides = []
    if left_room >= 0.0:
        sides.append((left_room, 1.0, other_mid_m + apart))
    if right_room >= 0.0:
        sides.append((right_room, -1.0, other_mid_m - apart))
    if my_mid_m is not None:
        sides = [s for s in sides if s[1] == (1.0 if my_mid_m >= other_mid_m else -1.0)]
    if not sides:
        return None
    inside = [s for s in sides if s[1] == inside_sign]
    _, side, target = inside[0] if inside else max(sides)
    return side, target


def pass_pays(gap_m: float, my_speed_mps: float, other_speed_mps: float, length_m: float, straight_m: float,
              inside: bool) -> bool:
    """Whether a pass is worth starting: on the inside of the coming turn (we brake later than the
    car we pass, on the shorter way), or when we are a car length clear ahead of it before the
    next braking zone (straight_m ahead) at today's closing speed."""
    if inside:
        return True
    closing = my_speed_mps - other_speed_mps
    if closing <= 0.0:
        return False
    needed_s = (max(0.0, gap_m) + 2.0 * length_m) / closing
    return my_speed_mps * needed_s <= straight_m
