"""Traffic on plain numbers: the room cars alongside leave us, and the side to pass a car on.

Everything is one-dimensional along the track (distance ahead, speeds) plus a lateral position
(metres from the track's middle, + to the left), so it can be checked by hand:

- `room`: the band of lateral positions left to us by cars alongside;
- `pass_side`: which side of a slower car to pass on, or None when neither side has room.
"""

from __future__ import annotations


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
