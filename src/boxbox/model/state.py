"""What a robot sees each drive step.  Plain tuples: decoding a step costs one C call.

Field order equals the wire layout (`boxbox.torcs.wire.STATE_FIELDS`); a test keeps them equal.
Units are in the names; `to_start` is metres on straights and radians on turns (as in TORCS).
"""

from __future__ import annotations

from typing import NamedTuple

# car_state bits (TORCS RM_CAR_STATE_*)
CAR_STATE_PIT = 0x1  # stopped in its pit right now
CAR_STATE_DNF = 0x2
CAR_STATE_FINISH = 0x100
CAR_STATE_OUT = CAR_STATE_DNF | CAR_STATE_FINISH
CAR_STATE_NO_SIMU = 0xFF  # any of these: TORCS neither simulates the car nor calls its robot (pits, out)


class Opponent(NamedTuple):
    car_index: float
    x_m: float
    y_m: float
    yaw_rad: float
    speed_x_mps: float
    speed_y_mps: float
    speed_mps: float
    seg_id: float
    to_start: float
    to_middle_m: float
    dist_from_start_m: float
    dist_raced_m: float
    laps: float
    last_lap_time_s: float
    best_lap_time_s: float
    car_state: float
    damage: float
    length_m: float
    width_m: float

class State(NamedTuple):
    sim_time_s: float
    x_m: float
    y_m: float
    z_m: float
    yaw_rad: float
    roll_rad: float
    pitch_rad: float
    speed_x_mps: float  # along the car's axis
    speed_y_mps: float
    speed_z_mps: float
    yaw_rate_rps: float
    accel_x_mps2: float
    accel_y_mps2: float
    seg_id: float
    to_start: float
    to_right_m: float
    to_middle_m: float  # + left, - right
    to_left_m: float
    angle_rad: float  # track tangent minus car yaw, in [-pi, pi]
    dist_from_start_m: float
    dist_raced_m: float
    gear: float
    rpm: float  # engine speed in rad/s, as TORCS reports it
    spin_fr_rps: float
    spin_fl_rps: float
    spin_rr_rps: float
    spin_rl_rps: float
    fuel_l: float
    damage: float
    laps: float  # TORCS counts the lap being driven: 1 during the first lap
    remaining_laps: float
    total_laps: float
    position: float
    cur_lap_time_s: float
    last_lap_time_s: float
    best_lap_time_s: float
    race_time_s: float
    car_state: float
    pit_stops: float
    penalty_time_s: float
    top_speed_mps: float
    n_opponents: float
    # each wheel's suspension travel (m): the car file's ride height at rest, less under load, 0 on
    # the packers (where TORCS counts damage for the speed the body hits them with)
    travel_fr_m: float = 0.0
    travel_fl_m: float = 0.0
    travel_rr_m: float = 0.0
    travel_rl_m: float = 0.0
    opponents: tuple[Opponent, ...] = ()

    @property
    def in_pit(self) -> bool:
        """Stopped in the pit (captured by the race engine)."""
        return int(self.car_state) & CAR_STATE_PIT != 0
