"""The tutorial robot's plan of a track (made in on_track, rebuilt each lap): the racing line and
the width it may use, the speed profile under the learned turn factors, the fuel load and the
brakes' ceiling, speed caps off the packers, the rear wing, the start fuel and the pit part."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from boxbox.cache import cached_array
from boxbox.control import carmodel, fuel, lapsim, speed, suspension, tyre
from boxbox.control.braking import brake_distance, brake_limited_speed
from boxbox.control.carmodel import CarModel
from boxbox.control.speed import SpeedProfile, allowed_speed, bump_speed, crest_speed
from boxbox.control.trackwidth import CUT_LIMIT_CAR_WIDTHS
from boxbox.model import Car, CarSetup, Track
from boxbox.model.constants import G_MPS2
from boxbox.robot import bottoming, carsetup
from boxbox.robot.base import FUEL_L_PER_M_ESTIMATE, Robot
from boxbox.robot.bottoming import packer_speed_caps
from boxbox.robot.carsetup import best_rear_wing_rad
from boxbox.robot.drivable import centre_room
from boxbox.robot.learning import TurnLearner
from boxbox.robot.params import TutorialParams, load_params
from boxbox.robot.pit import PitParams, PitStops
from boxbox.robot.racingline import RacingLine, middle_line, washboard
from boxbox.robot.start_fuel import MODEL_MARGIN, start_fuel_l
from boxbox.robot.strategy import OUT_DAMAGE

DAMAGE_DRAG_POINTS = 5000.0  # the damage the drag's cost per point is measured at


class TrackPlan(Robot):
    """The per-track plan: line, limits, profile, car setup, start fuel, pit part."""

    # set by the robot's on_track (robot.py) and read here
    params: TutorialParams
    learner: TurnLearner
    tyre_model: CarModel
    fuel_l: float
    _brake_caps: np.ndarray | None

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
        brake_w = fuel.padded_engine_brake_power_w(car.torque_curve_radps, car.torque_curve_nm,
                                                   car.engine_tickover_radps,
                                                   car.engine_revs_max_radps, car.engine_brake_coeff)
        return fuel.lap_fuel_l(step_m, speeds, point_mass.mass_kg, point_mass.cw_n_per_mps2, car.fuel_cons_factor,
                               brake_w)

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
        params = PitParams(lookahead_m=p.pit_lookahead_m, brake_mu_scale=p.pit_brake_mu_scale,
                           give_up_s=p.pit_give_up_s, stop_threshold_m=p.pit_stop_threshold_m,
                           stop_grip_share=p.pit_stop_grip_share, brake_method=p.brake_method)
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
