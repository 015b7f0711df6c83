"""Pit stops as an action: the env drives the car into its box and out again.

When the agent asks (the `pit` action >= 0.5), the env takes the wheel `TAKEOVER_M` before the pit
entry and drives with the shipped pit pieces: the pit path into the own box (robot/pitpath.py),
steered with the path-tracking law (control/steering.py); the pit brake filter for the entry, the
speed limit and the stop at the box, with the constant-deceleration stop controller and its speed
tracker (control/pit_brake.py, control/stop.py); the gears by speed (control/gears.py).  TORCS
captures the car, the env answers its pit call (fuel and repair: `order`), and once the car has
driven out to the end of the pit path the agent drives again.  A request stands until the stop is
made; a stop the filter gives up (the car pushed past its box) is tried again on the next lap.

robot/pit.py (`PitStops`) composes the same pieces for a robot: there the strategy decides each
lap whether to stop and the robot's own steering is filtered; here the agent decides, at any
moment, and the env drives the whole way in and out, so it holds the pieces itself.
"""

from __future__ import annotations

import math

from boxbox.control.carmodel import CarModel
from boxbox.control.gears import GearBox
from boxbox.control.pit_brake import HOLD, STOP
from boxbox.control.steering import steer_to_line
from boxbox.model import Car, PitOrder, State, Track
from boxbox.robot.pit import PitParams, pit_brake_filter
from boxbox.robot.pitpath import PitPath

TAKEOVER_M = 300.0  # the env drives from this far before the pit entry
APPROACH_MPS = 20.0  # speed held on the way to the entry when the filter asks for no other
THROTTLE_PER_MPS = 1.0  # throttle per m/s below the target speed (holding the limit needs ~0.2)
# The gym's pit parameters: the pit brake filter's own defaults (the stop at the box with half the
# lane's grip, 0.5 m from its centre is stopped, giving up after 5 s, the lane's braking grip at 0.9
# of surface x tyre), steering 4 m ahead (the turn into the box is tight), where the robot's
# (PitParams(), its tuned pit_* parameters) stop with 0.9 of the grip, 0.1 m from the centre,
# give up after 10 s, brake with 0.65 and steer 6 m + 0.2 s ahead: the gym's pit stops
# (tests/integration/test_gym_pit.py) are made with this set, the robot's figures with its own.
GYM_PIT_PARAMS = PitParams(lookahead_m=4.0, brake_mu_scale=0.9, give_up_s=5.0, stop_threshold_m=0.5,
                           stop_grip_share=0.5)


class PitStop:
    """The pit stop the env drives for one car on one track (`for_car`: None without a pit)."""

    def __init__(self, track: Track, car: Car) -> None:
        self.path = PitPath(track, car)
        self.car = car
        model = CarModel.from_car(car, car.tank_l / 2.0)
        self.filter = pit_brake_filter(self.path, model, GYM_PIT_PARAMS, "constant-decel")
        self.gearbox = GearBox(car)
        self.curvature = track.curvature().tolist()
        self.wheelbase_m = car.steering_wheelbase_m
        self.reset()

    @classmethod
    def for_car(cls, track: Track, car: Car) -> PitStop | None:
        if track.pit is None or car.pit_seg < 0:
            return None
        return cls(track, car)

    def reset(self) -> None:
        """A new race: no request, nobody in the pit."""
        self.requested = False  # the agent asked, the stop is not made yet
        self.driving = False  # the env has the wheel
        self.entered = False  # ... and has reached the pit path
        self.phase: str | None = None  # the pit brake filter's phase while the env drives (info["pit"])
        self.stops = 0
        self.filter.reset()

    def request(self) -> None:
        """The agent asks for a stop; asked while the env drives one, it is the agent's next one."""
        if not self.driving:
            self.requested = True

    def active(self, s: State) -> bool:
        """Whether the env drives this step: from TAKEOVER_M before the entry (a stop requested) to
        the end of the pit path."""
        pos = self.path.signed_coord(s.dist_from_start_m)
        if self.driving:
            if pos >= 0.0:
                self.entered = True
                return True
            if not self.entered:
                return True
            self.driving = self.entered = False  # out at the end of the path: the agent drives
            self.phase = None
            return False
        if self.requested and -TAKEOVER_M <= pos < 0.0:
            self.driving, self.entered = True, False
            self.filter.reset()
            return True
        return False

    def controls(self, s: State) -> tuple[float, float, float, float, int, bool]:
        """(steer, throttle, brake, clutch, gear, pit request) for this drive step."""
        path = self.path
        v = s.speed_x_mps
        pos = path.signed_coord(s.dist_from_start_m)
        on_path = pos >= 0.0
        seg = int(s.seg_id)
        r = self.filter.filter(0.0, v, pos, self.requested, on_path, s.in_pit)
        if r.gave_up:
            self.requested = False  # asked again by the agent, or not
        self.phase = r.phase
        target = r.target_speed_mps if r.target_speed_mps is not None else APPROACH_MPS
        throttle = 0.0 if r.brake > 0.0 or v >= target else min(1.0, THROTTLE_PER_MPS * (target - v))
        ahead_m = s.dist_from_start_m + GYM_PIT_PARAMS.lookahead_m
        slope = path.slope_at_s(path.to_spline_coord(ahead_m)) if path.is_on_path(ahead_m) else 0.0
        steer = steer_to_line(s.angle_rad + math.atan(slope), path.offset_at(ahead_m) - s.to_middle_m,
                              self.curvature[seg], v, s.yaw_rate_rps, self.wheelbase_m, self.car.steer_lock_rad)
        clutch = 1.0 if r.phase in (STOP, HOLD) and throttle == 0.0 else 0.0  # brakes alone at the box
        return steer, throttle, r.brake, clutch, self.gearbox.select(int(s.gear), v), self.requested

    def order(self, s: State, fuel_l: float | None, repair: float | None) -> PitOrder:
        """TORCS has the car in its box: fuel (default: fill the tank) and repair (default: all)."""
        self.requested = False
        self.stops += 1
        fuel = max(0.0, self.car.tank_l - s.fuel_l) if fuel_l is None else fuel_l
        return PitOrder(fuel_l=fuel, repair=s.damage if repair is None else repair)
