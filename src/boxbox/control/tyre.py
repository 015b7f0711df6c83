"""The tyre's force against slip, as TORCS's simuv2 computes it, and what the skill level adds.

simuv2 (wheel.cpp) uses Pacejka's magic formula on the combined slip s (capped at 1.5):
    F(s) = sin(C atan(B s (1 - E) + E atan(B s))) x (1 + s x skid factor)
with C = 2 - 2 asin(dynamic friction) / pi, B = stiffness / C, E = elasticity factor, from the
car file (TORCS's defaults 30, 0.8, 0.7), and the skid factor from the skill level (0 at pro,
0.3 at semi-pro; model/skill.py). At pro F peaks at 1 (times the tyre's mu and the load); below
pro a sliding tyre keeps gaining force, so a car can use more grip than mu says.
"""

from __future__ import annotations

import math

import numpy as np

MAX_SLIP = 1.5  # simuv2 caps the slip here


def magic_formula(slip: np.ndarray, stiffness: float, dynamic_friction: float, elasticity: float,
                  skid_factor: float = 0.0) -> np.ndarray:
    """Tyre force as a share of mu x load at combined slip `slip` (dimensionless, >= 0)."""
    if stiffness <= 0.0 or not 0.0 < dynamic_friction <= 1.0 or not 0.0 <= elasticity <= 1.0:
        raise ValueError(f"tyre shape out of range: stiffness {stiffness} > 0, dynamic friction "
                         f"{dynamic_friction} in (0, 1], elasticity {elasticity} in [0, 1]")
    s = np.minimum(np.asarray(slip, dtype=float), MAX_SLIP)
    c = 2.0 - 2.0 * math.asin(dynamic_friction) / math.pi
    bx = stiffness / c * s
    return np.sin(c * np.arctan(bx * (1.0 - elasticity) + elasticity * np.arctan(bx))) * (1.0 + s * skid_factor)


def skid_grip_gain(stiffness: float, dynamic_friction: float, elasticity: float, skid_factor: float,
                   usable_slip: float | None = None) -> float:
    """Most force with the slip held at or below `usable_slip`, over the pro tyre's peak force.

    `usable_slip` None: the slip of the pro tyre's peak, where a car still steers as it does at
    pro; the gain is then exactly 1 at pro. car1-trb1's tyres at semi-pro give about 1.08 there
    (slip 0.26) and 1.30 at slip 1.5 (sliding).
    """
    if usable_slip is not None and not 0.0 < usable_slip <= MAX_SLIP:
        raise ValueError(f"usable slip {usable_slip} must be in (0, {MAX_SLIP}]")
    if not math.isfinite(skid_factor) or skid_factor < 0.0:
        raise ValueError(f"skid factor {skid_factor} must be finite and >= 0")
    slip = np.linspace(0.0, MAX_SLIP, 3001)
    pro = magic_formula(slip, stiffness, dynamic_friction, elasticity)
    pro_peak = float(pro.max())
    usable = slip[slip <= (slip[pro.argmax()] if usable_slip is None else usable_slip)]
    return float(magic_formula(usable, stiffness, dynamic_friction, elasticity, skid_factor).max()) / pro_peak


def peak_slip(stiffness: float, dynamic_friction: float, elasticity: float) -> float:
    """The combined slip (dimensionless) at which the pro tyre's force peaks: beyond it a tyre slides."""
    slip = np.linspace(0.0, MAX_SLIP, 3001)
    return float(slip[int(np.argmax(magic_formula(slip, stiffness, dynamic_friction, elasticity)))])


def falls_past_peak(stiffness: float, dynamic_friction: float, elasticity: float, skid_factor: float) -> bool:
    """Whether the level's tyre gives less force somewhere past the pro tyre's peak slip than at it:
    at pro (no skid factor) a sliding tyre loses grip, so the robot must hold the slip at the peak;
    at semi-pro and below the force keeps growing with the slip (car1-trb1: 1.08 at the peak, 1.30
    at slip 1.5), and a slide past the peak is caught by the tyre itself."""
    slip = np.linspace(peak_slip(stiffness, dynamic_friction, elasticity), MAX_SLIP, 1001)
    force = magic_formula(slip, stiffness, dynamic_friction, elasticity, skid_factor)
    return bool(np.any(force < force[0] - 1e-9))
