"""Pit stops for any robot: when to stop, the way into the box and out, what to ask for.

The part bt's robot keeps in its own class (pit.cpp), built from boxbox's pieces: the strategy
(robot/strategy.py: when to stop and how much to fill), the pit path (robot/pitpath.py: a spline
from the pit entry through the box to the exit), the pit brake filter with the stop controller
(control/pit_brake.py, control/stop.py: the tutorial's brake filter and a constant-deceleration
stop on the box). A robot hands its own controls through `filter` every step and answers TORCS's
pit call with `pit_stop`:

    class MyRobot(Robot):
        def on_track(self, track, car):
            super().on_track(track, car)
            self.pits = PitStops(track, car, self.options)

        def drive(self, state):
            return self.pits.filter(state, my_controls(state))

        def pit_stop(self, state):
            return self.pits.pit_stop(state)

`--pit-laps` asks for stops on given laps; otherwise the strategy stops for fuel or damage.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from boxbox.control.braking import brake_distance
from boxbox.control.carmodel import CarModel
from boxbox.control.pit_brake import HOLD, PIT_LOOKAHEAD_M, STOP, PitBrakeFilter
from boxbox.control.steering import steer_to_point
from boxbox.control.stop import SpeedTracker
from boxbox.model import Car, Controls, PitOrder, State, Track
from boxbox.model.constants import G_MPS2
from boxbox.robot.base import FUEL_L_PER_M_ESTIMATE, RaceOptions
from boxbox.robot.pitpath import PitPath
from boxbox.robot.racingline import middle_line
from boxbox.robot.strategy import PitStrategy, laps_after_box, plan_stops

EXIT_BRAKE_BAND_MPS = 2.0  # leaving the lane: full brake this far above the exit path's speed cap
PIT_HOLD_GAIN_PER_MPS = 1.0  # throttle per m/s below the pit lane's target speed
DECIDE_BEFORE_ENTRY_M = 600.0  # a stop is decided once per lap, this far before the pit entry
# stops given up (pushed past the box, or not captured) after which no more are asked for in the race:
# a box that did not capture the car twice will not the third time (forza from slot 10 of 10: stopped
# in its box, never captured, 28 s lost in each of six laps)
MAX_GIVEN_UP = 2


@dataclass(frozen=True)
class PitParams:
    """How the pit part drives: the defaults for any robot, and of the tutorial robot's pit_*
    parameters (robot/params.py reads them here: change one here and both follow)."""

    lookahead_m: float = PIT_LOOKAHEAD_M  # steering aims this far (+ 0.2 s) ahead on the pit path
    brake_mu_scale: float = 0.65  # braking grip in the lane, relative to its surface x tyre friction
    give_up_s: float = 10.0
    stop_threshold_m: float = 0.1  # constant-decel stop: close enough to the box centre
    stop_grip_share: float = 0.9  # constant-decel stop: deceleration as a share of the lane's grip
    brake_method: str = "exact"


def pit_brake_filter(path: PitPath, model: CarModel, p: PitParams, stop_mode: str) -> PitBrakeFilter:
    """The pit brake filter on `path` (the entry's braking, the speed limit, the stop at the box and
    giving up) for a car of `model` with the parameters `p`: the one wiring of the pit part's
    (PitStops) and the gym's pit stops (gym/pitstop.py)."""
    lane_mu = path.surface_friction * model.mu
    return PitBrakeFilter(
        lambda v1, v2, mu: brake_distance(v1, v2, mu, model, p.brake_method),
        limit_start_m=path.limit_start_m, box_m=path.box_m, limit_end_m=path.limit_end_m,
        speed_limit_mps=path.speed_limit_mps, box_length_m=path.box_length_m,
        pit_mu=lane_mu, surface_mu_scale=p.brake_mu_scale,
        entry_constraints=path.entry_speed_constraints(lane_mu * 0.9),
        stop_mode=stop_mode, stop_threshold_m=p.stop_threshold_m,
        stop_max_decel_mps2=p.stop_grip_share * lane_mu * G_MPS2,
        give_up_timeout_s=p.give_up_s,
        # full brake on the lane's surface decelerates by about mu g (clutch open: no engine braking)
        tracker=SpeedTracker(full_brake_mps2=lane_mu * G_MPS2, drag_k_per_m=model.cw / model.mass_kg))


@dataclass
class PitEvent:
    """One visit to the pit lane (times in s of race time; stop error in m, + past the box)."""

    lap: int
    entry_time: float
    mode: str
    stop_time: float | None = None
    leave_time: float | None = None
    exit_time: float | None = None
    stop_error_m: float | None = None
    fuel: float = 0.0
    repair: float = 0.0
    gave_up: bool = False

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


class PitStops:
    """The pit part: `step` (the tutorial's filter stage) or `filter` (whole Controls) each drive
    step, `pit_stop` when TORCS calls. Inactive on tracks without a pit lane or a box."""

    def __init__(self, track: Track, car: Car, options: RaceOptions, params: PitParams | None = None,
                 model: CarModel | None = None, entry_offset_m: float = 0.0, exit_offset_m: float = 0.0,
                 entry_slope: float = 0.0, exit_slope: float = 0.0, s_per_lap_per_damage: float = 0.0,
                 lap_fuel_l: float | None = None) -> None:
        self.track, self.car, self.options = track, car, options
        self.params = params or PitParams()
        self.model = model or CarModel.from_car(car, fuel_l=car.initial_fuel_l)
        self.events: list[PitEvent] = []
        self.event: PitEvent | None = None
        # s_per_lap_per_damage: lap time a damage point costs (TORCS 1.3.7 raises the drag with damage);
        # lap_fuel_l: the robot's estimate of a lap's fuel until one is measured (else per metre)
        per_m_l = lap_fuel_l / track.length_m if lap_fuel_l else FUEL_L_PER_M_ESTIMATE * car.fuel_cons_factor
        self.strategy = PitStrategy(track.length_m, car.tank_l, pit_laps=options.pit_laps, fuel_per_m_l=per_m_l,
                                    s_per_lap_per_damage=s_per_lap_per_damage)
        self.wanted = False  # a stop is planned for this lap and not made yet (TORCS's pit request)
        self.decided_lap = -1
        self.retry = False  # a stop given up in an earlier lap is still owed
        self.given_up = 0  # stops given up so far (MAX_GIVEN_UP: no more)
        self.clutch_open = False
        self.phase: str | None = None  # the pit brake filter's phase this step (telemetry)
        self.plan = None
        if options.laps and not options.pit_laps:
            plan = plan_stops(options.laps, self.strategy.fuel_per_lap_l, car.tank_l)
            self.plan = {"stops": plan.stops, "stint_laps": list(plan.stint_laps)}
        self.path: PitPath | None = None
        if track.pit is not None and car.pit_seg >= 0:
            self._setup_path(entry_offset_m, exit_offset_m, entry_slope, exit_slope)

    def _setup_path(self, entry_offset_m: float, exit_offset_m: float, entry_slope: float, exit_slope: float) -> None:
        p, model, track, car = self.params, self.model, self.track, self.car
        path = PitPath(track, car, entry_offset_m=entry_offset_m, exit_offset_m=exit_offset_m,
                       entry_slope=entry_slope, exit_slope=exit_slope)
        lane_mu = path.surface_friction * model.mu
        self.path = path
        self._coast_decel = 2.0 * 0.5 * lane_mu * G_MPS2  # v^2 = 2 a d with a = half the lane's grip
        self.brake_filter = pit_brake_filter(path, model, p, self.options.pit_mode)
        self._exit_from_m, self._exit_caps = path.exit_speed_caps(lane_mu * 0.9, 0.5 * lane_mu * G_MPS2)
        mid = middle_line(track, step_m=2.0)
        self._step_m, self._n = mid.step_m, mid.n
        self._mid_xy = list(zip(mid.x_m.tolist(), mid.y_m.tolist(), strict=True))
        self._normals = [(-math.sin(h), math.cos(h)) for h in mid.heading_rad.tolist()]
        self._box_from_start_m = track.dist_of(car.pit_seg, car.pit_to_start)

    # --- each drive step --------------------------------------------------------------------------
    def filter(self, s: State, c: Controls) -> Controls:
        """A robot's controls with the pit stop's steering, throttle, brake, clutch and request."""
        if self.path is None:
            return c
        brake, accel, steer = self.step(s, s.speed_x_mps, c.brake, c.accel, c.steer)
        clutch = 1.0 if self.clutch_open and accel == 0.0 else c.clutch
        return dataclasses.replace(c, steer=steer, accel=accel, brake=brake, clutch=clutch,
                                   pit_request=c.pit_request or self.wanted)

    def step(self, s: State, v: float, brake: float, accel: float, steer: float) -> tuple[float, float, float]:
        """(brake, accel, steer) with the pit stop applied: decide, brake to the box, steer the path."""
        path = self.path
        if path is None:
            return brake, accel, steer
        laps_done = max(0, int(s.laps) - 1)
        self.strategy.on_lap(laps_done, s.fuel_l, s.damage)
        pos = path.signed_coord(s.dist_from_start_m)
        on_path = pos >= 0.0
        self._decide(s, pos, on_path, laps_done)
        if not on_path and self.event is not None:
            self._close_event(s)
        if not on_path and not self.wanted:
            self.phase = None
            return brake, accel, steer
        r = self.brake_filter.filter(brake, v, pos, self.wanted, on_path and (self.wanted or self.event is not None),
                                     s.in_pit)
        if r.gave_up and self.wanted:
            # pushed past the box (or not captured): drive on at the limit, try again next lap
            self.given_up += 1
            self.wanted, self.retry = False, True  # _decide asks for none past MAX_GIVEN_UP
            if self.event is not None:
                self.event.gave_up = True
        if on_path and (self.wanted or self.event is not None):
            self._log(s, pos)
            steer = self._steer_on_path(s, v)
        self.clutch_open = r.phase in (STOP, HOLD)
        self.phase = r.phase
        brake, accel = r.brake, self._throttle(accel, v, pos, on_path, r.target_speed_mps, r.brake)
        if on_path and self.event is not None and pos >= self._exit_from_m:
            brake, accel = self._exit_cap(v, pos, brake, accel)
        return brake, accel, steer

    def _exit_cap(self, v: float, pos: float, brake: float, accel: float) -> tuple[float, float]:
        """Leaving the lane: no faster than the path back to the line allows (PitPath.exit_speed_caps),
        braking in proportion over EXIT_BRAKE_BAND_MPS above it."""
        i = int(pos - self._exit_from_m)
        if i >= len(self._exit_caps) or v <= self._exit_caps[i]:
            return brake, accel
        return max(brake, min(1.0, (v - self._exit_caps[i]) / EXIT_BRAKE_BAND_MPS)), 0.0

    def _decide(self, s: State, pos: float, on_path: bool, laps_done: int) -> None:
        """Once per lap, a few hundred metres before the entry: stop this lap or not."""
        if not on_path and pos > -DECIDE_BEFORE_ENTRY_M and self.decided_lap != s.laps:
            self.decided_lap = int(s.laps)
            remaining = laps_after_box(s.remaining_laps, s.dist_from_start_m, self._box_from_start_m,
                                       self.track.length_m)
            self.wanted = self.given_up < MAX_GIVEN_UP and (
                (self.retry and remaining > 0) or self.strategy.wants_stop(laps_done, remaining, s.fuel_l, s.damage))

    def _steer_on_path(self, s: State, v: float) -> float:
        """Steer at the pit path a short way ahead."""
        assert self.path is not None
        ahead = s.dist_from_start_m + self.params.lookahead_m + 0.2 * v
        off = self.path.offset_at(ahead)
        j = int(ahead / self._step_m) % self._n
        mx, my = self._mid_xy[j]
        nx, ny = self._normals[j]
        return steer_to_point(s.x_m, s.y_m, s.yaw_rad, mx + off * nx, my + off * ny, self.car.steer_lock_rad)

    def _throttle(self, accel: float, v: float, pos: float, on_path: bool, target_mps: float | None,
                  brake: float) -> float:
        """Throttle under the pit lane's rules: none while braking or above the lane's target speed."""
        assert self.path is not None
        if self.wanted and on_path and self.options.pit_mode == "bang-bang":
            # no throttle towards the box beyond the speed from which half the grip still stops the
            # car there: the filter only brakes, so the robot would otherwise accelerate between its
            # full-brake calls and overshoot the box (constant-decel tracks a speed command instead)
            left = self.path.box_m - pos
            if left > 0.0 and v > max(3.0, math.sqrt(self._coast_decel * left)):
                accel = 0.0
        if target_mps is not None:
            if v > target_mps:
                accel = 0.0
            else:
                # proportional hold: holding the limit takes about 0.2 throttle, so a gain of 1 per
                # m/s settles 0.2 m/s below the target (inside the limit's 0.5 m/s margin)
                accel = min(accel, max(0.0, PIT_HOLD_GAIN_PER_MPS * (target_mps - v)))
        return 0.0 if brake > 0.0 else accel

    # --- the event log -----------------------------------------------------------------------------
    def _log(self, s: State, pos: float) -> None:
        assert self.path is not None
        if self.event is None:
            self.event = PitEvent(lap=int(s.laps), entry_time=round(s.sim_time_s, 3), mode=self.options.pit_mode)
        e = self.event
        if s.in_pit and e.stop_time is None:
            e.stop_time = round(s.sim_time_s, 3)
            e.stop_error_m = round(pos - self.path.box_m, 3)
        if not s.in_pit and e.stop_time is not None and e.leave_time is None:
            e.leave_time = round(s.sim_time_s, 3)

    def _close_event(self, s: State) -> None:
        assert self.event is not None
        self.event.exit_time = round(s.sim_time_s, 3)
        self.events.append(self.event)
        self.event = None

    def remaining_after_box(self, s: State) -> float:
        """Laps still to drive after the box, standing in it (TORCS's remaining laps exclude this lap)."""
        box = self._box_from_start_m
        return laps_after_box(s.remaining_laps, box, box, self.track.length_m)  # at the box: not behind us

    # --- TORCS's pit call and the race report -------------------------------------------------------
    def pit_stop(self, state: State) -> PitOrder:
        """Fuel for the rest of the race (or a full tank) and all the damage repaired, as planned."""
        fuel, repair = self.strategy.order(self.remaining_after_box(state), state.fuel_l, state.damage,
                                           self.car.tank_l)
        self.wanted = self.retry = False
        if self.event is not None and self.path is not None:
            self.event.fuel, self.event.repair = round(fuel, 2), round(repair, 1)
            if self.event.stop_time is None:
                self.event.stop_time = round(state.sim_time_s, 3)
                self.event.stop_error_m = round(self.path.signed_coord(state.dist_from_start_m) - self.path.box_m, 3)
        return PitOrder(fuel_l=fuel, repair=repair)

    @property
    def busy(self) -> bool:
        """A stop is asked for this lap or under way (the lap's times say nothing of the track)."""
        return self.wanted or self.phase is not None

    def report(self) -> dict:
        """{"pit_events": [...], "pit_plan": ...} for the driver's entry in the race JSON."""
        events = self.events + ([self.event] if self.event is not None else [])
        return {"pit_events": [e.to_json() for e in events], "pit_plan": self.plan}

