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

import dataclasses
import math
from pathlib import Path

import numpy as np

from boxbox.cache import cached_array
from boxbox.control import carmodel, fuel, lapsim, speed, suspension, tyre
from boxbox.control.braking import brake_distance, brake_limited_speed
from boxbox.control.carmodel import CarModel
from boxbox.control.engine import engine_brake_power_w, engine_brake_share
from boxbox.control.gears import GearBox
from boxbox.control.offset_room import offset_room_ahead
from boxbox.control.pit_brake import ENTRY, EXIT, FREE, GAVE_UP, HOLD, LANE, LIMIT, STOP
from boxbox.control.speed import SpeedProfile, allowed_speed, bump_speed, crest_speed
from boxbox.control.steering import steer_to_line, steer_to_point
from boxbox.control.trackwidth import CUT_LIMIT_CAR_WIDTHS
from boxbox.control.traction import (
    SlipParams,
    abs_filter,
    abs_hold,
    combined_slip_room,
    drive_axles,
    drive_force_room_n,
    driven_wheel_speed_mps,
    spare_slip_ratio,
    tcl_from_slip,
    throttle_for_torque,
)
from boxbox.model import Car, CarSetup, Controls, PitOrder, State, Track
from boxbox.model.car import FWD, RWD, STEERING_WHEELBASE_SHARE
from boxbox.model.constants import DRIVE_STEP_S, G_MPS2
from boxbox.model.skill import SkillLevel
from boxbox.robot import bottoming, carsetup
from boxbox.robot.base import FUEL_L_PER_M_ESTIMATE, RaceOptions, Robot
from boxbox.robot.bottoming import NO_PACKER_LIMIT_MPS, packer_speed_caps
from boxbox.robot.carsetup import best_rear_wing_rad
from boxbox.robot.drivable import centre_room
from boxbox.robot.learning import TurnLearner
from boxbox.robot.opponent_lines import OpponentLines
from boxbox.robot.opponents import (
    Nearby,
    OpponentParams,
    collision_brake,
    hazard_brake,
    in_lane,
    nearby,
    overtake_offset,
    side_steer,
)
from boxbox.robot.params import BOUNDS, CHOICES, TutorialParams, load_params
from boxbox.robot.pit import PitParams, PitStops
from boxbox.robot.planning import Road, TrafficPlanner
from boxbox.robot.racecraft import (
    TURN_CURVATURE_1PM,
    Racecraft,
    RacecraftParams,
    conflict_time_s,
    inside_speed_mps,
    on_our_path,
)
from boxbox.robot.racingline import RacingLine, middle_line, washboard
from boxbox.robot.start_fuel import MODEL_MARGIN, start_fuel_l
from boxbox.robot.strategy import OUT_DAMAGE

TWO_PI = 2.0 * math.pi
DAMAGE_DRAG_POINTS = 5000.0  # the damage the drag's cost per point is measured at
# the pit brake filter's phase as a number for telemetry (0: no pit business)
PIT_PHASE_CODES = {None: 0, FREE: 0, ENTRY: 1, LIMIT: 2, LANE: 3, STOP: 4, HOLD: 5, EXIT: 6, GAVE_UP: 7}
REVERSE_MAX_S = 4.0  # longest time backing out in one go
REVERSE_MAX_MPS = 4.0  # no throttle in reverse beyond this speed
BACKWARDS_RAD = 0.5 * math.pi  # pointing further than this from the track's direction: turned round
GRINDING_S = 0.5  # damage this recent: still pushing into something
BOXED_MPS = 1.0  # backing out slower than this and grinding: boxed in (cars stopped front and back)
BOXED_HOLD_S = 1.0  # boxed in: held on the brakes this long before trying again
REVERSE_CLEAR_S = 3.0  # no backing while a car coming from behind would reach us within this
FOLLOW_LENGTHS = 3.0  # a car this many of our lengths ahead (centre to centre) in our lane: we follow it
LOCK_SHARE = 0.95  # |steer| from which the steering counts as at its lock
LOCK_MIN_SPEED_MPS = 10.0  # below this (leaving the grid onto the line) full lock is no sign of a slide
OPPONENT_LINE_STEP_M = 5.0  # the step other cars' lines are remembered at (a car length)
# an overtaking offset keeps inside the room over this much road ahead (20-50 m measured: docs/racecraft.md;
# 40 m won more field races but failed the integration race from third on g-track-1)
OFFSET_ROOM_AHEAD_M = 30.0


class TutorialRobot(Robot):
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

    # --- per track -----------------------------------------------------------------------------
    def initial_fuel_l(self, track: Track, car: Car) -> float | None:
        """--fuel-laps if given; else from the fuel a simulated lap takes (robot/start_fuel.py)."""
        if self.options.fuel_laps is not None or not self.options.laps:
            return super().initial_fuel_l(track, car)
        return start_fuel_l(self.options.laps, self._lap_fuel_l(track, car), car.tank_l, track.pit is not None,
                            self.options.cars > 1)

    def _lap_fuel_l(self, track: Track, car: Car) -> float:
        """Litres a lap of the racing line takes at the speeds of its simulated lap (control/fuel.py),
        the car carrying half of what the per-metre estimate gives the race."""
        race_l = FUEL_L_PER_M_ESTIMATE * car.fuel_cons_factor * track.length_m * max(1, self.options.laps)
        if len(car.torque_curve_nm) < 2:  # no engine to simulate: the per-metre estimate
            return race_l / max(1, self.options.laps)
        p, _ = load_params(car.name, track.name, self.options.robot_args.get("set"))
        self.params = p
        self._prepare_line(track, car, p)
        model = CarModel.from_car(car, fuel_l=0.5 * min(car.tank_l, race_l))
        step_m, _, _, speeds, point_mass = self._simulated_lap(car, model, p, "fuel-laps")
        return fuel.lap_fuel_l(step_m, speeds, point_mass.mass_kg, point_mass.cw_n_per_mps2, car.fuel_cons_factor,
                               engine_brake_power_w(car))

    def _simulated_lap(self, car: Car, model: CarModel, p: TutorialParams, kind: str
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, lapsim.PointMassCar]:
        """The current line's step (m), curvature and grip per sample, the speeds (m/s) of its lap
        simulation with the robot's own limits, and the point mass with the ideal gearbox
        (robot/carsetup.py) it simulated; cached under `kind`: the same line, car and limits give
        the same lap (~10-35 ms of simulation)."""
        step_m, curv, mu, limits = self._lap_inputs(model, p)
        point_mass = carsetup.ideal_gearbox_car(car, model)

        def lap() -> np.ndarray:
            return lapsim.lap_speeds_mps(step_m, curv, mu, point_mass, corner_limit_mps=limits)

        key = [Path(str(lapsim.__file__)).read_bytes(), Path(str(carsetup.__file__)).read_bytes(),
               repr(point_mass).encode(), *(a.tobytes() for a in (limits, step_m, curv, mu))]
        return step_m, curv, mu, cached_array(kind, key, lap), point_mass

    def car_setup(self, track: Track, car: Car) -> CarSetup | None:
        """The rear wing angle that laps fastest on this track (robot/carsetup.py), with `wing_setup`."""
        p, _ = load_params(car.name, track.name, self.options.robot_args.get("set"))
        if not p.wing_setup:
            return None
        self.params = p
        self._prepare_line(track, car, p)
        fuel_l = self.initial_fuel_l(track, car)
        base = CarModel.from_car(car, fuel_l=car.initial_fuel_l if fuel_l is None else fuel_l)
        step_m = [self.step_m * f for f in self.line.length_factor[: self.n].tolist()]
        # the cornering grip: the simulation's own point-mass corner limit must not undercut the robot's
        corner_mu = [base.mu * f * p.mu_scale for f in self._friction]

        def choose() -> np.ndarray:
            angle, times = best_rear_wing_rad(car, base.mass_kg - car.mass_kg, step_m, self._curv, corner_mu,
                                              lambda model: self._limits([1.0] * self.n, model), p.rear_balance)
            return np.array([angle, *times.keys(), *times.values()])

        # cached: the same line, car and parameters choose the same wing (~50-100 ms of simulated laps)
        key = [*(Path(str(m.__file__)).read_bytes() for m in (carsetup, lapsim, speed, carmodel, tyre)),
               Path(__file__).read_bytes(), repr((dataclasses.astuple(car), dataclasses.astuple(p), fuel_l)).encode(),
               np.ascontiguousarray(self.line.curvature_1pm).tobytes()]
        chosen = cached_array("car-setups", key, choose).tolist()
        angle, tried = chosen[0], (len(chosen) - 1) // 2
        angles, laps = chosen[1:1 + tried], chosen[1 + tried:]
        self.wing_laps_s = {round(math.degrees(a), 1): round(t, 3) for a, t in zip(angles, laps, strict=True)}
        return CarSetup(rear_wing_angle_rad=angle) if angle != car.rear_wing_angle_rad else None

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
        self.craft = Racecraft(RacecraftParams(), car.width_m, car.length_m, self.tyre_model.mu)
        self.opp_lines = OpponentLines(track.length_m, OPPONENT_LINE_STEP_M)
        self.planning = TrafficPlanner(self._road(car), track.length_m, car.width_m, car.length_m) \
            if p.planner else None
        self._init_race_state()
        self._setup_pit(track, car, p)
        self._inv_lock = 1.0 / car.steer_lock_rad
        self.wheelbase_m = car.steering_wheelbase_m
        self._stuck_angle = math.radians(p.stuck_angle_deg)

    def _road(self, car: Car) -> Road:
        """What the traffic planner reads of the road per sample: our line and the lateral positions our
        centre may take, RacecraftParams.edge_m inside the track's edges (or the line, where beyond)."""
        line = np.asarray(self.line.offset_m[: self.n], dtype=float)
        inside = 0.5 * car.width_m + self.craft.p.edge_m
        left = np.maximum(np.asarray(self._half_left[: self.n]) - inside, line)
        right = np.minimum(inside - np.asarray(self._half_right[: self.n]), line)
        return Road(self.step_m, line, left, right)

    def _setup_slip(self, car: Car, p: TutorialParams) -> None:
        """ABS and traction control, and what the level's tyre lets the throttle use in a turn."""
        self.radii = (car.wheel_radius_fr_m, car.wheel_radius_fl_m, car.wheel_radius_rr_m, car.wheel_radius_rl_m)
        shape = (car.tyre_stiffness_rr, car.tyre_dynamic_friction_rr, car.tyre_elasticity_rr)
        peak = tyre.peak_slip(*shape)
        # a tyre whose force never peaks (dynamic friction 1: the buggy's) gives no slip ratio to aim
        # for: the tutorial's fixed slip (with the ratio the buggy hit g-track-1's wall every lap)
        self._peak_slip = peak if peak < tyre.MAX_SLIP else 0.0
        # where the level's tyre loses force past its peak (pro), the throttle is gone before the
        # driven wheels' slip has grown by the peak's ratio (mixed-2 at pro: a spin out of a hairpin
        # in first gear at 44 % slip, which the tutorial's 10 m/s range allowed at 16 m/s)
        holds = self._peak_slip > 0.0 and tyre.falls_past_peak(*shape, SkillLevel(car.skill_level).skid_factor)
        self._holds_peak = holds and len(car.torque_curve_nm) >= 2
        # the weight on the front axle is the CG's share of the wheelbase behind it
        # (in this order: the product rounds as the robot's measured figures had it)
        self._cg_to_rear_m = car.front_weight_share * STEERING_WHEELBASE_SHARE * car.length_m
        self._axles = drive_axles(car)
        self._drive_radius_m = car.wheel_radius_fr_m if car.drivetrain == FWD else car.wheel_radius_rr_m
        self.slip = SlipParams(abs_slip_mps=p.abs_slip_mps, abs_range_mps=p.abs_range_mps,
                               tcl_slip_mps=p.tcl_slip_mps, tcl_slip_ratio=p.tcl_slip_ratio,
                               tcl_range_mps=p.tcl_range_mps, tcl_range_ratio=peak if holds else math.inf,
                               abs_min_speed_mps=p.slip_min_speed_mps, tcl_min_speed_mps=p.slip_min_speed_mps,
                               abs_hold_over_mps=p.abs_hold_over_mps, abs_hold_share=p.abs_hold_share)
        self._abs_brake, self._abs_at_s = 0.0, -math.inf  # the brake the last drive step gave, and when
        self._profile_mps = math.inf  # the speed profile's target this drive step (_speed)

    def _init_race_state(self) -> None:
        """What the drive steps keep between them: the race starts with none of it."""
        self.offset_m = 0.0
        self.target_mps = 0.0  # the speed profile's target the last drive step used
        self.stuck_steps = 0
        self.reversing = False
        self.reverse_steps = 0
        self.blocked_steps = 0
        self._damage_seen, self._grinding_until_s = 0.0, -math.inf  # for _grinding
        self._hold_until_s = -math.inf  # boxed in: on the brakes until then
        self._backing_on_throttle = False  # the last backing step gave throttle (not waiting for a car)
        self._backing_from_m: float | None = None  # where backing away from a wreck began
        self._wrecks_until_s = -math.inf  # after backing from a wreck, stopped cars are driven round until then
        self.wreck: Nearby | None = None  # the stopped car ahead driven round this step
        self.laps_seen = 0
        self.last_damage = 0.0
        self._following, self._following_since_s = -1, 0.0  # the car close ahead in our lane, and since when
        self._speed_share = 1.0  # the share of the speed profile the traffic planner drives at (robot/planning.py)

    def _prepare_line(self, track: Track, car: Car, p: TutorialParams) -> None:
        """The racing line and what the speed limits need of it per sample (once: car_setup made it
        already when on_track comes for the same track and parameters)."""
        if getattr(self, "_line_for", None) == (id(track), car.width_m, p):
            return
        self._line_for = (id(track), car.width_m, p)
        bounds = self._line_bounds(track, car, p)
        self._set_line(RacingLine(track, step_m=2.0, margin_m=p.line_margin_m, blend=p.racing_line, bounds_m=bounds), p)
        if p.line_speed_margin_s > 0.0:
            self._set_line(RacingLine(track, step_m=2.0, margin_m=p.line_margin_m, blend=p.racing_line,
                                      bounds_m=self._fast_turn_bounds(car, p, bounds)), p)

    def _lap_inputs(self, model: CarModel, p: TutorialParams
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What the lap simulation needs of the current line, per sample: the step (m), the
        curvature, the grip and the robot's own speed limits (unlearned)."""
        limits = np.maximum(np.asarray(self._limits([1.0] * self.n, model)), 0.1)
        step_m = np.asarray(self.line.length_factor[: self.n]) * self.step_m
        mu = model.mu * np.asarray(self._friction) * p.mu_scale
        return step_m, np.asarray(self._curv), mu, limits

    def _fast_turn_bounds(self, car: Car, p: TutorialParams, bounds: tuple[np.ndarray, np.ndarray]
                          ) -> tuple[np.ndarray, np.ndarray]:
        """The bounds with more room kept outside each turn where the line's simulated lap is fast and
        near its grip: a car slides out of its line by more the faster it goes (g-track-1's long left
        turn at 45 m/s left the track from a line on the outer edge), never in."""
        model = CarModel.from_car(car, fuel_l=car.initial_fuel_l)
        _, curv, mu, v, _ = self._simulated_lap(car, model, p, "fast-turn-laps")
        grip = mu * (G_MPS2 + v * v * model.ca_corner / model.mass_kg)
        use = np.clip(v * v * curv / grip, 0.0, 1.0)
        extra = p.line_speed_margin_s * v * use
        k = self.line.curvature_1pm[: self.n]
        left, right = bounds
        # a left turn (k > 0) throws the car out to the right
        return (np.maximum(left - np.where(k < 0.0, extra, 0.0), 0.0),
                np.maximum(right - np.where(k > 0.0, extra, 0.0), 0.0))

    def _set_line(self, line: RacingLine, p: TutorialParams) -> None:
        self.line = line
        mid = self.line.middle
        self.step_m = self.line.step_m
        self.n = mid.n
        self._friction = [float(f) for f in mid.friction[: self.n]]
        self._curv = [abs(k) for k in self.line.curvature_1pm[: self.n].tolist()]
        self._vcurv = self.line.vertical_curvature_1pm[: self.n].tolist() if p.elevation else [0.0] * self.n
        self._rough = self.line.roughness_1pm[: self.n].tolist() if p.elevation else [0.0] * self.n
        # bumps that repeat (a washboard) are taken at bump_accel_mps2; a single kink at kink_accel_mps2
        board = washboard(np.asarray(self._rough), self.step_m)
        self._bump_accel = np.where(board, p.bump_accel_mps2, p.kink_accel_mps2).tolist()
        # banking into the turn the line takes (TORCS's angle is + with the left edge higher)
        turn_sign = np.sign(self.line.curvature_1pm[: self.n])
        self._bank = (-turn_sign * mid.bank_rad[: self.n]).tolist() if p.banking else [0.0] * self.n

    def _line_bounds(self, track: Track, car: Car, p: TutorialParams) -> tuple[np.ndarray, np.ndarray]:
        """Room for the racing line left and right per sample (robot/drivable.py), and the room for
        the car's centre the learner measures margins against."""
        mid = middle_line(track, 2.0)
        n = mid.n
        ride_m = min(car.ride_height_fr_m, car.ride_height_fl_m, car.ride_height_rr_m, car.ride_height_rl_m)
        room_l, room_r = centre_room(track, mid.seg_id[:n], mid.seg_frac[:n], mid.half_left_m[:n], car.width_m,
                                     p.track_limits, ride_m)
        self._room_left, self._room_right = room_l.tolist(), room_r.tolist()
        safety_m = p.line_margin_m - 0.5 * car.width_m
        # beyond the track's edge a car that runs wide still finds grip (the sides' part it may use);
        # beyond the sides' there is grass, gravel or a wall: keep side_catch_m more from it
        half = mid.half_left_m[:n]
        strict = np.maximum(half - p.line_margin_m, 0.0)
        # where TORCS's cutting limit on a turn's inside binds, the sides go on beyond it and a car
        # does not slide inwards: the smaller cut_catch_m
        cut = half + CUT_LIMIT_CAR_WIDTHS * car.width_m
        catch_l = np.where(np.isclose(room_l, cut), p.cut_catch_m, p.side_catch_m)
        catch_r = np.where(np.isclose(room_r, cut), p.cut_catch_m, p.side_catch_m)
        bound_l = np.where(room_l > half - 0.5 * car.width_m, room_l - safety_m - catch_l, room_l - safety_m)
        bound_r = np.where(room_r > half - 0.5 * car.width_m, room_r - safety_m - catch_r, room_r - safety_m)
        return np.maximum(bound_l, np.minimum(strict, room_l)), np.maximum(bound_r, np.minimum(strict, room_r))

    def _setup_pit(self, track: Track, car: Car, p: TutorialParams) -> None:
        """The pit part (robot/pit.py), joining the racing line at the pit entry and exit."""
        entry_offset_m = exit_offset_m = entry_slope = exit_slope = 0.0
        if track.pit is not None:
            seg = track.seg
            entry_m = float(seg["start_dist_m"][track.pit.entry_seg])
            exit_m = float(seg["start_dist_m"][track.pit.exit_seg] + seg["length_m"][track.pit.exit_seg])
            line = self.line
            entry_offset_m, exit_offset_m = line.offset_at(entry_m), line.offset_at(exit_m)
            step = self.step_m

            def slope(d: float) -> float:  # the line's lateral slope, d offset / d s
                return (line.offset_at(d + step) - line.offset_at(d - step)) / (2.0 * step)

            entry_slope, exit_slope = slope(entry_m), slope(exit_m)
        params = PitParams(lookahead_m=p.pit_lookahead_m, mu_source=p.pit_mu_source, mu=p.pit_mu,
                           brake_mu_scale=p.pit_brake_mu_scale, entry_braking=p.pit_entry_braking,
                           brake_ahead_m=p.pit_brake_ahead_m, give_up_s=p.pit_give_up_s,
                           stop_threshold_m=p.pit_stop_threshold_m, stop_grip_share=p.pit_stop_grip_share,
                           brake_method=p.brake_method)
        self.pits = PitStops(track, car, self.options, params, self.tyre_model, entry_offset_m, exit_offset_m,
                             entry_slope, exit_slope, self._damage_lap_cost_s(car),
                             self._lap_fuel_l(track, car) * (1.0 + MODEL_MARGIN))

    def _damage_lap_cost_s(self, car: Car) -> float:
        """Lap time (s) one damage point costs: TORCS 1.3.7 multiplies the body's and the wings'
        drag by 1 + damage / 10000 (simuv2 aero.cpp), so the lap simulation with the drag of 5000
        points (x 1.5) against none, over 5000 (e-track-4 +6.7 s a lap, mixed-2 +0.05 s)."""
        model = self.tyre_model
        step_m, curv, mu, limits = self._lap_inputs(model, self.params)
        point = carsetup.ideal_gearbox_car(car, model)

        def cost() -> np.ndarray:
            def lap(drag_factor: float) -> float:
                slower = dataclasses.replace(point, cw_n_per_mps2=point.cw_n_per_mps2 * drag_factor)
                speeds = lapsim.lap_speeds_mps(step_m, curv, mu, slower, corner_limit_mps=limits)
                return lapsim.lap_time_s(step_m, speeds)
            return np.array([(lap(1.0 + DAMAGE_DRAG_POINTS / OUT_DAMAGE) - lap(1.0)) / DAMAGE_DRAG_POINTS])

        key = [Path(str(lapsim.__file__)).read_bytes(), repr(dataclasses.astuple(point)).encode(),
               *(a.tobytes() for a in (limits, step_m, curv, mu))]
        return float(cached_array("damage-lap-cost", key, cost)[0])

    def _apex_signs(self) -> tuple[list[float], list[float]]:
        """Per sample: the turn direction (+1 left, -1 right) where the line curves at least half as
        much as at its tightest in that turn, else 0.  The learner judges understeer there: turning
        in, the car may still be settling onto the line, which says nothing about the turn's grip.
        Second list: the same where the line curves at least a quarter as much; there only the outer
        edge counts as leaving the track (a wheel over the inside kerb is a steering matter, and
        slowing the turn down does not bring it back)."""
        signs = [0.0] * self.n
        sides = [0.0] * self.n
        k_signed = self.line.curvature_1pm[: self.n].tolist()
        members: dict[int, list[int]] = {}
        for i, t in enumerate(self.learner.sample_index):
            if t >= 0:
                members.setdefault(t, []).append(i)
        for samples in members.values():
            peak = max(self._curv[i] for i in samples)
            for i in samples:
                direction = 1.0 if k_signed[i] > 0.0 else -1.0
                if self._curv[i] >= 0.5 * peak:
                    signs[i] = direction
                if self._curv[i] >= 0.25 * peak:
                    sides[i] = direction
        return signs, sides

    def _limits(self, factors: list[float], model: CarModel) -> list[float]:
        p = self.params
        out = []
        for k, kv, rough, f, g, bank, bump in zip(self._curv, self._vcurv, self._rough, self._friction, factors,
                                                  self._bank, self._bump_accel, strict=False):
            mu = model.mu * f * p.mu_scale * g
            v = allowed_speed(1.0 / k if k > 1e-9 else math.inf, mu, model, p.max_speed_mps, kv, bank)
            if kv < 0.0:
                v = min(v, crest_speed(kv, model, p.crest_load_share, p.max_speed_mps))
            if rough > 0.0:
                v = min(v, bump_speed(rough, bump, p.max_speed_mps))
            out.append(v)
        return out

    def _packer_speed_caps(self, car: Car) -> list[float]:
        """Speed caps per sample that keep the wheels off their packers (robot/bottoming.py), at the
        start's fuel; cached, as the same track, line, car and profile give the same caps (the
        search takes up to a second)."""
        def speeds_with(caps: np.ndarray) -> np.ndarray:
            self._packer_caps = caps.tolist()
            self._build_profile()
            return np.asarray(self.profile.target_speeds)

        def compute() -> np.ndarray:
            return packer_speed_caps(self.track, self.line, car, carsetup.ideal_gearbox_car(car, self.model),
                                     self.params.packer_impact_mps, speeds_with)

        seg = self.track.seg
        flat = np.zeros(len(seg["start_z_m"]))
        key = [Path(str(bottoming.__file__)).read_bytes(), Path(str(suspension.__file__)).read_bytes(),
               repr(dataclasses.astuple(car)).encode(), repr(self.params.packer_impact_mps).encode(),
               *(np.ascontiguousarray(a).tobytes() for a in (
                   self.line.offset_m, self.profile.target_speeds, self.learner.factors_per_sample(),
                   seg["start_z_m"], seg["end_z_m"], seg["start_dist_m"], seg["start_width_m"],
                   seg.get("banking_start_rad", flat), seg.get("banking_end_rad", flat)))]
        return cached_array("packer-caps", key, compute).tolist()

    def _build_profile(self) -> None:
        """The speed profile for the current fuel load and learned turn factors, under the brakes'
        ceiling where there is one (_brake_ceiling)."""
        p = self.params
        model = self.tyre_model.with_fuel(self.fuel_l)
        factors = self.learner.factors_per_sample()
        corner_mu = self._corner_grip(model, factors)
        # per sample, for traction control: the line's curvature over the corner grip (a turn's share
        # of the grip at speed v is v^2 k / (mu (g + CA v^2 / m)))
        self._k_per_mu = [k / mu for k, mu in zip(self._curv, corner_mu, strict=False)]
        self._ca_per_kg = model.ca_corner / model.mass_kg
        self._corner_mu = corner_mu
        self.profile = self._speed_profile(model, factors, corner_mu)
        if self._brake_caps is not None:
            self.profile.cap(self._brake_caps)
        self.model = model
        method = p.brake_method
        self._brakedist = lambda v1, v2, mu=model.mu: brake_distance(v1, v2, mu, model, method)

    def _corner_grip(self, model: CarModel, factors: list[float]) -> list[float]:
        """Per sample, the grip the profile corners on: tyre x surface x mu_scale x learned factor."""
        scale = self.params.mu_scale
        return [model.mu * f * scale * g for f, g in zip(self._friction, factors, strict=False)]

    def _speed_profile(self, model: CarModel, factors: list[float], corner_mu: list[float]) -> SpeedProfile:
        """The profile of `model` on this line (the tyres' plan, or the brakes' for their ceiling)."""
        p = self.params
        limits = self._limits(factors, model)
        if self._packer_caps is not None:
            limits = [min(v, cap) for v, cap in zip(limits, self._packer_caps, strict=True)]
        brake_mu = [model.mu * f * p.brake_mu_scale for f in self._friction]
        return SpeedProfile(limits, brake_mu, model, self.step_m, max_speed_mps=p.max_speed_mps,
                            curvature_1pm=self._curv if p.friction_circle else None, corner_mu=corner_mu,
                            brake_method=p.brake_method, vertical_curvature_1pm=self._vcurv if p.elevation else None)

    def _brake_ceiling(self, car: Car) -> np.ndarray | None:
        """A ceiling on the speed profile where the brakes, not the tyres, limit: the speeds the
        brakes, the engine's brake and all the drag can slow the car for (control/braking.py with
        CarModel.from_car(brakes=True)), one brake band over, at the samples where they are below the
        tyres' plan (the 155-DTM's brakes give 19 m/s^2: on its tyres' plan it came into street-1's
        hairpin 9 m/s fast and hit the wall, 330 damage).  The band is the speed controller's own;
        a learned faster turn elsewhere stays the learner's.  None where the brakes never bind below
        the top speed, or cannot lock the wheels even at rest (buggy, baja-bug: 3-5 m/s^2, a regime of
        its own: on the brakes' plan the buggy hit the road tracks' walls less but was slower on its
        own dirt track, mixed-2 +3.1 s)."""
        p = self.params
        model = CarModel.from_car(car, fuel_l=self.fuel_l, brakes=True)
        top_mu = model.mu * max(self._friction) * p.brake_mu_scale
        if model.brake_force_n < model.mu * p.brake_mu_scale * G_MPS2 * model.mass_kg \
                or brake_limited_speed(top_mu, model) >= p.max_speed_mps:
            return None
        factors = self.learner.factors_per_sample()
        corner_mu = self._corner_grip(model, factors)
        brakes_mps = self._speed_profile(model, factors, corner_mu).target_speeds
        # only where the brakes lower the plan: elsewhere a learned faster turn stays the learner's
        return np.where(brakes_mps < self.profile.target_speeds, brakes_mps + p.brake_band_mps, math.inf)

    # --- per step: the filter chain ---------------------------------------------------------------
    def drive(self, s: State) -> Controls:
        """The tutorial's chain, like bt's abs(speed(coll(pit(brake())))): steer to the line and
        round other cars, then throttle and brake from the speed profile through the pit stop,
        collision avoidance, ABS and traction control and the throttle guards."""
        v = s.speed_x_mps
        if s.dist_from_start_m != s.dist_from_start_m:  # NaN: TORCS lost the car's place (a pile-up)
            return self._blind(s)
        if s.laps != self.laps_seen:
            self._new_lap(s)
        if s.sim_time_s < self._hold_until_s:  # boxed in: pushing either way only takes damage
            self._damage_seen = s.damage  # what hits us meanwhile is no reason to back out after
            return self._blind(s)
        if self._stuck(s):
            return self._back_out(s, v)
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
        if cars:  # behind a slower car: coast before the gap brake, not throttle and brake in turn
            accel = self.craft.lift(accel, v, cars, self._brakedist)
        accel = self._guard_throttle(s, v, steer, accel)
        accel = self._release_engine_brake(s, v, brake, accel)
        gear = self.gears.select(int(s.gear), v)
        return Controls(steer=steer, accel=accel, brake=brake, clutch=self._clutch(gear, v, accel), gear=gear,
                        pit_request=self.pits.wanted)

    def _blind(self, s: State) -> Controls:
        """No place on the track to drive by: brake in the gear the car is in until TORCS finds it."""
        gear = int(s.gear) if s.gear == s.gear and 1 <= s.gear <= self.car.max_gear else 1
        return Controls(steer=0.0, accel=0.0, brake=1.0, clutch=0.0, gear=gear)

    def _back_out(self, s: State, v: float) -> Controls:
        """Reverse, steering the nose back towards the track's direction; held on the brakes while
        a car comes up from behind (the backing car is in its way)."""
        steer = max(-1.0, min(1.0, -s.angle_rad * self._inv_lock))
        self._backing_on_throttle = False
        if s.opponents and self._coming_from_behind(s):
            self.reverse_steps -= 1  # waiting is no time spent backing
            return Controls(steer=steer, accel=0.0, brake=1.0, clutch=0.0, gear=-1)
        # backing out is for turning round, not for speed: off the track it slid into walls at 11 m/s
        accel = 0.6 if v > -REVERSE_MAX_MPS else 0.0
        self._backing_on_throttle = accel > 0.0
        return Controls(steer=steer, accel=accel, brake=0.0, clutch=0.0, gear=-1)

    def _coming_from_behind(self, s: State) -> bool:
        """A moving car behind us that reaches us within REVERSE_CLEAR_S (e-track-2, 10 laps: boxbox
        backed off the grass at 3000 m into bt:2 and berniw:3 coming by, 242 damage)."""
        cars = nearby(s, self.car.length_m, self.track.length_m, self.params.back_range_m, 0.0, self._heading_at)
        return any(c.dist_m < 0.0 and c.speed_mps > REVERSE_MAX_MPS
                   and -c.dist_m < (c.speed_mps + REVERSE_MAX_MPS) * REVERSE_CLEAR_S for c in cars)

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

    def _traffic(self, s: State, v: float) -> list[Nearby]:
        """The cars near enough to matter, and the line's offset from racecraft (robot/racecraft.py:
        passing, room side by side, letting a lapping car by); back to the line, a step at a time,
        when nobody is near."""
        p = self.params
        cars = nearby(s, self.car.length_m, self.track.length_m, p.back_range_m, p.front_range_m, self._heading_at) \
            if s.opponents and not math.isnan(s.dist_from_start_m) else []
        self.wreck = None
        if cars:
            if self.craft.p.learn_lines or self.craft.p.conflict_s:
                self.opp_lines.observe(s.dist_from_start_m, cars)
            cars = self.craft.predict(s.sim_time_s, cars)
            self._back_from_wreck(s, v, cars)
            self.wreck = self._wreck_ahead(s, cars)
            dist = s.dist_from_start_m
            self._now_s, self._dist_m, self._my_mid_m = s.sim_time_s, dist, s.to_middle_m
            j = int(dist / self.step_m) % self.n
            k = self.line.curvature_at(dist + self.craft.p.horizon_s * v) if not self.craft.p.next_turn_s \
                else next((c for c in (self.line.curvature_at(dist + x) for x in
                                       range(0, int(max(0.0, v) * self.craft.p.next_turn_s) + 1, 10))
                           if abs(c) >= TURN_CURVATURE_1PM), 0.0)  # the turn we are heading for
            inside = 0.0 if abs(k) < TURN_CURVATURE_1PM else math.copysign(1.0, k)
            straight = next((x for x in range(0, 400, 10) if self.profile.speed_at(dist + x) < 0.95 * v), 400)
            passing = [c for c in self._on_our_path(cars, v)
                       if c.laps_ahead > 0 or in_lane(c, self.car.width_m, self.opp)] \
                if self.craft.p.path_pass else cars
            base: float | None
            if self.planning is not None:  # the planned path (robot/planning.py) for the tutorial's offset
                base, self._speed_share = self.planning.step(s.sim_time_s, dist, v, s.to_middle_m, self.offset_m,
                                                             cars, self.profile.target_speeds)
            else:
                base = None if self.craft.p.plan_passes else \
                    overtake_offset(self.offset_m, v, s.to_middle_m, passing, 0.5 * self.track.width_m - 1.5,
                                    self.car.length_m, self.opp, self._held_up(s, cars, j, straight))
            turn = max(abs(self.line.curvature_at(dist + x))
                       for x in range(0, int(max(0.0, v) * self.craft.p.turn_ahead_s) + 1, 10))
            self.offset_m = self.craft.offset(s.sim_time_s, v, s.to_middle_m, cars, self.offset_m,
                                              self.line.offset_at(dist), (self._half_left[j], -self._half_right[j]),
                                              inside, straight, p.overtake_step_m, base, turn,
                                              self.line.curvature_at(dist))
        else:
            self._following = -1  # nobody near: a car met again is followed afresh (_held_up)
            if self.planning is not None:
                self.planning.reset()
                self._speed_share = 1.0
        if not cars and self.offset_m:
            self.offset_m = max(0.0, self.offset_m - p.overtake_step_m) if self.offset_m > 0 \
                else min(0.0, self.offset_m + p.overtake_step_m)
        return cars

    def _held_up(self, s: State, cars: list[Nearby], j: int, straight_m: float) -> float:
        """Our lap simulation's speed here once we have followed the same car close ahead in our lane
        for TutorialParams.draft_after_s (a train: passing it at our speed is worth a try) with at
        least draft_straight_m of road before the next braking zone (with draft_last_lap: on the last
        lap only), else 0 (the tutorial's rule)."""
        if not self._alone_mps or (self.params.draft_last_lap and s.laps < s.total_laps):
            return 0.0
        reach_m = FOLLOW_LENGTHS * self.car.length_m
        ahead = [c for c in cars if 0.0 < c.dist_m < reach_m and in_lane(c, self.car.width_m, self.opp)]
        index = min(ahead, key=lambda c: c.dist_m).index if ahead else -1
        if index != self._following:
            self._following, self._following_since_s = index, s.sim_time_s
        if index < 0 or s.sim_time_s - self._following_since_s < self.params.draft_after_s \
                or straight_m < self.params.draft_straight_m:
            return 0.0
        return self._alone_mps[j]

    def _heading_at(self, dist_m: float) -> float:
        """The track's direction at dist_m (rad), from the middle line's samples."""
        return self._headings[int(dist_m / self.step_m) % self.n]

    def _back_from_wreck(self, s: State, v: float, cars: list[Nearby]) -> None:
        """Start backing away from a stopped car in our lane after RacecraftParams.blocked_s stopped
        behind it (robot/racecraft.py blocking): from where we stand there is no steering round it."""
        on_track = PIT_PHASE_CODES.get(self.pits.phase, -1) == 0  # not in the pit lane, where cars stop
        blocker = self.craft.blocking(v, cars) if on_track else None
        self.blocked_steps = self.blocked_steps + 1 if blocker else 0
        wait_s = self.craft.p.blocked_grinding_s if self._grinding(s) else self.craft.p.blocked_s
        if blocker and self.blocked_steps * DRIVE_STEP_S > wait_s:
            self.reversing, self.reverse_steps, self.blocked_steps = True, 0, 0
            self._backing_from_m = s.dist_from_start_m
            self._wrecks_until_s = s.sim_time_s + self.craft.p.wreck_s

    def _wreck_ahead(self, s: State, cars: list[Nearby]) -> Nearby | None:
        """Within RacecraftParams.wreck_s of backing from a wreck: the nearest stopped car ahead
        (or alongside) in our way, driven round at walking pace and not braked for (a pile-up
        seldom has one car in it)."""
        if s.sim_time_s > self._wrecks_until_s:
            return None
        return self.craft.stopped_ahead(cars)

    def _steer_by_wreck(self, s: State, c: Nearby) -> float | None:
        """Steer at the point beside the wreck c (a car length ahead of us once alongside), on the
        side with room (robot/racecraft.py wreck_target); None when neither side has room."""
        at = s.dist_from_start_m + max(c.dist_m, self.car.length_m)
        j = int(at / self.step_m) % self.n
        target = self.craft.wreck_target(c, self._half_left[j], -self._half_right[j])
        if target is None:
            return None
        tx, ty = self.line.point_at(at)
        off = target - self.line.offset_at(at)
        nx, ny = self._normals[j]
        return steer_to_point(s.x_m, s.y_m, s.yaw_rad, tx + off * nx, ty + off * ny, self.car.steer_lock_rad)

    def _other_target(self, c: Nearby) -> float:
        """The speed a car ahead is predicted to slow to within the horizon: our profile's lowest
        speed over the road it covers, scaled by how much slower than the profile it drives now
        (no less than 0.8: a car far below the profile is starting or in trouble, and held at its speed)."""
        pos = self._dist_m + c.dist_m
        here = max(1.0, self.profile.speed_at(pos))
        reach = c.speed_mps * self.craft.p.horizon_s
        lowest = min(self.profile.speed_at(pos + x) for x in range(0, int(reach) + 1, 10))
        return min(c.speed_mps, max(0.8, min(1.0, c.speed_mps / here)) * lowest)

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

    def _moved_line(self, j: int, line_off: float) -> float:
        """The line at sample j moved by the overtaking offset: never nearer the edge of the room than
        RacecraftParams.edge_m unless the line itself is (aalborg's right-hander at 1350 m: an inside
        offset held to the room's very edge, the car cut past it into the inside wall, 29k damage in 9 races)."""
        edge = self.craft.p.edge_m
        lo = min(line_off, edge - self._half_right[j])
        hi = max(line_off, self._half_left[j] - edge)
        off = max(min(0.0, edge - self._offset_room_r[j]), min(max(0.0, self._offset_room_l[j] - edge), self.offset_m))
        return max(lo, min(hi, line_off + off))

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

    def _avoid_side(self, steer: float, cars: list[Nearby]) -> float:
        if not cars:
            return steer
        return side_steer(steer, cars, self.car.length_m, self.car.width_m, self.car.steer_lock_rad, self.opp,
                          self.craft.p.side_push_rad_per_m)

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
        if self._speed_share < 1.0:  # the traffic planner waits behind (robot/planning.py)
            target *= self._speed_share
        self.target_mps = target  # for telemetry
        if v > target:
            return min(1.0, (v - target) / p.brake_band_mps), 0.0
        margin = target - v
        return 0.0, (1.0 if margin >= p.full_accel_margin_mps else 0.4 + 0.6 * margin / p.full_accel_margin_mps)

    def _avoid_collision(self, brake: float, v: float, cars: list[Nearby]) -> float:
        """Brake for a car ahead: time-to-collision braking from the prediction (robot/racecraft.py),
        and/or the tutorial's fixed-gap filter (RacecraftParams.brake_mode)."""
        if not cars:
            return brake
        mode = self.craft.p.brake_mode
        if self.wreck is not None:  # driven round at walking pace
            cars = [c for c in cars if c.index != self.wreck.index]
        if self.craft.p.path_lane or self.params.lapped_path_lane:
            cars = self._on_our_path(cars, v, lapped_only=not self.craft.p.path_lane)
        brake = self.craft.brake(self._now_s, brake, v, cars, self._other_target, predict=mode != "gap")
        if mode != "ttc":
            brake = collision_brake(brake, v, cars, self.car.width_m, self.opp, self._brakedist)
        brake = hazard_brake(brake, v, self._my_mid_m, cars, self.car.width_m, self.opp, self._brakedist)
        if self.craft.p.conflict_s > 0.0:
            brake = self._conflict_brake(brake, v, cars)
        return brake

    def _conflict_brake(self, brake: float, v: float, cars: list[Nearby]) -> float:
        """Full brake for a car up to three lengths ahead, beside our lane now, whose line crosses
        ours while we overlap (robot/racecraft.py conflict_time_s): it turns in and does not see us."""
        length, width = self.car.length_m, self.car.width_m
        for c in cars:
            if 0.0 < c.dist_m < 3.0 * length and not in_lane(c, width, self.opp) and c.laps_ahead <= 0:
                clear = 0.5 * (width + (c.width_m or width)) + 0.5
                if conflict_time_s(c, v, length, clear, self.craft.p.conflict_s, self._line_mid_ahead,
                                   self._their_mid_ahead) < math.inf:
                    self.craft.mark_spoiled(self._now_s)
                    return 1.0
        return brake

    def _on_our_path(self, cars: list[Nearby], v: float, lapped_only: bool = False) -> list[Nearby]:
        """The cars ahead (or only those we are lapping) judged where we reach them (robot/racecraft.py
        on_our_path)."""
        their = self._their_mid_ahead if self.craft.p.learn_lines else None
        return on_our_path(cars, v, self.craft.p.path_lane_s, self._line_mid_ahead, their, lapped_only)

    def _their_mid_ahead(self, c: Nearby, ahead_m: float) -> tuple[float, bool]:
        """Car c's to_middle ahead_m further along, from where it was seen there before."""
        mid = self.opp_lines.mid_at(c.index, self._dist_m + c.dist_m + ahead_m, math.nan)
        return (c.mid_m, False) if mid != mid else (mid, True)

    def _line_mid_ahead(self, ahead_m: float) -> float:
        """Our line's to_middle ahead_m ahead of the car, with the offset of now (inside the usable width)."""
        at = self._dist_m + ahead_m
        j = int(at / self.step_m) % self.n
        return self._moved_line(j, self.line.offset_at(at)) if self.offset_m else self.line.offset_at(at)

    def _traction(self, s: State, v: float, brake: float, accel: float, traffic: bool) -> tuple[float, float]:
        """ABS on the brake (its bang held off far over the target: abs_hold), or traction control on
        the throttle (never both)."""
        spins = (s.spin_fr_rps, s.spin_fl_rps, s.spin_rr_rps, s.spin_rl_rps)
        last = self._abs_brake if s.sim_time_s - self._abs_at_s < 1.5 * DRIVE_STEP_S else 0.0
        self._abs_at_s, self._abs_brake = s.sim_time_s, 0.0
        if brake > 0.0:
            filtered = abs_filter(brake, v, spins, self.radii, self.slip)
            # over the profile's own speed, not a target traffic lowered at once (the traffic planner's
            # share: g-track-1 from the back, held 19 m/s over a car ahead, 118 damage against 37)
            self._abs_brake = abs_hold(brake, filtered, last, v - self._profile_mps, self.slip)
            return self._abs_brake, 0.0
        if accel == 0.0 or v < self.slip.tcl_min_speed_mps:
            return 0.0, accel
        slip_mps = driven_wheel_speed_mps(spins, self.radii, self.car.drivetrain) - v
        if slip_mps <= self.slip.tcl_slip_mps:  # within the least slip allowed: no turn share needed
            return 0.0, accel
        if traffic:
            # off the line among cars the turn's share is not the line's: the tutorial's 2 m/s (with
            # the slip ratio, 30 field races lost 35 places and took 85k damage, not 46k: racecraft.md)
            return 0.0, tcl_from_slip(accel, v, slip_mps, self.slip, 0.0)
        v2 = v * v
        share = v2 * self._k_per_mu[int(s.dist_from_start_m / self.step_m) % self.n] / (G_MPS2 + v2 * self._ca_per_kg)
        room = spare_slip_ratio(self._peak_slip, share)
        if self.car.drivetrain == RWD:
            # the rear axle's own lateral slip, measured: the body's side speed plus the yaw's at the
            # axle (car1-ow1 out of e-track-2's 37 m/s right-hander at 13 deg body slip spun with 27 %
            # wheelspin, which the turn's share alone allowed)
            room = min(room, combined_slip_room(self._peak_slip, self._rear_side_slip(s, v)))
        return 0.0, tcl_from_slip(accel, v, slip_mps, self.slip, room)

    def _drive_room(self, s: State, v: float, accel: float) -> float:
        """Where the level's tyre loses force past its peak (pro): no more throttle than the drive force
        the axles can hold beside the turn (control/traction.py: drive_force_room_n, with the load the
        force moves rearwards off the steering front), through the engine's torque at part throttle,
        which the engine brake lowers (g-track-1's long turn at pro, full throttle at 44 m/s, spun;
        with the rear axle's static load alone and the torque taken as linear in the throttle, dirt-2
        at pro came out of its slow turns on 0.4 throttle at 3 % wheelspin)."""
        gear = int(s.gear)
        if not self._holds_peak or accel == 0.0 or gear < 1 or v < self.slip.tcl_min_speed_mps:
            return accel
        i = int(s.dist_from_start_m / self.step_m) % self.n
        room_n = drive_force_room_n(self._axles, self._corner_mu[i], v, self._curv[i])
        car = self.car
        torque_nm = float(np.interp(s.rpm, car.torque_curve_radps, car.torque_curve_nm))
        full_n = torque_nm * car.gear_ratio(gear) / self._drive_radius_m
        if full_n <= room_n:
            return accel
        brake = engine_brake_share(s.rpm, car.engine_tickover_radps, car.engine_revs_max_radps, car.engine_brake_coeff)
        return min(accel, throttle_for_torque(room_n / full_n, brake))

    def _rear_side_slip(self, s: State, v: float) -> float:
        """The rear axle's lateral slip: the body's side speed plus the yaw's at the axle, over the speed."""
        return (s.speed_y_mps - self._cg_to_rear_m * s.yaw_rate_rps) / v

    def _release_engine_brake(self, s: State, v: float, brake: float, accel: float) -> float:
        """Coasting where the level's tyre loses force past its peak (pro), with the driven rear sliding
        sideways at or past it (combined_slip_room 0: no grip left along the tyre): the throttle at which
        the engine drives nothing, rather than its brake dragging the sliding rear round (mixed-1 at
        pro: off the throttle in a first-gear S-bend at 22 m/s, the rear slid out, 347 damage)."""
        if (not self._holds_peak or accel > 0.0 or brake > 0.0 or self.car.drivetrain != RWD or s.gear < 1
                or v < self.slip.tcl_min_speed_mps
                or combined_slip_room(self._peak_slip, self._rear_side_slip(s, v)) > 0.0):
            return accel
        car = self.car
        return throttle_for_torque(0.0, engine_brake_share(s.rpm, car.engine_tickover_radps,
                                                           car.engine_revs_max_radps, car.engine_brake_coeff))

    def _guard_throttle(self, s: State, v: float, steer: float, accel: float) -> float:
        """Less throttle when the tyres have no grip to spare: at the steering lock (lock guard) and
        while the rear steps out (spin guard)."""
        if accel == 0.0:
            return accel
        p = self.params
        line_k = self.line.curvature_at(s.dist_from_start_m)
        if abs(steer) >= LOCK_SHARE and v > LOCK_MIN_SPEED_MPS:
            # counter-steering at the lock (steer against the line's turn): the rear is out
            accel = min(accel, p.counter_lock_accel if steer * line_k < 0.0 else p.lock_accel)
        # the car turns faster than its line and against the steering: power would spin it
        # (dirt-2's S-bends at 13 m/s in first gear)
        excess = s.yaw_rate_rps - v * line_k
        if excess * steer < 0.0 and abs(excess) > p.spin_yaw_rate_rps:
            accel = 0.0
        return accel

    def _clutch(self, gear: int, v: float, accel: float) -> float:
        """Open while stopping at the box (brakes alone, predictable); slipping at the start."""
        p = self.params
        if self.pits.clutch_open and accel == 0.0:
            return 1.0
        if gear == 1 and v < p.clutch_release_mps:
            return min(p.clutch_start, p.clutch_start * (1.0 - v / p.clutch_release_mps))
        return 0.0

    def _stuck(self, s: State) -> bool:
        """Reverse out after stuck_time_s of being slow, sideways and off the middle; once backing,
        go on until the car points along the track again (at most REVERSE_MAX_S): a car that drives
        forward still sideways hits the same wall again (dirt-3 hit it six times in a row)."""
        p = self.params
        if self.reversing:
            self.reverse_steps += 1
            if self._reverse_done(s) or self.reverse_steps * DRIVE_STEP_S > REVERSE_MAX_S:
                self.reversing = False
                self.stuck_steps = 0
                self._backing_from_m = None
            return self.reversing
        grinding = self._grinding(s)
        sideways = s.speed_x_mps < p.stuck_speed_mps and abs(s.angle_rad) > self._stuck_angle \
            and abs(s.to_middle_m) > p.stuck_offset_m and s.angle_rad * s.to_middle_m < 0
        # turned round and pushing into something anywhere on the track (dirt-5: against a car
        # stopped behind it, boxbox took 10,000 damage at full throttle in the middle); turned
        # round alone, forward round the lock is quicker than backing (e-track-3).  At once: each
        # step costs damage (dirt-5: 1,400 in the 2 s of stuck_time_s against a car stopped there)
        turned_round = not sideways and abs(s.speed_x_mps) < p.stuck_speed_mps \
            and abs(s.angle_rad) > BACKWARDS_RAD and grinding
        self.stuck_steps = self.stuck_steps + 1 if sideways else 0
        if turned_round or self.stuck_steps * DRIVE_STEP_S > p.stuck_time_s:
            self.reversing = True
            self.reverse_steps = 0
        return self.reversing

    def _reverse_done(self, s: State) -> bool:
        """Backed out far enough: pointing along the track again, or away from a wreck; or boxed in
        (dirt-5: turned round between two stopped cars, backing from one into the other), then held
        on the brakes for BOXED_HOLD_S."""
        backing_s = self.reverse_steps * DRIVE_STEP_S
        pushing = self._backing_on_throttle and abs(s.speed_x_mps) < BOXED_MPS  # hit while waiting is not
        if self._grinding(s) and backing_s > GRINDING_S and pushing:
            self._hold_until_s = s.sim_time_s + BOXED_HOLD_S
            return True
        if self._backing_from_m is None:
            return abs(s.angle_rad) < 0.5 * self._stuck_angle
        half = 0.5 * self.track.length_m  # away from a wreck: far enough back to steer round it
        backed_m = (self._backing_from_m - s.dist_from_start_m + half) % self.track.length_m - half
        return backed_m > self.craft.p.blocked_back_lengths * self.car.length_m

    def _grinding(self, s: State) -> bool:
        """Whether the car took damage within the last GRINDING_S (called every step, so damage
        taken long ago is never new)."""
        if s.damage > self._damage_seen:
            self._damage_seen, self._grinding_until_s = s.damage, s.sim_time_s + GRINDING_S
        return s.sim_time_s < self._grinding_until_s

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

    def signals(self) -> dict[str, float]:
        return {"offset_m": self.offset_m}

    def telemetry_fields(self) -> tuple[str, ...]:
        return ("target_speed_mps", "pit_phase", "offset_m", "reversing")

    def telemetry(self, s: State) -> tuple[float, ...]:
        """The target speed drive() used (the speed profile speed_lookahead_s ahead of the car), the
        pit phase code (PIT_PHASE_CODES), the overtaking offset and 1 while reversing out of a stuck
        position.  Values drive() stored: nothing is computed here."""
        return (self.target_mps, PIT_PHASE_CODES.get(self.pits.phase, -1), self.offset_m, self.reversing)
