"""The default boxbox robot: the TORCS tutorial robot, rebuilt from boxbox's controllers.

Per track (on_track): car model, racing line, speed profile, gear box, learned turn factors, the
pit part (robot/pit.py). Per step (drive): look-ups and a few comparisons, one named step each,
in the order of the tutorial's filter chain (bt's driver.cpp: filterABS(filterBrakeSpeed(
filterBColl(filterBPit(getBrake()))))):

    new lap (learned factors, fuel: rebuild the profile) -> stuck (or behind a wreck)? back out
    learn (room left in this turn) -> traffic (cars near, overtaking offset)
    steer     = avoid_side(steer to the line + offset)
    brake, accel = speed (the profile) -> pits.step (stop in the box) -> avoid_collision
                 -> traction (ABS or TCL) -> guard_throttle (lock guard, spin guard)
    gear      = gears.select(gear, speed);  clutch (pit stop, start)
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from boxbox.control.carmodel import CarModel
from boxbox.control.gears import GearBox
from boxbox.control.offset_room import offset_room_ahead
from boxbox.control.steering import steer_to_line, steer_to_point
from boxbox.model import Car, Controls, PitOrder, State, Track
from boxbox.model.constants import G_MPS2
from boxbox.robot.base import RaceOptions, Robot
from boxbox.robot.bottoming import NO_PACKER_LIMIT_MPS
from boxbox.robot.learning import TurnLearner
from boxbox.robot.opponents import Nearby, OpponentParams
from boxbox.robot.params import BOUNDS, CHOICES, TutorialParams, load_params
from boxbox.robot.racecraft import Racecraft, inside_speed_mps
from boxbox.robot.tutorial.plan import TrackPlan
from boxbox.robot.tutorial.slip import WheelSlip
from boxbox.robot.tutorial.traffic import OFFSET_ROOM_AHEAD_M, PIT_PHASE_CODES, Traffic
from boxbox.robot.unstuck import Unstuck, UnstuckParams

TWO_PI = 2.0 * math.pi


class TutorialRobot(TrackPlan, Traffic, WheelSlip, Robot):
    name = "boxbox"
    param_class = TutorialParams  # what `boxbox tune` may search (robot/tunable.py)
    param_bounds = BOUNDS
    param_choices = CHOICES

    def __init__(self, options: RaceOptions | None = None) -> None:
        super().__init__(options)
        self.params: TutorialParams = None  # type: ignore[assignment]  # set by on_track
        self.learning_file: Path | None = None

    @classmethod
    def check_setup(cls, options: RaceOptions, track_name: str, car_name: str) -> None:
        """Fail early (before TORCS starts) on bad parameter files or --set values."""
        load_params(car_name, track_name, options.robot_args.get("set"))

    def on_track(self, track: Track, car: Car) -> None:
        super().on_track(track, car)
        p, _ = load_params(car.name, track.name, self.options.robot_args.get("set"))
        self.params = p
        self._prepare_line(track, car, p)
        mid = self.line.middle
        self._normals = [(-math.sin(h), math.cos(h)) for h in mid.heading_rad.tolist()]
        self._headings = mid.heading_rad.tolist()
        self._half_left = mid.half_left_m.tolist()
        self._half_right = mid.half_right_m.tolist()
        ahead = int(OFFSET_ROOM_AHEAD_M / self.step_m)
        room = offset_room_ahead(np.asarray(self.line.offset_m[: self.n]), mid.half_left_m[: self.n],
                                 mid.half_right_m[: self.n], ahead)
        self._offset_room_l, self._offset_room_r = room[0].tolist(), room[1].tolist()
        self.tyre_model = CarModel.from_car(car, fuel_l=car.initial_fuel_l)
        self._downforce_per_mg = self.tyre_model.ca / (self.tyre_model.mass_kg * G_MPS2)
        self.learner = TurnLearner.from_limits(self._limits([1.0] * self.n, self.tyre_model), self.step_m,
                                               self.line.length_m, p.max_speed_mps, gain=p.learn_gain,
                                               target_margin_m=p.learn_margin_m,
                                               steady_error_m=p.learn_steady_error_m)
        self._apex_sign, self._turn_sign = self._apex_signs()
        if p.learning and self.options.learning_dir:
            self.learning_file = Path(self.options.learning_dir) / f"{track.name}--{car.name}.json"
            self.learner.load(self.learning_file)
        self.fuel_l = car.initial_fuel_l
        self._packer_caps: list[float] | None = None
        self._brake_caps: np.ndarray | None = None
        self._build_profile()
        if p.elevation and p.packer_impact_mps < NO_PACKER_LIMIT_MPS:
            self._packer_caps = self._packer_speed_caps(car)
            self._build_profile()
        self._brake_caps = self._brake_ceiling(car)
        if self._brake_caps is not None:
            self.profile.cap(self._brake_caps)
        # how fast the car goes alone on its line (lap simulation): a car ahead slower than that holds us
        # up (only the slipstream pass asks: an empty list with it off)
        self._alone_mps = self._simulated_lap(car, self.tyre_model, p, "alone-laps")[3].tolist() \
            if p.draft_mps > 0.0 else []
        self.gears = GearBox(car, shift=p.shift, shift_margin_mps=p.shift_margin_mps)
        self._setup_slip(car, p)
        self.opp = OpponentParams(front_range_m=p.front_range_m, back_range_m=p.back_range_m,
                                  length_margin_m=p.length_margin_m, side_margin_m=p.side_margin_m,
                                  overtake_step_m=p.overtake_step_m, keep_side_s=p.keep_side_s,
                                  draft_mps=p.draft_mps, soft_gap_m=p.soft_gap_m, hazard_slip_deg=p.hazard_slip_deg,
                                  lapped_own_side=p.lapped_own_side)
        self.craft = Racecraft(p, car.width_m, car.length_m, self.tyre_model.mu)
        self._init_race_state()
        self._setup_pit(track, car, p)
        self.wheelbase_m = car.steering_wheelbase_m
        self.unstuck = Unstuck(track, car, UnstuckParams(angle_deg=p.stuck_angle_deg, speed_mps=p.stuck_speed_mps,
                                                         offset_m=p.stuck_offset_m, time_s=p.stuck_time_s,
                                                         back_range_m=p.back_range_m), self._heading_at)

    def _init_race_state(self) -> None:
        """What the drive steps keep between them: the race starts with none of it."""
        self.offset_m = 0.0
        self.target_mps = 0.0  # the speed profile's target the last drive step used
        self.blocked_steps = 0
        self._wrecks_until_s = -math.inf  # after backing from a wreck, stopped cars are driven round until then
        self.wreck: Nearby | None = None  # the stopped car ahead driven round this step
        self.laps_seen = 0
        self.last_damage = 0.0
        self._following, self._following_since_s = -1, 0.0  # the car close ahead in our lane, and since when

    def drive(self, s: State) -> Controls:
        """The tutorial's chain, like bt's abs(speed(coll(pit(brake())))): steer to the line and
        round other cars, then throttle and brake from the speed profile through the pit stop,
        collision avoidance, ABS and traction control and the throttle guards."""
        v = s.speed_x_mps
        if s.dist_from_start_m != s.dist_from_start_m:  # NaN: TORCS lost the car's place (a pile-up)
            return self.unstuck.blind(s)  # before the new lap: a lap needs the car's place
        if s.laps != self.laps_seen:
            self._new_lap(s)
        backing = self.unstuck.step(s)  # stuck (or behind a wreck, traffic.py): back out; boxed in: brake
        if backing is not None:
            return backing
        self._learn(s)
        cars = self._traffic(s, v)
        steer = self._avoid_side(self._steer(s, v), cars)
        brake, accel = self._speed(s, v)
        brake, accel, steer = self.pits.step(s, v, brake, accel, steer)
        brake = self._avoid_collision(brake, v, cars)
        # the plain slip only aside among cars: on the line the line's turn share holds, car behind or
        # not (with one behind boxbox spun out of g-track-1's turn at 1100 m, 1139 damage)
        brake, accel = self._traction(s, v, brake, accel, bool(cars) and self.offset_m != 0.0)
        accel = self._drive_room(s, v, accel)
        accel = self._guard_throttle(s, v, steer, accel)
        accel = self._release_engine_brake(s, v, brake, accel)
        gear = self.gears.select(int(s.gear), v)
        return Controls(steer=steer, accel=accel, brake=brake, clutch=self._clutch(gear, v, accel), gear=gear,
                        pit_request=self.pits.wanted)

    def _learn(self, s: State) -> None:
        """Tell the learner how much room the car left to the edge in this turn and how far the car
        was pushed outside its line near the apex."""
        if not self.learner.turns:
            return
        dist = s.dist_from_start_m  # never NaN here: drive() stops at a NaN distance
        i = int(dist / self.step_m) % self.n
        turn = self.learner.sample_index[i]
        # alone, traffic never spoiled a step: the learner's usual path, without the call
        skip, new = self.craft.tainted(s.sim_time_s, int(s.laps), turn if turn >= 0 else self.learner.last_turn) \
            if self.craft.spoiled_until_s > -math.inf else (False, False)
        if turn >= 0 and turn != self.learner.timing_turn:
            # a section with a pit stop in it or traffic about says nothing of the factor's worth
            self.learner.enter(turn, s.sim_time_s, spoiled=skip or self.pits.busy)
        if skip:  # traffic shaped this turn this lap (robot/racecraft.py): it teaches nothing of its grip
            if new:
                t = self.learner.turns[turn if turn >= 0 else self.learner.last_turn]
                t.min_margin_m, t.max_error_m, t.damaged, t.damage_points = 1e9, -1.0, False, 0.0
            self.last_damage = s.damage
            return
        error = None
        # room left to the limit of the drivable width (robot/drivable.py), at the car's side
        left_m, right_m = self._room_left[i] - s.to_middle_m, self._room_right[i] + s.to_middle_m
        margin = min(left_m, right_m)
        if self.params.steering == "line":
            sign = self._apex_sign[i]
            error = max(0.0, (self.line.offset_at(dist) + self.offset_m - s.to_middle_m) * sign) if sign else 0.0
            side = self._turn_sign[i]
            if side:
                margin = right_m if side > 0.0 else left_m
        self.learner.observe(i, margin, max(0.0, s.damage - self.last_damage), error)
        self.last_damage = s.damage

    def _steer(self, s: State, v: float) -> float:
        if self.wreck is not None:
            steer = self._steer_by_wreck(s, self.wreck)
            if steer is not None:
                return steer
        return self._steer_line(s, v) if self.params.steering == "line" else self._steer_lookahead(s, v)

    def _steer_line(self, s: State, v: float) -> float:
        """Follow the racing line (shifted by the overtaking offset, inside the usable width)."""
        p, dist = self.params, s.dist_from_start_m
        ahead = dist + v * p.line_preview_s
        line_off = self.line.offset_at(dist)
        if self.offset_m:
            j = int(dist / self.step_m) % self.n
            line_off = self._moved_line(j, line_off)
        heading_error = (self.line.heading_at(ahead) - s.yaw_rad + math.pi) % TWO_PI - math.pi
        # slip angle per lateral acceleration falls as downforce loads the tyres
        understeer = p.line_understeer_rad_per_mps2 / (1.0 + self._downforce_per_mg * v * v)
        return steer_to_line(heading_error, line_off - s.to_middle_m, self.line.curvature_at(ahead), v,
                             s.yaw_rate_rps, self.wheelbase_m, self.car.steer_lock_rad, p.line_lateral_gain,
                             p.line_yaw_damping_s, understeer_rad_per_mps2=understeer)

    def _steer_lookahead(self, s: State, v: float) -> float:
        """The tutorial's steering: at a point on the line lookahead_m + lookahead_s x speed ahead."""
        p = self.params
        target_dist = s.dist_from_start_m + p.lookahead_m + p.lookahead_s * v
        tx, ty = self.line.point_at(target_dist)
        if self.offset_m:
            j = int(target_dist / self.step_m) % self.n
            line_off = self.line.offset_at(target_dist)
            off = self._moved_line(j, line_off) - line_off
            nx, ny = self._normals[j]
            tx += off * nx
            ty += off * ny
        return steer_to_point(s.x_m, s.y_m, s.yaw_rad, tx, ty, self.car.steer_lock_rad)

    def _speed(self, s: State, v: float) -> tuple[float, float]:
        """(brake, accel) from the speed profile a little ahead of the car."""
        p = self.params
        target = self.profile.speed_at(s.dist_from_start_m + v * p.speed_lookahead_s)
        self._profile_mps = target  # the plan alone, before traffic lowers it (the ABS's hold)
        if self.offset_m and self.craft.p.inside_speed:  # off the line in traffic: its radius, not the line's
            target = inside_speed_mps(target, self.line.curvature_at(s.dist_from_start_m + v * p.speed_lookahead_s),
                                      self.offset_m)
        if self.wreck is not None:
            target = min(target, self.craft.p.wreck_speed_mps)
        self.target_mps = target  # for telemetry
        if v > target:
            return min(1.0, (v - target) / p.brake_band_mps), 0.0
        margin = target - v
        return 0.0, (1.0 if margin >= p.full_accel_margin_mps else 0.4 + 0.6 * margin / p.full_accel_margin_mps)

    def _clutch(self, gear: int, v: float, accel: float) -> float:
        """Open while stopping at the box (brakes alone, predictable); slipping at the start."""
        p = self.params
        if self.pits.clutch_open and accel == 0.0:
            return 1.0
        if gear == 1 and v < p.clutch_release_mps:
            return min(p.clutch_start, p.clutch_start * (1.0 - v / p.clutch_release_mps))
        return 0.0

    def _new_lap(self, s: State) -> None:
        first = self.laps_seen == 0
        self.laps_seen = int(s.laps)
        if first:
            return
        self.fuel_l = s.fuel_l
        self._end_lap_learning(s)
        self._build_profile()

    def _end_lap_learning(self, s: State) -> None:
        """The lap's lessons per turn (robot/learning.py), for the next laps; the learning file is
        written once, at the race's end (a write inside a drive step took over 200 ms on a busy
        disk, past the step budget: 23 of about 400 field races on a loaded machine)."""
        if not self.params.learning:
            return
        self.learner.close(s.sim_time_s, spoiled=self.pits.busy)
        self.learner.end_lap()

    def on_race_end(self, state: State) -> None:
        """The last lap teaches too (nothing after the finish line calls drive() again); then the
        lessons go to the learning file, once (the host calls this once, in every ending)."""
        if self.laps_seen >= 1 and self.learner.turns:
            self._end_lap_learning(state)
        if self.params.learning and self.learning_file is not None:
            self.learner.save(self.learning_file, self.track.name, self.car.name)

    def pit_stop(self, state: State) -> PitOrder:
        return self.pits.pit_stop(state)

    def race_report(self) -> dict:
        report = self.pits.report()
        if getattr(self, "wing_laps_s", None):
            report["rear_wing_deg"] = round(math.degrees(self.car.rear_wing_angle_rad), 1)
            report["rear_wing_laps_s"] = self.wing_laps_s  # the simulated lap per angle tried
        return report

    def telemetry_fields(self) -> tuple[str, ...]:
        return ("target_speed_mps", "pit_phase", "offset_m", "reversing")

    def telemetry(self, s: State) -> tuple[float, ...]:
        """The target speed drive() used (the speed profile speed_lookahead_s ahead of the car), the
        pit phase code (PIT_PHASE_CODES), the overtaking offset and 1 while reversing out of a stuck
        position.  Values drive() stored: nothing is computed here."""
        return (self.target_mps, PIT_PHASE_CODES.get(self.pits.phase, -1), self.offset_m, self.unstuck.reversing)
