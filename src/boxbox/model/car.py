"""The car's constants, from its parameter file and from TORCS's car structure."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NoReturn

from boxbox.model.names import no_such_field

RWD, FWD, AWD = 0, 1, 2
DRIVETRAIN_NAMES = {RWD: "RWD", FWD: "FWD", AWD: "4WD"}
STEERING_WHEELBASE_SHARE = 0.6  # the steering's wheelbase as a share of the car's length (TORCS's cars: about 0.6)


@dataclass
class Car:
    name: str = ""
    # from the car's parameter file (known when the track is loaded)
    mass_kg: float = 1000.0  # without fuel
    tank_l: float = 100.0
    initial_fuel_l: float = 100.0
    front_wing_area_m2: float = 0.0
    front_wing_angle_rad: float = 0.0
    rear_wing_area_m2: float = 0.0
    rear_wing_angle_rad: float = 0.0
    front_clift: float = 0.0
    rear_clift: float = 0.0
    cx: float = 0.0
    front_area_m2: float = 0.0
    ride_height_fr_m: float = 0.2
    ride_height_fl_m: float = 0.2
    ride_height_rr_m: float = 0.2
    ride_height_rl_m: float = 0.2
    mu_fr: float = 1.0
    mu_fl: float = 1.0
    mu_rr: float = 1.0
    mu_rl: float = 1.0
    drivetrain: int = RWD
    fuel_cons_factor: float = 1.0
    # the engine's tickover and revs maxi (rad/s) and its brake coefficient (simuv2 engine.cpp's
    # defaults): with the throttle closed it brakes with brake_coeff x (w - tickover) / (revs max -
    # tickover) of its full torque, and burns fuel for it
    engine_tickover_radps: float = 150.0
    engine_revs_max_radps: float = 1000.0
    engine_brake_coeff: float = 0.33
    brake_pressure_max: float = 0.0  # brake system's highest pressure, Pa (TORCS converts the file's kPa)
    brake_front_rear: float = 0.5
    # each wheel's brake (simuv2 brake.cpp, its defaults): torque = disk diameter / 2 x piston area x
    # pad mu x the wheel's pressure (the pressure's front_rear share on the front wheels)
    brake_disk_diameter_fr_m: float = 0.2
    brake_disk_diameter_fl_m: float = 0.2
    brake_disk_diameter_rr_m: float = 0.2
    brake_disk_diameter_rl_m: float = 0.2
    brake_piston_area_fr_m2: float = 0.002
    brake_piston_area_fl_m2: float = 0.002
    brake_piston_area_rr_m2: float = 0.002
    brake_piston_area_rl_m2: float = 0.002
    brake_mu_fr: float = 0.3
    brake_mu_fl: float = 0.3
    brake_mu_rr: float = 0.3
    brake_mu_rl: float = 0.3
    front_weight_share: float = 0.5  # share of the car's weight on the front axle
    # tyres (the car file's "stiffness", "dynamic friction", "elasticity factor" per wheel; TORCS's
    # defaults where it is silent): the shape of the magic formula, see control/tyre.py
    tyre_stiffness_fr: float = 30.0
    tyre_stiffness_fl: float = 30.0
    tyre_stiffness_rr: float = 30.0
    tyre_stiffness_rl: float = 30.0
    tyre_dynamic_friction_fr: float = 0.8
    tyre_dynamic_friction_fl: float = 0.8
    tyre_dynamic_friction_rr: float = 0.8
    tyre_dynamic_friction_rl: float = 0.8
    tyre_elasticity_fr: float = 0.7
    tyre_elasticity_fl: float = 0.7
    tyre_elasticity_rr: float = 0.7
    tyre_elasticity_rl: float = 0.7
    # the tyres' load sensitivity (simuv2 wheel.cpp; its defaults): grip = mu x load x (min + (max -
    # min) exp(ln((1 - min) / (max - min)) load / operating load)); operating load 0 = 1.2 x static
    tyre_load_factor_max_fr: float = 1.6
    tyre_load_factor_max_fl: float = 1.6
    tyre_load_factor_max_rr: float = 1.6
    tyre_load_factor_max_rl: float = 1.6
    tyre_load_factor_min_fr: float = 0.8
    tyre_load_factor_min_fl: float = 0.8
    tyre_load_factor_min_rr: float = 0.8
    tyre_load_factor_min_rl: float = 0.8
    tyre_operating_load_fr_n: float = 0.0
    tyre_operating_load_fl_n: float = 0.0
    tyre_operating_load_rr_n: float = 0.0
    tyre_operating_load_rl_n: float = 0.0
    # the suspension (simuv2 suspension.cpp; its defaults): the CG's height, the axles' x (m, + forward
    # of the CG), per wheel its y (m, + left), spring (N/m), bellcrank, packers (m), the dampers'
    # slow and fast rates (N s/m) and the damper speed (m/s) where the fast rate takes over
    gc_height_m: float = 0.5
    front_axle_x_m: float = 1.3
    rear_axle_x_m: float = -1.3
    wheel_y_fr_m: float = -0.8
    spring_fr_npm: float = 175000.0
    bellcrank_fr: float = 1.0
    packers_fr_m: float = 0.0
    slow_bump_fr_nspm: float = 0.0
    slow_rebound_fr_nspm: float = 0.0
    fast_bump_fr_nspm: float = 0.0
    fast_rebound_fr_nspm: float = 0.0
    bump_threshold_fr_mps: float = 0.5
    rebound_threshold_fr_mps: float = 0.5
    wheel_y_fl_m: float = 0.8
    spring_fl_npm: float = 175000.0
    bellcrank_fl: float = 1.0
    packers_fl_m: float = 0.0
    slow_bump_fl_nspm: float = 0.0
    slow_rebound_fl_nspm: float = 0.0
    fast_bump_fl_nspm: float = 0.0
    fast_rebound_fl_nspm: float = 0.0
    bump_threshold_fl_mps: float = 0.5
    rebound_threshold_fl_mps: float = 0.5
    wheel_y_rr_m: float = -0.8
    spring_rr_npm: float = 175000.0
    bellcrank_rr: float = 1.0
    packers_rr_m: float = 0.0
    slow_bump_rr_nspm: float = 0.0
    slow_rebound_rr_nspm: float = 0.0
    fast_bump_rr_nspm: float = 0.0
    fast_rebound_rr_nspm: float = 0.0
    bump_threshold_rr_mps: float = 0.5
    rebound_threshold_rr_mps: float = 0.5
    wheel_y_rl_m: float = 0.8
    spring_rl_npm: float = 175000.0
    bellcrank_rl: float = 1.0
    packers_rl_m: float = 0.0
    slow_bump_rl_nspm: float = 0.0
    slow_rebound_rl_nspm: float = 0.0
    fast_bump_rl_nspm: float = 0.0
    fast_rebound_rl_nspm: float = 0.0
    bump_threshold_rl_mps: float = 0.5
    rebound_threshold_rl_mps: float = 0.5
    # the engine's torque curve from the car file: engine speed (rad/s) and torque (N m) per point
    torque_curve_radps: tuple[float, ...] = field(default_factory=tuple)
    torque_curve_nm: tuple[float, ...] = field(default_factory=tuple)
    # from the car structure (known when the race starts)
    car_index: int = 0
    # TORCS's _gearNb: simuv2 sets it to the top forward gear + 1 (transmission.cpp, TransmInit), not
    # to the count of gears with reverse and neutral that car.h's comment suggests
    gear_count: int = 0
    gear_offset: int = 1  # gear_ratios[gear + gear_offset] is the ratio of `gear`
    gear_ratios: tuple[float, ...] = field(default_factory=tuple)  # all MAX_GEARS slots, with the final drive
    rpm_redline: float = 0.0  # rad/s
    rpm_max: float = 0.0
    rpm_max_torque: float = 0.0
    rpm_max_power: float = 0.0
    max_torque_nm: float = 0.0
    max_power_w: float = 0.0
    wheel_radius_fr_m: float = 0.3
    wheel_radius_fl_m: float = 0.3
    wheel_radius_rr_m: float = 0.3
    wheel_radius_rl_m: float = 0.3
    steer_lock_rad: float = 0.5
    length_m: float = 4.5
    width_m: float = 1.9
    height_m: float = 1.2
    start_rank: int = 0
    race_laps: int = 0
    # TORCS's skill level of this car: 0 rookie, 1 amateur, 2 semi-pro, 3 pro. It sets the tyres'
    # skid factor and the damage factor (simuv2). Pro until the race says otherwise: its tyres have
    # no skid bonus, the cautious assumption.
    skill_level: int = 3
    # this car's own pit box (None without pits)
    pit_seg: int = -1
    pit_to_start: float = 0.0
    pit_to_middle_m: float = 0.0
    pit_lmin_m: float = 0.0
    pit_lmax_m: float = 0.0

    @property
    def wheelbase_m(self) -> float:
        """The distance between the axles (m), from the car's file (car1-trb1: 2.64 m)."""
        return self.front_axle_x_m - self.rear_axle_x_m

    @property
    def steering_wheelbase_m(self) -> float:
        """The wheelbase the tutorial robot's and the gym's pit steering feed forward with, and the
        lever of the robot's front weight: STEERING_WHEELBASE_SHARE x the car's length (car1-trb1:
        2.71 m against its axles' 2.64).  Every solo figure of the robot is measured with it: the
        axles' wheelbase would change its steering, unmeasured."""
        return STEERING_WHEELBASE_SHARE * self.length_m

    @property
    def max_gear(self) -> int:
        """The top forward gear: the highest gear with a non-zero ratio (TORCS's gearbox.gearMax,
        which it also reports as _gearNb - 1). 6 before the race has started."""
        forward = self.gear_ratios[self.gear_offset + 1:]
        top = max((g for g, ratio in enumerate(forward, start=1) if ratio > 0.0), default=0)
        if top:
            return top
        return max(1, self.gear_count - 1) if self.gear_count else 6

    def gear_ratio(self, gear: int) -> float:
        return self.gear_ratios[gear + self.gear_offset]

    def __getattr__(self, name: str) -> NoReturn:
        no_such_field(self, name)
