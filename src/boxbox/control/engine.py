"""The engine as simuv2 runs it (engine.cpp): its torque curve up to the rev limit, and the brake it
gives with the throttle closed.  One copy of these rules for the brakes' model (control/carmodel.py),
the fuel a lap takes (control/fuel.py) and the ideal gearbox of the lap simulation
(robot/carsetup.py)."""

from __future__ import annotations

from boxbox.model.car import Car

# the bridge sends the rev limit and the curve's points as floats: a point within this share of the
# limit is on it (car1-trb1's last point, 1047.2 rad/s, is its revs maxi)
LIMIT_ROUNDING = 1e-6


def torque_curve_to_limit(car: Car) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The torque curve's points (rad/s, N m) up to the engine's revs maxi, where simuv2 cuts the
    engine: TORCS pads some cars' curves past it with points the engine never reaches (the
    155-DTM's reads 750 N m from 1152 to 1466 rad/s, past its 1047; the buggy's and the baja-bug's
    1187 N m at 942 rad/s, past their 733 and 628), which would count several times the power the
    engine has."""
    top = car.engine_revs_max_radps * (1.0 + LIMIT_ROUNDING)
    points = [(w, t) for w, t in zip(car.torque_curve_radps, car.torque_curve_nm, strict=False) if w <= top]
    return tuple(w for w, _ in points), tuple(t for _, t in points)


def engine_brake_share(rpm_radps: float, tickover_radps: float, revs_max_radps: float, brake_coeff: float) -> float:
    """The engine brake as a share of the full torque at engine speed `rpm_radps`: simuv2 gives the
    torque full x (throttle x (1 + share) - share), so no throttle brakes and part throttle gives less
    than its share of the full torque."""
    if revs_max_radps <= tickover_radps:
        return 0.0
    return brake_coeff * max(0.0, rpm_radps - tickover_radps) / (revs_max_radps - tickover_radps)


def engine_brake_power_w(car: Car) -> float:
    """The power (W) the engine brakes with at zero throttle at its speed of most power, where a
    racing car's gear changes keep it: engine_brake_share of the full torque there, from the curve
    up to the rev limit only (torque_curve_to_limit); 0 without a curve.  What it adds to the
    brakes: P / v, 1.5 m/s^2 for the 155-DTM (114 kW) at 68 m/s (measured at full brake on
    street-1: 1.3 beyond the brakes and drag); and the engine burns fuel for it (control/fuel.py)."""
    tick, top = car.engine_tickover_radps, car.engine_revs_max_radps
    rpm, torque = torque_curve_to_limit(car)
    if len(rpm) < 2 or not 0.0 <= tick < top:
        return 0.0
    w, torque_nm = max(zip(rpm, torque, strict=True), key=lambda p: p[0] * p[1])
    return max(0.0, engine_brake_share(w, tick, top, car.engine_brake_coeff) * torque_nm * w)
