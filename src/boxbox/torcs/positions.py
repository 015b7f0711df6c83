"""Places lap by lap, from every car's lap times (what a race with a Python car records for all cars)."""

from __future__ import annotations

from itertools import accumulate


def positions_by_lap(lap_times: list[list[float]]) -> list[list[int]]:
    """Per car, its place at the end of each lap it completed.

    At the end of lap k a car is behind every car that finished lap k sooner (race time = the sum
    of its first k laps); cars that never finished lap k are behind it.  Cars are given in the
    order of `lap_times`; a tie keeps that order.
    """
    totals = [list(accumulate(times)) for times in lap_times]
    places: list[list[int]] = []
    for i, mine in enumerate(totals):
        row = []
        for k, t in enumerate(mine):
            ahead = sum(1 for j, other in enumerate(totals)
                        if j != i and len(other) > k and (other[k] < t or (other[k] == t and j < i)))
            row.append(ahead + 1)
        places.append(row)
    return places
