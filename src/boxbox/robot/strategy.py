"""Pit strategy: when to stop, how much fuel and repair to take.

Decision (tutorial rules, TORCS.md "Pit strategy"): stop when the fuel will not reach the finish and
less than 1.5 laps of fuel are left, when damage exceeds 5000, or in a requested lap.

Order: enough fuel to finish plus a margin, split over as many stops as minimise the race time:
  each stop costs  pit_loss_s (driving the pit lane instead of the track) + 2 s + fuel / 8 l/s
                   + repair * 0.007 s                       (TORCS race defaults, TORCS.md)
  carried fuel costs  s_per_lap_per_kg * fuel mass per lap  (a heavier car is slower).
The default 0.03 s/lap/kg is a rule-of-thumb figure for racing cars (a few hundredths of a second per
lap per kilogram); TORCS adds the fuel to the car's mass as litres == kilograms (kg_per_l = 1).
More stops carry less fuel, so with a cheap pit lane and a heavy fuel load two short stints can beat
one long one; `plan_stops` compares the numbers of stops.

Repair: TORCS 1.3.7 puts a car out at 10000 damage; we assume damage does not slow the car
otherwise (s_per_lap_per_damage = 0), so repairing costs time and buys only safety: repair down to
repair_keep_damage (1000) unless lap time lost to damage makes a full repair pay.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

FUEL_PER_M_L = 0.0008  # first guess before a lap is measured (about 4.3 l/lap on e-track-2)
STOP_BASE_S = 2.0  # TORCS: fixed part of a pit stop
FUEL_RATE_LPS = 8.0  # TORCS: refuelling speed
REPAIR_S_PER_POINT = 0.007  # TORCS: repair time per damage point
DAMAGE_LIMIT = 5000.0  # stop for repair above this
MIN_FUEL_LAPS = 1.5  # stop for fuel only when less than this many laps are left in the tank


@dataclass(frozen=True, slots=True)
class StopPlan:
    stops: int  # further stops
    stint_laps: int  # laps of the longest stint (fuel is sized for it)
    fuel_per_stint_l: float  # fuel at the start of each stint (stint laps + margin), <= tank
    time_cost_s: float  # pit time + weight penalty of this plan (comparable between plans only)


def plan_stops(race_laps: float, fuel_per_lap_l: float, tank_l: float, *, pit_loss_s: float = 15.0,
               s_per_lap_per_kg: float = 0.03, kg_per_l: float = 1.0, margin_laps: float = 0.3,
               first_stint_fuelled: bool = True, max_extra_stops: int = 3) -> StopPlan:
    """Number of stops and fuel per stint that minimise time for race_laps laps from a full stop.

    race_laps counts the laps still to drive (from the race start, or from the pit stop being
    planned; the current stop then is stop 0 and `stops` counts the stops after it).  Stints are equal
    in whole laps; each starts with stint laps + margin_laps of fuel.  The fewest stops the tank allows
    is tried, and up to max_extra_stops more.  first_stint_fuelled: the first stint's fuel costs no
    refuelling time (race start: it is loaded before the start); False when planning at a stop.
    """
    if fuel_per_lap_l <= 0.0 or race_laps <= 0:
        return StopPlan(0, max(0, math.ceil(race_laps)), max(0.0, margin_laps * fuel_per_lap_l), 0.0)
    laps = math.ceil(race_laps - 1e-9)
    max_stint = math.floor(tank_l / fuel_per_lap_l - margin_laps + 1e-9)
    if max_stint < 1:
        raise ValueError(f"tank of {tank_l} l holds less than one lap (+ margin) at {fuel_per_lap_l} l/lap")
    min_stops = math.ceil(laps / max_stint) - 1
    best: StopPlan | None = None
    for stops in range(min_stops, min(min_stops + max_extra_stops, laps - 1) + 1):
        stints = stops + 1
        base, extra = divmod(laps, stints)
        stint_laps = [base + 1] * extra + [base] * (stints - extra)
        fuel_start = [(n + margin_laps) * fuel_per_lap_l for n in stint_laps]
        # fuel refuelled: the laps of the refuelled stints (a stint's margin carries over to the next)
        refuelled = stint_laps[1:] if first_stint_fuelled else stint_laps
        pit_s = stops * (pit_loss_s + STOP_BASE_S) + sum(refuelled) * fuel_per_lap_l / FUEL_RATE_LPS
        # weight: a stint of n laps carries on average (n/2 + margin) laps of fuel
        weight_s = sum(n * (n / 2.0 + margin_laps) * fuel_per_lap_l * kg_per_l * s_per_lap_per_kg
                       for n in stint_laps)
        plan = StopPlan(stops, max(stint_laps), max(fuel_start), pit_s + weight_s)
        if best is None or plan.time_cost_s < best.time_cost_s - 1e-9:
            best = plan
    assert best is not None
    return best


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
                 s_per_lap_per_kg: float = 0.03, kg_per_l: float = 1.0, repair_keep_damage: float = 1000.0,
                 s_per_lap_per_damage: float = 0.0) -> None:
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
        self.measured_l: list[float] = []  # fuel used per lap, laps without a stop
        self._laps_done: int | None = None
        self._lap_start_fuel_l = 0.0
        self._added_l = 0.0  # ordered in the current lap
        self._stopped_in_lap: int | None = None  # laps_done when the last stop was ordered

    @property
    def fuel_per_lap_l(self) -> float:
        """Largest measured use (running dry costs the race), else the per-metre estimate."""
        if self.measured_l:
            return max(self.measured_l)
        return self.fuel_per_m_l * self.track_length_m

    def on_lap(self, laps_done: int, fuel_l: float, damage: float) -> None:
        """Call with the completed laps (cheap to call every step: acts only when laps_done changes)."""
        if laps_done == self._laps_done:
            return
        if self._laps_done is not None and laps_done == self._laps_done + 1:
            used = self._lap_start_fuel_l + self._added_l - fuel_l
            # a lap with a stop the strategy did not order cannot be measured
            if used > 0.0 and (self._added_l > 0.0 or fuel_l <= self._lap_start_fuel_l):
                self.measured_l.append(used)
        self._laps_done = laps_done
        self._lap_start_fuel_l = fuel_l
        self._added_l = 0.0

    def wants_stop(self, laps_done: int, remaining_laps: float, fuel_l: float, damage: float) -> bool:
        """remaining_laps: laps still to drive after passing the pit this time."""
        if remaining_laps <= 0:  # the race ends here: a stop only loses time
            return False
        if self._stopped_in_lap == laps_done:  # stopped in this lap already
            return False
        if damage > self.damage_limit:
            return True
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
        fpl = self.fuel_per_lap_l
        fuel = 0.0
        if remaining_laps > 0:
            stint_laps = self.plan(remaining_laps, tank_l, at_stop=True).stint_laps
            fuel = (stint_laps + self.margin_laps) * fpl - fuel_l
            fuel = min(max(0.0, fuel), max(0.0, tank_l - fuel_l))
        repair = self._repair(remaining_laps, damage)
        self._added_l += fuel
        self._stopped_in_lap = self._laps_done
        return fuel, repair

    def _repair(self, remaining_laps: float, damage: float) -> float:
        if damage <= 0.0:
            return 0.0
        if self.s_per_lap_per_damage * max(0.0, remaining_laps) > REPAIR_S_PER_POINT:
            return float(damage)  # damage costs more over the remaining laps than repairing it
        return max(0.0, float(damage) - self.repair_keep_damage)
