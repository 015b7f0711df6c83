"""The few car constants the speed and braking controllers need: mass, downforce, drag, tyre grip.

The aerodynamic coefficients follow the TORCS robot tutorial's estimates (its chapters on
downforce and drag; TORCS's simuv2 aero.cpp for the factors): forces are CA * v^2 (downforce, N) and
CW * v^2 (drag, N) with v in m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from boxbox.control.engine import engine_brake_power_w
from boxbox.control.tyre import skid_grip_gain
from boxbox.model.car import Car
from boxbox.model.constants import AIR_DENSITY_KGPM3 as AIR_DENSITY
from boxbox.model.skill import SkillLevel

WING_FACTOR = 4.0  # the tutorial's empirical factor on the wing term
DRAG_FACTOR = 0.645  # the tutorial's empirical factor (about rho / 2) on Cx * front area
FUEL_KG_PER_L = 1.0  # TORCS counts the fuel load with 1 kg per litre (mass = car mass + fuel)


def ground_effect_factor(car: Car) -> float:
    """h = 2 exp(-3 (1.5 * sum of the four ride heights)^4): body lift helps less when the car rides high."""
    heights_m = car.ride_height_fr_m + car.ride_height_fl_m + car.ride_height_rr_m + car.ride_height_rl_m
    return 2.0 * math.exp(-3.0 * (1.5 * heights_m) ** 4)


def axle_downforce_coefficients(car: Car) -> tuple[float, float]:
    """(front, rear) downforce in N/(m/s)^2: simuv2 puts each Clift on its own axle and each
    wing's force at the wing (aero.cpp, wing.cpp)."""
    h, wing = ground_effect_factor(car), WING_FACTOR * AIR_DENSITY
    front = h * car.front_clift + wing * car.front_wing_area_m2 * math.sin(car.front_wing_angle_rad)
    rear = h * car.rear_clift + wing * car.rear_wing_area_m2 * math.sin(car.rear_wing_angle_rad)
    return front, rear


def cornering_downforce_coefficient(car: Car) -> float:
    """The downforce (N/(m/s)^2) that counts for cornering: each axle must hold the side force of
    the weight it carries, so the axle with the least downforce per share of weight sets the limit,
    min(CA_front / w_front, CA_rear / w_rear).  A car whose downforce is split like its weight
    corners on all of it; car1-trb1 (52 % of its weight in front, 37 % of its downforce) on
    about 72 % of it, which matters in fast turns."""
    front, rear = axle_downforce_coefficients(car)
    share = min(max(car.front_weight_share, 0.05), 0.95)
    return min(front / share, rear / (1.0 - share))


def downforce_coefficient(car: Car, include_front_wing: bool = True) -> float:
    """CA in N/(m/s)^2: h * (front + rear Clift) + 4 * 1.23 * wing area * sin(wing angle).

    The tutorial counts only the rear wing; a front wing (area > 0) is added the same way unless
    `include_front_wing` is False.
    """
    wing_m2 = car.rear_wing_area_m2 * math.sin(car.rear_wing_angle_rad)
    if include_front_wing and car.front_wing_area_m2 > 0.0:
        wing_m2 += car.front_wing_area_m2 * math.sin(car.front_wing_angle_rad)
    body = ground_effect_factor(car) * (car.front_clift + car.rear_clift)
    return body + WING_FACTOR * AIR_DENSITY * wing_m2


def drag_coefficient(car: Car) -> float:
    """CW in N/(m/s)^2: 0.645 * Cx * front area."""
    return DRAG_FACTOR * car.cx * car.front_area_m2


def wing_drag_coefficient(car: Car) -> float:
    """The wings' drag in N/(m/s)^2: 1.23 x area x sin(angle) per wing, as simuv2 applies it
    (aero.cpp); the tutorial's CW leaves it out."""
    return AIR_DENSITY * (car.front_wing_area_m2 * math.sin(car.front_wing_angle_rad)
                          + car.rear_wing_area_m2 * math.sin(car.rear_wing_angle_rad))


def brake_force_n(car: Car) -> float:
    """The most braking force (N) the brakes give at full pressure, all four wheels (simuv2
    brake.cpp: a wheel's torque is disk diameter / 2 x piston area x pad mu x its pressure, the
    pressure's front_rear share on each front wheel, the rest on each rear wheel), at the wheels'
    radii; inf where the car file gives no pressure.  Whether the tyres could take more is the
    braking model's question (control/braking.py): with a full tank the buggy's brakes stop it at
    3.4 m/s^2, the 155-DTM's at 19, car1-trb1's at 40 (its tyres limit first)."""
    if car.brake_pressure_max <= 0.0:
        return math.inf
    total = 0.0
    for w in ("fr", "fl", "rr", "rl"):
        share = car.brake_front_rear if w[0] == "f" else 1.0 - car.brake_front_rear
        torque = (0.5 * getattr(car, f"brake_disk_diameter_{w}_m") * getattr(car, f"brake_piston_area_{w}_m2")
                  * getattr(car, f"brake_mu_{w}") * car.brake_pressure_max * share)
        total += torque / max(getattr(car, f"wheel_radius_{w}_m"), 0.01)
    return total if total > 0.0 else math.inf


def tyre_mu(car: Car) -> float:
    """The weakest tyre limits the car, so use the smallest of the four, each with what the car's
    skill level adds at the slip of its peak (control/tyre.py; nothing at pro)."""
    skid = SkillLevel(car.skill_level).skid_factor
    wheels = (("fr", car.mu_fr), ("fl", car.mu_fl), ("rr", car.mu_rr), ("rl", car.mu_rl))
    return min(mu * (skid_grip_gain(getattr(car, f"tyre_stiffness_{w}"), getattr(car, f"tyre_dynamic_friction_{w}"),
                                    getattr(car, f"tyre_elasticity_{w}"), skid) if skid else 1.0)
               for w, mu in wheels)


@dataclass(frozen=True)
class CarModel:
    """Point-mass car: mass (with fuel), downforce CA, drag CW (both N per (m/s)^2), tyre friction mu.

    `empty_mass_kg` is the mass without fuel (defaults to `mass_kg`), so `with_fuel` can re-derive
    the mass as the fuel burns.  `ca_corner`: the downforce that counts in a turn, the weaker
    axle's (cornering_downforce_coefficient; defaults to `ca`).  `brake_force_n`: the most the
    brakes give (brake_force_n(car); inf: the tyres always limit); `engine_brake_w`: the engine's
    braking power at zero throttle (engine_brake_power_w(car)), which adds P / v where the brakes limit.
    """

    mass_kg: float
    ca: float
    cw: float
    mu: float
    empty_mass_kg: float = field(default=-1.0, compare=False)
    ca_corner: float = -1.0
    brake_force_n: float = math.inf
    engine_brake_w: float = 0.0

    def __post_init__(self) -> None:
        if self.empty_mass_kg < 0.0:
            object.__setattr__(self, "empty_mass_kg", self.mass_kg)
        if self.ca_corner < 0.0:
            object.__setattr__(self, "ca_corner", self.ca)

    @classmethod
    def from_car(cls, car: Car, fuel_l: float = 0.0, include_front_wing: bool = True,
                 brakes: bool = False) -> CarModel:
        """The car's model.  With `brakes`, the brakes' and the engine's braking limit too, and the
        wings' drag in `cw` (simuv2 applies it; the tyres' plan leaves it out, a margin): a model of
        what slows the car at full pressure.  Without, the tyres alone limit its braking
        (brake_force_n inf)."""
        return cls(
            mass_kg=car.mass_kg + fuel_l * FUEL_KG_PER_L,
            ca=downforce_coefficient(car, include_front_wing),
            cw=drag_coefficient(car) + (wing_drag_coefficient(car) if brakes else 0.0),
            mu=tyre_mu(car),
            empty_mass_kg=car.mass_kg,
            ca_corner=cornering_downforce_coefficient(car) if include_front_wing else downforce_coefficient(car, False),
            brake_force_n=brake_force_n(car) if brakes else math.inf,
            engine_brake_w=engine_brake_power_w(car) if brakes else 0.0,
        )

    def with_fuel(self, fuel_l: float) -> CarModel:
        """The same car carrying `fuel_l` litres (1 kg per litre, as TORCS counts it)."""
        return replace(self, mass_kg=self.empty_mass_kg + max(0.0, fuel_l) * FUEL_KG_PER_L)

