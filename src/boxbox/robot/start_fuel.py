"""The fuel to start a race with, from what one lap takes (control/fuel.py on the robot's own
simulated lap).

Each lap is counted at the estimate plus MODEL_MARGIN, the fuel model's largest under-estimate
measured (5 %: michigan, alone; docs/pits.md, "Start fuel").  With other cars in the race, or
without a pit lane, TRAFFIC_MARGIN more: behind cars a race took up to 13 % more than alone on the
tracks with a pit lane (aalborg, g-track-3; 10-lap field races) and the strategy stops for fuel once
its largest lap would not reach the finish.  With a pit lane the car starts with the first stint of
the fastest stop plan (robot/strategy.py).  Without one a car cannot refuel and running dry ends its
race: the whole race and NO_PIT_SPARE_LAPS more.  TORCS's own default instead is the car file's
fuel: car1-trb1 starts with 94 l where 10 laps of mixed-2 take 12.
"""

from __future__ import annotations

import math

from boxbox.robot.strategy import plan_stops

MODEL_MARGIN = 0.05  # share added to the lap's estimate
TRAFFIC_MARGIN = 0.15  # share added again with other cars racing or no pit lane to refuel in
NO_PIT_SPARE_LAPS = 1.0  # laps of fuel more than the race where no stop can make up for a shortfall


def start_fuel_l(laps: int, lap_fuel_l: float, tank_l: float, pit_lane: bool, traffic: bool) -> float:
    """Litres to start a race of `laps` laps with, when a lap takes lap_fuel_l (estimated) and the
    tank holds tank_l; pit_lane: whether the track has one to refuel in; traffic: whether other
    cars race too."""
    if laps < 1 or not (math.isfinite(lap_fuel_l) and lap_fuel_l > 0.0) or not (math.isfinite(tank_l) and tank_l > 0):
        raise ValueError(f"need laps >= 1 and finite lap fuel and tank > 0, got {laps}, {lap_fuel_l}, {tank_l}")
    per_lap = lap_fuel_l * (1.0 + MODEL_MARGIN)
    if traffic or not pit_lane:
        per_lap *= 1.0 + TRAFFIC_MARGIN
    if not pit_lane:
        return min(tank_l, (laps + NO_PIT_SPARE_LAPS) * per_lap)
    return min(tank_l, plan_stops(laps, per_lap, tank_l).fuel_per_stint_l[0])
