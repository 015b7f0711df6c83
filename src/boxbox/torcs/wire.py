"""The bridge's wire format: the one definition both sides use.

Every message is a 16-byte header of four little-endian int32 (kind, robot index, step, count)
followed by a payload of float64 records.  Each record layout below is a list of field names;
the C++ bridge gets the same layouts as a generated header (`c_header()`), so the two sides
cannot drift apart.  All numbers travel as doubles: no padding, no per-field types to keep in sync.

Message flow (bridge -> host, host answers each with one message unless noted):
  HELLO       payload: HELLO record                      -> HELLO  (protocol check)
  NEW_TRACK   chunks of TRACK + count x SEGMENT + HANDLE  -> FUEL   (after the last chunk)
  NEW_RACE    CAR record                                  -> ACK
  DRIVE       STATE + count x OPPONENT                    -> CONTROLS
  PIT_CMD     STATE                                       -> PIT_ORDER
  END_RACE    STATE                                       -> ACK  (TORCS 1.3 never calls rbEndRace)
  SHUTDOWN    STATE (the car at the race's clean-up)      (no answer)
A reply's header carries the same kind, robot index and step; its `count` holds FLAG_* bits.
"""

from __future__ import annotations

import struct

from boxbox.torcs.car_setup import SLOTS

# 7: the whole car setup in FUEL; 6: SHUTDOWN carries the car's STATE; 5: the suspension in HANDLE,
# the wheels' travel
PROTOCOL_VERSION = 7

# message kinds
HELLO, NEW_TRACK, NEW_RACE, DRIVE, PIT_CMD, END_RACE, SHUTDOWN, FUEL, ACK, CONTROLS, PIT_ORDER = range(1, 12)

FLAG_FAULT = 1  # reply flag: the robot failed; the bridge brakes this car and stops asking

HEADER = struct.Struct("<iiii")
MAX_MESSAGE_BYTES = 60_000  # SOCK_SEQPACKET message limit we stay under (chunked above it)
MAX_OPPONENTS = 40
MAX_GEARS = 10
MAX_TORQUE_POINTS = 24  # engine curve points sent (TORCS cars have up to about 20)

HELLO_FIELDS = ["protocol_version", "car_struct_bytes", "pid"]

TRACK_FIELDS = [
    "length_m", "width_m", "n_segments",
    "pit_type", "pit_side", "pit_entry_seg", "pit_start_seg", "pit_end_seg", "pit_exit_seg",
    "pit_width_m", "pit_box_length_m", "pit_speed_limit_mps", "pit_count",
]

SIDE_PART_FIELDS = [
    "border_width_m", "border_style", "border_height_m", "border_friction", "border_roughness",
    "outer_start_width_m", "outer_end_width_m", "outer_friction", "outer_roll_resistance", "outer_roughness",
    "barrier_style", "barrier_width_m",
]

SEGMENT_FIELDS = [
    "id", "type", "length_m", "width_m", "start_width_m", "end_width_m", "start_dist_m",
    "radius_m", "radius_right_m", "radius_left_m", "arc_rad",
    "center_x", "center_y",
    "start_left_x", "start_left_y", "start_right_x", "start_right_y",
    "end_left_x", "end_left_y", "end_right_x", "end_right_y",
    "start_z_m", "end_z_m", "start_angle_rad",
    "friction", "roll_resistance", "roughness", "race_info",
    "left_side_width_m", "right_side_width_m", "left_side_friction", "right_side_friction",
    "banking_start_rad", "banking_end_rad",
    # The sides as TORCS builds them (track4.cpp, AddSides): outward from the main segment an optional
    # border (style 0 flat, 1 curb, 2 wall), then an optional side (flat), then the barrier (style 2
    # wall, 3 fence, 4 pit building). A part that is absent has width 0. (The two `*_side_*` fields
    # above are of the first part beside the track, which is the border where there is one.)
    *[f"{side}_{name}" for side in ("left", "right") for name in SIDE_PART_FIELDS],
]

SUSPENSION_FIELDS = [
    ("wheel_y", "_m"), ("spring", "_npm"), ("bellcrank", ""), ("packers", "_m"),
    ("slow_bump", "_nspm"), ("slow_rebound", "_nspm"), ("fast_bump", "_nspm"), ("fast_rebound", "_nspm"),
    ("bump_threshold", "_mps"), ("rebound_threshold", "_mps"),
]

# car constants readable from the car's parameter file at NEW_TRACK time
HANDLE_FIELDS = [
    "mass_kg", "tank_l", "initial_fuel_l",
    "front_wing_area_m2", "front_wing_angle_rad", "rear_wing_area_m2", "rear_wing_angle_rad",
    "front_clift", "rear_clift", "cx", "front_area_m2",
    "ride_height_fr_m", "ride_height_fl_m", "ride_height_rr_m", "ride_height_rl_m",
    "mu_fr", "mu_fl", "mu_rr", "mu_rl",
    "drivetrain",  # 0 RWD, 1 FWD, 2 4WD
    "fuel_cons_factor", "brake_pressure_max", "brake_front_rear",
    # each wheel's brake (simuv2 brake.cpp): disk diameter (m), piston area (m^2), pad friction; its
    # torque is disk / 2 x area x mu x the wheel's pressure
    "brake_disk_diameter_fr_m", "brake_disk_diameter_fl_m", "brake_disk_diameter_rr_m", "brake_disk_diameter_rl_m",
    "brake_piston_area_fr_m2", "brake_piston_area_fl_m2", "brake_piston_area_rr_m2", "brake_piston_area_rl_m2",
    "brake_mu_fr", "brake_mu_fl", "brake_mu_rr", "brake_mu_rl",
    # the engine's tickover, revs maxi (rad/s) and engine brake coefficient: its braking torque and
    # the fuel it burns with the throttle closed (simuv2 engine.cpp)
    "engine_tickover_radps", "engine_revs_max_radps", "engine_brake_coeff",
    "front_weight_share",  # the car file's front-rear weight repartition (share on the front axle)
    # tyres: the magic formula's stiffness, dynamic friction and elasticity factor, per wheel
    "tyre_stiffness_fr", "tyre_stiffness_fl", "tyre_stiffness_rr", "tyre_stiffness_rl",
    "tyre_dynamic_friction_fr", "tyre_dynamic_friction_fl", "tyre_dynamic_friction_rr", "tyre_dynamic_friction_rl",
    "tyre_elasticity_fr", "tyre_elasticity_fl", "tyre_elasticity_rr", "tyre_elasticity_rl",
    # tyres' load sensitivity (simuv2 wheel.cpp): mu x (min + (max - min) exp(k load / operating load)),
    # per wheel; operating load 0 where the car file is silent (simuv2 then takes 1.2 x the static load)
    "tyre_load_factor_max_fr", "tyre_load_factor_max_fl", "tyre_load_factor_max_rr", "tyre_load_factor_max_rl",
    "tyre_load_factor_min_fr", "tyre_load_factor_min_fl", "tyre_load_factor_min_rr", "tyre_load_factor_min_rl",
    "tyre_operating_load_fr_n", "tyre_operating_load_fl_n", "tyre_operating_load_rr_n", "tyre_operating_load_rl_n",
    # the suspension (simuv2 suspension.cpp, wheel.cpp): the CG's height, the axles' and wheels'
    # places, and per wheel the spring (N/m as TORCS converts the file's unit), bellcrank, packers
    # (m) and the dampers' slow and fast rates (N s/m) with the speed (m/s) where fast takes over
    "gc_height_m", "front_axle_x_m", "rear_axle_x_m",
    *[f"{name}_{w}{unit}" for w in ("fr", "fl", "rr", "rl") for name, unit in SUSPENSION_FIELDS],
    # the engine's torque curve (rad/s, N m), torque_points of them
    "torque_points",
    *[f"torque_rpm_{i}" for i in range(MAX_TORQUE_POINTS)],
    *[f"torque_nm_{i}" for i in range(MAX_TORQUE_POINTS)],
]

# car constants known once the car exists (NEW_RACE), plus this car's own pit
CAR_FIELDS = [
    "car_index", "gear_count", "gear_offset",
    *[f"gear_ratio_{i}" for i in range(MAX_GEARS)],
    "rpm_redline", "rpm_max", "rpm_max_torque", "rpm_max_power", "max_torque_nm", "max_power_w",
    "wheel_radius_fr_m", "wheel_radius_fl_m", "wheel_radius_rr_m", "wheel_radius_rl_m",
    "steer_lock_rad", "length_m", "width_m", "height_m", "tank_l",
    "pit_seg", "pit_to_start", "pit_to_middle_m", "pit_lmin_m", "pit_lmax_m",
    "start_rank", "race_laps",
    "skill_level",  # 0 rookie, 1 amateur, 2 semi-pro, 3 pro (TORCS's _skillLevel)
]

STATE_FIELDS = [
    "sim_time_s", "x_m", "y_m", "z_m", "yaw_rad", "roll_rad", "pitch_rad",
    "speed_x_mps", "speed_y_mps", "speed_z_mps", "yaw_rate_rps", "accel_x_mps2", "accel_y_mps2",
    "seg_id", "to_start", "to_right_m", "to_middle_m", "to_left_m", "angle_rad",
    "dist_from_start_m", "dist_raced_m",
    "gear", "rpm", "spin_fr_rps", "spin_fl_rps", "spin_rr_rps", "spin_rl_rps",
    "fuel_l", "damage", "laps", "remaining_laps", "total_laps", "position",
    "cur_lap_time_s", "last_lap_time_s", "best_lap_time_s", "race_time_s",
    "car_state", "pit_stops", "penalty_time_s", "top_speed_mps", "n_opponents",
    "travel_fr_m", "travel_fl_m", "travel_rr_m", "travel_rl_m",
]

OPPONENT_FIELDS = [
    "car_index", "x_m", "y_m", "yaw_rad", "speed_x_mps", "speed_y_mps", "speed_mps",
    "seg_id", "to_start", "to_middle_m", "dist_from_start_m", "dist_raced_m",
    "laps", "last_lap_time_s", "best_lap_time_s", "car_state", "damage", "length_m", "width_m",
]

CONTROLS_FIELDS = ["steer", "accel", "brake", "clutch", "gear", "pit_request"]
PIT_ORDER_FIELDS = ["fuel_l", "repair"]
# the answer to NEW_TRACK: fuel (< 0: the car's own) and the car setup, a value per place of
# torcs/car_setup.py's SLOTS (NaN: the car's own)
FUEL_FIELDS = ["initial_fuel_l", *[f"setup_{i}" for i in range(len(SLOTS))]]

RECORDS = {
    "HELLO": HELLO_FIELDS, "TRACK": TRACK_FIELDS, "SEGMENT": SEGMENT_FIELDS, "HANDLE": HANDLE_FIELDS,
    "CAR": CAR_FIELDS, "STATE": STATE_FIELDS, "OPPONENT": OPPONENT_FIELDS,
    "CONTROLS": CONTROLS_FIELDS, "PIT_ORDER": PIT_ORDER_FIELDS, "FUEL": FUEL_FIELDS,
}


def record(fields: list[str]) -> struct.Struct:
    return struct.Struct(f"<{len(fields)}d")


HELLO_REC = record(HELLO_FIELDS)
TRACK_REC = record(TRACK_FIELDS)
SEGMENT_REC = record(SEGMENT_FIELDS)
HANDLE_REC = record(HANDLE_FIELDS)
CAR_REC = record(CAR_FIELDS)
STATE_REC = record(STATE_FIELDS)
OPPONENT_REC = record(OPPONENT_FIELDS)
CONTROLS_REC = record(CONTROLS_FIELDS)
PIT_ORDER_REC = record(PIT_ORDER_FIELDS)
FUEL_REC = record(FUEL_FIELDS)

_KINDS = ["HELLO", "NEW_TRACK", "NEW_RACE", "DRIVE", "PIT_CMD", "END_RACE", "SHUTDOWN",
          "FUEL", "ACK", "CONTROLS", "PIT_ORDER"]


def c_header() -> str:
    """The C++ side of this module: structs of doubles with the same field order."""
    out = ["// Generated from boxbox/torcs/wire.py; do not edit.", "#pragma once", "#include <stdint.h>",
           f"#define BB_PROTOCOL_VERSION {PROTOCOL_VERSION}",
           f"#define BB_MAX_MESSAGE_BYTES {MAX_MESSAGE_BYTES}",
           f"#define BB_MAX_OPPONENTS {MAX_OPPONENTS}",
           f"#define BB_MAX_TORQUE_POINTS {MAX_TORQUE_POINTS}",
           f"#define BB_FLAG_FAULT {FLAG_FAULT}",
           f"#define BB_SIDE_PART_FIELDS {len(SIDE_PART_FIELDS)}"]
    out += [f"#define BB_{name} {i}" for i, name in enumerate(_KINDS, start=1)]
    out.append("typedef struct { int32_t kind, robot, step, count; } bb_header;")
    for name, fields in RECORDS.items():
        body = " ".join(f"double {f};" for f in fields)
        out.append(f"typedef struct {{ {body} }} bb_{name.lower()};")
    out.append(f"#define BB_SETUP_SLOTS {len(SLOTS)}")  # FUEL's setup_i: the place in the car's file
    places = ", ".join(f'{{"{section}", "{key}"}}' for section, key in SLOTS)
    out.append(f"static const char *const BB_SETUP_PLACES[BB_SETUP_SLOTS][2] = {{{places}}};")
    return "\n".join(out) + "\n"
