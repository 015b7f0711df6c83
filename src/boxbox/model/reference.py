"""The field reference of docs/robots.md, generated from the model's own classes.

Every field of Track, Car, State, Opponent, Controls and PitOrder with its type, its unit (from
the name's suffix, boxbox's naming rule) and what it means (the comment on its line in the
source, or the table below). A test keeps docs/robots.md equal to `markdown()`.
"""

from __future__ import annotations

import dataclasses
import inspect
import io
import tokenize
import typing

from boxbox.model import Car, Controls, Opponent, PitOrder, State, Track

CLASSES = (Track, Car, State, Opponent, Controls, PitOrder)

# unit by name suffix, longest first
UNITS = (("_nspm", "N s/m"), ("_npm", "N/m"),
         ("_mps2", "m/s²"), ("_radps", "rad/s"), ("_rps", "rad/s"), ("_mps", "m/s"), ("_1pm", "1/m"),
         ("_m2", "m²"), ("_kg", "kg"), ("_nm", "N m"), ("_rad", "rad"), ("_l", "l"), ("_m", "m"), ("_s", "s"),
         ("_w", "W"))

# meanings the source has no comment for
MEANINGS = {
    "name": "TORCS's name (track or car)", "category": "road, dirt or oval", "seg": "per-segment arrays, "
    "indexed by segment id (see below)", "pit": "the pit lane (PitLane) or None",
    "mass_kg": "car mass without fuel", "tank_l": "fuel tank size", "initial_fuel_l": "fuel at the start",
    "cx": "drag coefficient", "front_clift": "front body lift coefficient", "rear_clift": "rear body lift coefficient",
    "drivetrain": "0 RWD, 1 FWD, 2 4WD", "fuel_cons_factor": "fuel consumption factor",
    "engine_tickover_radps": "engine's tickover speed", "engine_revs_max_radps": "engine's highest speed (revs maxi)",
    "engine_brake_coeff": "engine brake coefficient (share of full torque at revs maxi, throttle closed)",
    "rpm_redline": "rev limiter (engine speed, rad/s as TORCS keeps it)", "rpm_max": "highest engine speed (rad/s)",
    "rpm_max_torque": "engine speed of the most torque (rad/s)", "rpm_max_power": "engine speed of the most power "
    "(rad/s)", "steer_lock_rad": "the wheels' angle at steer 1", "car_index": "TORCS's index of this car",
    "start_rank": "grid slot, from 0", "race_laps": "laps of the race", "pit_seg": "segment id of this car's box "
    "(-1: none)", "pit_to_start": "the box's place in its segment (m on straights, rad in turns)",
    "pit_to_middle_m": "the box's offset from the middle (+ left)", "pit_lmin_m": "start of the box along the track",
    "pit_lmax_m": "end of the box along the track", "sim_time_s": "simulated time", "x_m": "position (world)",
    "y_m": "position (world)", "z_m": "height (world)", "yaw_rad": "heading (world)", "speed_y_mps": "sideways speed",
    "speed_z_mps": "vertical speed", "yaw_rate_rps": "turning rate", "seg_id": "segment the car is on",
    "to_start": "place in the segment: m on straights, rad in turns (as TORCS has it)",
    "to_right_m": "distance to the right edge (< 0: beyond it)", "to_left_m": "distance to the left edge",
    "dist_from_start_m": "distance along the track from the start line", "dist_raced_m": "distance raced",
    "gear": "gear engaged (-1 reverse, 0 neutral; a whole number sent as a float)",
    "fuel_l": "fuel in the tank", "damage": "damage points (10000: out of the race)",
    "remaining_laps": "laps left after this one", "total_laps": "laps of the race", "position": "place in the race",
    "car_state": "TORCS's state bits (model.state.CAR_STATE_*)", "pit_stops": "stops made",
    "top_speed_mps": "highest speed so far", "n_opponents": "number of other cars",
    "opponents": "an Opponent per other car", "steer": "-1 .. 1, 1 = full lock to the left",
    "accel": "throttle 0 .. 1", "brake": "0 .. 1", "clutch": "0 (closed) .. 1 (open)",
    "pit_request": "ask for a pit stop", "repair": "damage points to repair",
    "speed_mps": "speed", "length_m": "length", "width_m": "width", "accel_x_mps2": "acceleration along the car",
    "accel_y_mps2": "sideways acceleration", "cur_lap_time_s": "time in this lap", "last_lap_time_s": "last lap's "
    "time", "best_lap_time_s": "best lap's time", "race_time_s": "time since the start",
    "penalty_time_s": "penalty time given so far", "speed_x_mps": "speed along the car",
    "to_middle_m": "distance from the middle, + left", "laps": "lap being driven (1 in the first lap)",
}


# meanings of per-wheel and other families of fields, by name prefix
PREFIXES = (
    ("front_wing_", "front wing (area, angle)"), ("rear_wing_", "rear wing (area, angle)"),
    ("front_area", "frontal area"), ("ride_height_", "ride height per wheel (fr, fl, rr, rl)"),
    ("mu_", "tyre friction per wheel"), ("tyre_stiffness_", "tyre stiffness per wheel (magic formula)"),
    ("tyre_dynamic_friction_", "tyre dynamic friction per wheel (magic formula)"),
    ("tyre_elasticity_", "tyre elasticity factor per wheel (magic formula)"),
    ("torque_curve_radps", "engine torque curve: engine speed per point"),
    ("torque_curve_nm", "engine torque curve: torque per point"), ("wheel_radius_", "wheel radius per wheel"),
    ("spin_", "wheel spin per wheel"), ("brake_pressure_max", "brake system's highest pressure"),
    ("brake_front_rear", "brake balance, share to the front"),
    ("brake_disk_diameter_", "brake disk diameter per wheel"), ("brake_piston_area_", "brake piston area per wheel"),
    ("brake_mu_", "brake pad friction per wheel"), ("max_torque_nm", "most engine torque"),
    ("front_weight_share", "share of the weight on the front axle"),
    ("tyre_load_factor_max_", "tyre load sensitivity per wheel: grip factor at no load (simuv2)"),
    ("tyre_load_factor_min_", "tyre load sensitivity per wheel: grip factor at high load (simuv2)"),
    ("tyre_operating_load_", "tyre load sensitivity per wheel: operating load (0: 1.2 x static)"),
    ("roll_rad", "the car's roll"), ("pitch_rad", "the car's pitch"),
    ("gc_height_m", "the CG's height"), ("front_axle_x_m", "front axle's place ahead of the CG"),
    ("rear_axle_x_m", "rear axle's place ahead of the CG (< 0)"), ("wheel_y_", "wheel's place left of the CG"),
    ("spring_", "suspension spring per wheel"), ("bellcrank_", "suspension bellcrank per wheel"),
    ("packers_", "suspension packers per wheel (travel where the body sits on them)"),
    ("slow_bump_", "damper's slow rate in compression per wheel"), ("slow_rebound_", "damper's slow rate in "
    "extension per wheel"), ("fast_bump_", "damper's fast rate in compression per wheel"),
    ("fast_rebound_", "damper's fast rate in extension per wheel"),
    ("bump_threshold_", "damper speed where the fast bump rate takes over"),
    ("rebound_threshold_", "damper speed where the fast rebound rate takes over"),
    ("travel_", "suspension travel per wheel: the ride height at rest, 0 on the packers"),
    ("max_power_w", "most engine power"), ("height_m", "height"), ("skill_level", "TORCS's skill level, 0 rookie .. "
    "3 pro (model.skill.SkillLevel; docs/rules.md)"), ("gear_count", "TORCS's _gearNb: the top gear + 1"),
)


def meaning_of(name: str, comments: dict[str, str]) -> str:
    if comments.get(name):
        return comments[name]
    if name in MEANINGS:
        return MEANINGS[name]
    return next((text for prefix, text in PREFIXES if name.startswith(prefix)), "")


def unit_of(name: str) -> str:
    if name.startswith("rpm"):
        return "rad/s"
    for suffix, unit in UNITS:
        if name.endswith(suffix):
            return unit
    return "-"


def _comments(cls: type) -> dict[str, str]:
    """The comment at the end of each field's line in the class body."""
    out: dict[str, str] = {}
    tokens = tokenize.generate_tokens(io.StringIO(inspect.getsource(cls)).readline)
    field_name = None
    for tok in tokens:
        if tok.type == tokenize.NAME and tok.start[1] == 4 and field_name is None:
            field_name = tok.string
        elif tok.type == tokenize.COMMENT and field_name:
            out.setdefault(field_name, tok.string.lstrip("# ").strip())
        elif tok.type in (tokenize.NEWLINE, tokenize.NL):
            field_name = None
    return out


def _fields(cls: type) -> list[tuple[str, str]]:
    """(name, type) of each field, NamedTuple or dataclass, in order."""
    hints = typing.get_type_hints(cls)
    names = list(getattr(cls, "_fields", ())) or [f.name for f in dataclasses.fields(cls)]
    out = []
    for n in names:
        if n.startswith("_"):
            continue
        hint = hints.get(n)
        text = hint.__name__ if isinstance(hint, type) else str(hint)
        out.append((n, text.replace("typing.", "").replace("boxbox.model.track.", "").replace("|", "or")))
    return out


def markdown() -> str:
    """One table per class: field, type, unit, meaning."""
    parts = []
    for cls in CLASSES:
        comments = _comments(cls)
        rows = ["| field | type | unit | meaning |", "|---|---|---|---|"]
        for name, type_name in _fields(cls):
            meaning = meaning_of(name, comments)
            rows.append(f"| `{name}` | {type_name} | {unit_of(name)} | {meaning} |")
        parts.append(f"### {cls.__name__}\n\n" + "\n".join(rows))
    return "\n\n".join(parts) + "\n"
