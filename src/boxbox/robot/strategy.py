"""Pit strategy: when to stop, how much fuel and repair to take.

Decision (the TORCS robot tutorial's pit strategy, chapter "Pit stops"): stop when the fuel will not
reach the finish and
less than 1.5 laps of fuel are left, in a requested lap, or when damage exceeds 5000 and the damage
taken per lap so far would carry it past OUT_DAMAGE - damage_reserve (8500) by the finish (the
tutorial stops at 5000 whatever is left of the race: with two laps to go in a 10-car field on
aalborg that stop repaired 5568 points, 39 s, and cost seven places), or when the lap time the damage
costs (s_per_lap_per_damage: TORCS 1.3.7 raises the drag by damage / 10000) over the rest of the race
is more than a stop that repairs it.

Order: enough fuel to finish plus a margin, split over as many stops as minimise the race time:
  each stop costs  pit_loss_s (driving the pit lane instead of the track) + 2 s + fuel / 8 l/s
                   + repair * 0.007 s                       (TORCS's race manager defaults, raceengine.xml)
  carried fuel costs  s_per_lap_per_kg * fuel mass per lap  (a heavier car is slower).
The default 0.022 s/lap/kg is measured: car1-trb1 on e-track-2 lapped 1.5 s slower with 68 kg more
fuel (4 laps with 26 l and with 94 l, laps 2-4); TORCS adds the fuel to the car's mass as
litres == kilograms (kg_per_l = 1).
More stops carry less fuel, so with a cheap pit lane and a heavy fuel load two short stints can beat
one long one; `plan_stops` compares the numbers of stops.

Repair: TORCS 1.3.7 puts a car out at 10000 damage and multiplies the drag by 1 + damage / 10000
(the robot measures what that costs a lap with its lap simulation; 0 by default here), so where
the lap time lost over the rest of the race is less than the repair's 0.007 s a point, repairing
buys only safety: repair down to repair_keep_damage (5000, where the next damage stop would come),
or lower when 1.5 x the damage taken per lap so far would carry it past OUT_DAMAGE -
damage_reserve before the finish; everything when lap time lost to damage makes a full repair pay.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from boxbox.robot.base import FUEL_L_PER_M_ESTIMATE

FUEL_PER_M_L = FUEL_L_PER_M_ESTIMATE  # first guess before a lap is measured (x the car's consumption factor)
STOP_BASE_S = 2.0  # TORCS: fixed part of a pit stop
FUEL_RATE_LPS = 8.0  # TORCS: refuelling speed
REPAIR_S_PER_POINT = 0.007  # TORCS: repair time per damage point
DAMAGE_LIMIT = 5000.0  # stop for repair above this (when the rest of the race needs it)
OUT_DAMAGE = 10000.0  # TORCS 1.3.7 takes a car out of the race at this damage
DAMAGE_RESERVE = 1500.0  # room kept below OUT_DAMAGE for one crash beyond the damage per lap so far
REPAIR_TREND = 1.5  # a repair plans for this many times the damage per lap so far
MIN_FUEL_LAPS = 1.5  # stop for fuel only when less than this many laps are left in the tank


@dataclass(frozen=True, slots=True)
class StopPlan:
    stops: int  # number of stops (at a stop: the stops after this one)
    stint_laps: tuple[int, ...]  # laps of each stint, in order (stops + 1 of them)
    fuel_per_stint_l: tuple[float, ...]  # fuel at the start of each stint: its laps + margin, <= tank
    time_cost_s: float  # pit time + weight penalty of this plan (comparable between plans only)


def plan_stops(race_laps: float, fuel_per_lap_l: float, tank_l: float, *, pit_loss_s: float = 15.0,
               s_per_lap_per_kg: float = 0.022, kg_per_l: float = 1.0, margin_laps: float = 0.3,
               first_stint_fuelled: bool = True, max_extra_stops: int = 3) -> StopPlan:
    """Number of stops and fuel per stint that minimise time for race_laps laps still to drive.

    Cost of a plan: stops * (pit_loss_s + 2 s) + refuelled litres / 8 l/s + weight, where a stint of n
    laps carries on average (n/2 + margin_laps) laps of fuel at s_per_lap_per_kg per kg and lap.
    Each stint starts with its laps + margin_laps of fuel (the margin carries over, so it is refuelled
    once).  first_stint_fuelled: the first stint's fuel costs no refuelling time (race start: loaded
    before the start), which makes a longer first stint pay; False when planning at a stop, where
    every stint is refuelled.  From the fewest stops the tank allows, more stops are tried until
    max_extra_stops past the best so far; for each number, every first-stint length with the rest
    split evenly (the weight cost is convex, so even is best for the refuelled stints).  A fractional
    race_laps (at a stop: the rest of this
    lap plus the laps after it) is planned as whole laps, but the last stint is fuelled for the
    fraction only.  Called per stop, not per step.
    """
    laps = max(0, math.ceil(race_laps - 1e-9))
    short = max(0.0, laps - race_laps)  # the last stint is this much shorter than its whole laps
    if fuel_per_lap_l <= 0.0 or laps == 0:
        return StopPlan(0, (laps,), (max(0.0, (laps - short + margin_laps) * fuel_per_lap_l),), 0.0)
    max_stint = math.floor(tank_l / fuel_per_lap_l - margin_laps + 1e-9)
    if max_stint < 1:
        raise ValueError(f"tank of {tank_l} l holds less than one lap (+ margin) at {fuel_per_lap_l} l/lap")
    weight_k = fuel_per_lap_l * kg_per_l * s_per_lap_per_kg

    def cost(stints: list[int]) -> float:
        refuelled = sum(stints[1:]) if first_stint_fuelled else sum(stints)
        weight = sum(n * (n / 2.0 + margin_laps) for n in stints) * weight_k
        return (len(stints) - 1) * (pit_loss_s + STOP_BASE_S) + refuelled * fuel_per_lap_l / FUEL_RATE_LPS + weight

    min_stops = math.ceil(laps / max_stint) - 1
    best: tuple[float, list[int]] | None = None
    stops = min_stops
    while stops <= laps - 1 and (best is None or stops <= len(best[1]) - 1 + max_extra_stops):
        firsts = [laps] if stops == 0 else range(1, min(max_stint, laps - stops) + 1)
        for first in firsts:
            stints = [first]
            if stops:
                base, extra = divmod(laps - first, stops)
                if base + (1 if extra else 0) > max_stint:
                    continue
                stints += [base + 1] * extra + [base] * (stops - extra)
            c = cost(stints)
            if best is None or c < best[0] - 1e-9:
                best = (c, stints)
        stops += 1
    assert best is not None
    c, stints = best
    fuel = [(n + margin_laps) * fuel_per_lap_l for n in stints]
    fuel[-1] -= short * fuel_per_lap_l
    return StopPlan(len(stints) - 1, tuple(stints), tuple(fuel), c)


def laps_after_box(remaining_laps: float, dist_m: float, box_m: float, length_m: float) -> float:
    """Laps still to drive after the box, seen from dist_m (from the start line) before reaching it:
    remaining_laps (TORCS's: the laps after this one) plus the rest of a lap from the box.  A box
    behind us in this lap's distance is reached after the line, in the next lap: one lap fewer (on
    aalborg the box is just past the line, and a stop decided late in the last lap asked for one in
    a lap the race does not have)."""
    box = box_m % length_m
    beyond_line = box < dist_m % length_m
    return remaining_laps - (1.0 if beyond_line else 0.0) + (length_m - box) / length_m


def pit_lane_loss_s(lane_length_m: float, speed_limit_mps: float, race_speed_mps: float,
                    decel_mps2: float = 8.0, accel_mps2: float = 4.0) -> float:
    """Rough time lost by a pit stop's drive (not the standing): the lane at the limit instead of the
    race speed, slowing to the limit and back, and stopping at the box from the limit and starting."""
    v, u = race_speed_mps, speed_limit_mps
    lane = lane_length_m / u - lane_length_m / v
    # time lost braking from v to u and accelerating back, versus holding v over the same distance
    dv = max(0.0, v - u)
    change = dv * dv / (2.0 * v) * (1.0 / decel_mps2 + 1.0 / accel_mps2)
    stop = u / 2.0 * (1.0 / decel_mps2 + 1.0 / accel_mps2)
    return lane + change + stop


class PitStrategy:
    """Per-race pit strategy over plain numbers (fuel in litres, damage in TORCS points).

    pit_laps: laps (1-based, the lap being driven when the car reaches the pit, i.e. laps_done + 1)
    in which to stop in any case.
    """

    def __init__(self, track_length_m: float, tank_l: float, *, fuel_per_m_l: float = FUEL_PER_M_L,
                 pit_laps: Iterable[int] = (), damage_limit: float = DAMAGE_LIMIT,
                 min_fuel_laps: float = MIN_FUEL_LAPS, margin_laps: float = 0.3, pit_loss_s: float = 15.0,
                 s_per_lap_per_kg: float = 0.022, kg_per_l: float = 1.0, repair_keep_damage: float = DAMAGE_LIMIT,
                 s_per_lap_per_damage: float = 0.0, damage_reserve: float = DAMAGE_RESERVE) -> None:
        self.track_length_m = track_length_m
        self.tank_l = tank_l
        self.fuel_per_m_l = fuel_per_m_l
        self.pit_laps = frozenset(int(n) for n in pit_laps)
        self.damage_limit = damage_limit
        self.min_fuel_laps = min_fuel_laps
        self.margin_laps = margin_laps
        self.pit_loss_s = pit_loss_s
        self.s_per_lap_per_kg = s_per_lap_per_kg
        self.kg_per_l = kg_per_l
        self.repair_keep_damage = repair_keep_damage
        self.s_per_lap_per_damage = s_per_lap_per_damage
        self.damage_reserve = damage_reserve
        self.measured_l: list[float] = []  # fuel used per lap, laps without a stop, from lap 2 on
        self.first_lap_l: float | None = None  # the first lap's use (the standing start burns more)
        self._laps_done: int | None = None
        self._lap_start_fuel_l = 0.0
        self._added_l = 0.0  # ordered in the current lap
        self._stopped_in_lap: int | None = None  # laps_done when the last stop was ordered
        self._lap_start_damage = 0.0
        self.damage_gained = 0.0  # damage taken in the measured laps (repairs not subtracted)
        self.damage_laps = 0

    @property
    def fuel_per_lap_l(self) -> float:
        """Largest measured use from lap 2 on (running dry costs the race), else the first lap's, else
        the per-metre estimate."""
        if self.measured_l:
            return max(self.measured_l)
        if self.first_lap_l is not None:
            return self.first_lap_l
        return self.fuel_per_m_l * self.track_length_m

    def on_lap(self, laps_done: int, fuel_l: float, damage: float) -> None:
        """Call with the completed laps (cheap to call every step: acts only when laps_done changes)."""
        if laps_done == self._laps_done:
            return
        if self._laps_done is not None and laps_done == self._laps_done + 1:
            used = self._lap_start_fuel_l + self._added_l - fuel_l
            # a lap with a stop the strategy did not order cannot be measured
            if used > 0.0 and (self._added_l > 0.0 or fuel_l <= self._lap_start_fuel_l):
                if laps_done == 1:
                    self.first_lap_l = used
                else:
                    self.measured_l.append(used)
            if damage >= self._lap_start_damage:  # a lap with a repair is skipped
                self.damage_gained += damage - self._lap_start_damage
                self.damage_laps += 1
        self._laps_done = laps_done
        self._lap_start_fuel_l = fuel_l
        self._lap_start_damage = damage
        self._added_l = 0.0

    @property
    def damage_per_lap(self) -> float:
        return self.damage_gained / self.damage_laps if self.damage_laps else 0.0

    def wants_stop(self, laps_done: int, remaining_laps: float, fuel_l: float, damage: float) -> bool:
        """remaining_laps: laps still to drive after passing the pit this time."""
        if remaining_laps <= 0:  # the race ends here: a stop only loses time
            return False
        if self._stopped_in_lap == laps_done:  # stopped in this lap already
            return False
        if damage > self.damage_limit and \
                damage + self.damage_per_lap * remaining_laps > OUT_DAMAGE - self.damage_reserve:
            return True
        if damage * self.s_per_lap_per_damage * remaining_laps > \
                self.pit_loss_s + STOP_BASE_S + damage * REPAIR_S_PER_POINT:
            return True  # the damage's drag costs more by the finish than a stop that repairs it
        if laps_done + 1 in self.pit_laps:
            return True
        fpl = self.fuel_per_lap_l
        return fuel_l < remaining_laps * fpl and fuel_l < self.min_fuel_laps * fpl

    def plan(self, remaining_laps: float, tank_l: float | None = None, at_stop: bool = False) -> StopPlan:
        """Best plan for the remaining laps (at_stop: planned while standing in the pit, so the
        next stint's fuel is refuelled too; otherwise as at the race start)."""
        return plan_stops(remaining_laps, self.fuel_per_lap_l, self.tank_l if tank_l is None else tank_l,
                          pit_loss_s=self.pit_loss_s, s_per_lap_per_kg=self.s_per_lap_per_kg,
                          kg_per_l=self.kg_per_l, margin_laps=self.margin_laps, first_stint_fuelled=not at_stop)

    def order(self, remaining_laps: float, fuel_l: float, damage: float, tank_l: float) -> tuple[float, float]:
        """(fuel_l, repair) to order at this stop; remaining_laps as in wants_stop."""
        fuel = 0.0
        if remaining_laps > 0:
            next_stint_l = self.plan(remaining_laps, tank_l, at_stop=True).fuel_per_stint_l[0]
            fuel = next_stint_l - fuel_l
            fuel = min(max(0.0, fuel), max(0.0, tank_l - fuel_l))
        repair = self._repair(remaining_laps, damage)
        self._added_l += fuel
        self._stopped_in_lap = self._laps_done
        return fuel, repair

    def _repair(self, remaining_laps: float, damage: float) -> float:
        if damage <= 0.0:
            return 0.0
        laps = max(0.0, remaining_laps)
        if self.s_per_lap_per_damage * laps > REPAIR_S_PER_POINT:
            return float(damage)  # damage costs more over the remaining laps than repairing it
        # keep damage (repairing costs time), but not so much that the damage taken per lap so far
        # (with a margin) would bring the car near TORCS's limit before the finish
        to_keep = min(self.repair_keep_damage,
                      OUT_DAMAGE - self.damage_reserve - REPAIR_TREND * self.damage_per_lap * laps)
        return min(float(damage), max(0.0, float(damage) - to_keep))
