import dataclasses
import math

import pytest

from boxbox.control.traction import (
    SlipParams,
    abs_filter,
    abs_hold,
    axle_force_room_n,
    combined_slip_room,
    drive_axles,
    drive_force_room_n,
    driven_wheel_speed_mps,
    spare_slip_ratio,
    tcl_filter,
    throttle_for_torque,
)
from boxbox.model.car import AWD, FWD, RWD, Car
from boxbox.model.constants import G_MPS2

R = (0.33, 0.33, 0.3, 0.3)  # fr, fl, rr, rl


def spins(fr_mps: float, fl_mps: float, rr_mps: float, rl_mps: float) -> tuple[float, float, float, float]:
    """Wheel spins (rad/s) giving these wheel surface speeds with radii R."""
    return (fr_mps / R[0], fl_mps / R[1], rr_mps / R[2], rl_mps / R[3])


def test_defaults():
    p = SlipParams()
    assert (p.abs_slip_mps, p.abs_range_mps, p.abs_min_speed_mps) == (2.0, 5.0, 3.0)
    assert (p.tcl_slip_mps, p.tcl_range_mps, p.tcl_min_speed_mps) == (2.0, 10.0, 3.0)
    assert (p.abs_hold_over_mps, p.abs_hold_share) == (math.inf, 0.5)  # the plain ABS unless asked
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.abs_slip_mps = 1.0  # type: ignore[misc]


# --- ABS ---

def test_abs_rolling_wheels_unchanged():
    assert abs_filter(0.8, 30.0, spins(30, 30, 30, 30), R) == 0.8


def test_abs_below_threshold_unchanged():
    assert abs_filter(0.8, 30.0, spins(28.5, 28.5, 27.5, 27.5), R) == 0.8  # slip exactly 2


def test_abs_below_min_speed_unchanged():
    assert abs_filter(1.0, 2.9, spins(0, 0, 0, 0), R) == 1.0


def test_abs_proportional_reduction():
    # mean wheel speed 25.5 -> slip 4.5 -> brake - (4.5 - 2) / 5
    assert abs_filter(0.8, 30.0, spins(26, 26, 25, 25), R) == pytest.approx(0.3, abs=1e-12)


def test_abs_locked_wheels_release_fully():
    assert abs_filter(1.0, 30.0, spins(0, 0, 0, 0), R) == 0.0


def test_abs_custom_params():
    p = SlipParams(abs_slip_mps=1.0, abs_range_mps=2.0)
    assert abs_filter(1.0, 30.0, spins(28, 28, 28, 28), R, p) == pytest.approx(0.5, abs=1e-12)


HOLD = SlipParams(abs_hold_over_mps=6.0)


def test_abs_hold_keeps_half_of_a_full_step_far_over_the_target():
    # full pressure last step, the fronts locked, the ABS releases fully: 8 m/s over the target
    assert abs_hold(1.0, 0.0, 1.0, 8.0, HOLD) == 0.5
    assert abs_hold(1.0, 0.2, 0.9, 8.0, HOLD) == pytest.approx(0.45, abs=1e-12)


def test_abs_hold_never_above_the_brake_asked():
    assert abs_hold(0.3, 0.0, 1.0, 8.0, HOLD) == 0.3


def test_abs_hold_leaves_the_abs_alone_within_the_plan():
    assert abs_hold(1.0, 0.0, 1.0, 6.0, HOLD) == 0.0  # not more than 6 m/s over
    assert abs_hold(1.0, 0.0, 1.0, 50.0) == 0.0  # off by default (abs_hold_over_mps inf)


def test_abs_hold_only_right_after_full_pressure():
    assert abs_hold(1.0, 0.0, 0.85, 8.0, HOLD) == 0.0  # the last step was a part pressure
    assert abs_hold(1.0, 0.7, 1.0, 8.0, HOLD) == 0.7  # the ABS releases less than the hold
    assert abs_hold(1.0, 1.0, 1.0, 8.0, HOLD) == 1.0


def test_abs_hold_share():
    assert abs_hold(1.0, 0.0, 1.0, 8.0, SlipParams(abs_hold_over_mps=6.0, abs_hold_share=0.3)) == 0.3
    assert abs_hold(1.0, 0.0, 1.0, 8.0, SlipParams(abs_hold_over_mps=6.0, abs_hold_share=0.0)) == 0.0


# --- TCL ---

def test_driven_wheels_per_drivetrain():
    s = spins(10, 12, 20, 22)
    assert driven_wheel_speed_mps(s, R, RWD) == pytest.approx(21.0)
    assert driven_wheel_speed_mps(s, R, FWD) == pytest.approx(11.0)
    assert driven_wheel_speed_mps(s, R, AWD) == pytest.approx(16.0)
    with pytest.raises(ValueError):
        driven_wheel_speed_mps(s, R, 7)


def test_tcl_no_slip_unchanged():
    assert tcl_filter(1.0, 20.0, spins(20, 20, 21.9, 21.9), R, RWD) == 1.0


def test_tcl_below_min_speed_unchanged():
    assert tcl_filter(1.0, 2.0, spins(2, 2, 40, 40), R, RWD) == 1.0


def test_tcl_rwd_uses_rear_wheels():
    # rear slip 7 m/s -> accel - 0.5; spinning fronts do not matter
    assert tcl_filter(1.0, 20.0, spins(20, 20, 27, 27), R, RWD) == pytest.approx(0.5, abs=1e-12)
    assert tcl_filter(1.0, 20.0, spins(40, 40, 20, 20), R, RWD) == 1.0


def test_tcl_fwd_uses_front_wheels():
    assert tcl_filter(1.0, 20.0, spins(27, 27, 20, 20), R, FWD) == pytest.approx(0.5, abs=1e-12)
    assert tcl_filter(1.0, 20.0, spins(20, 20, 40, 40), R, FWD) == 1.0


def test_tcl_awd_uses_all_wheels():
    # mean 27 -> slip 7
    assert tcl_filter(1.0, 20.0, spins(24, 24, 30, 30), R, AWD) == pytest.approx(0.5, abs=1e-12)


def test_tcl_not_below_zero():
    assert tcl_filter(0.3, 20.0, spins(20, 20, 60, 60), R, RWD) == 0.0


def test_tcl_slip_ratio_allows_more_slip_at_speed():
    ratio = SlipParams(tcl_slip_ratio=0.15)
    # at 40 m/s 0.15 allows 6 m/s: 5 m/s of slip keeps the throttle, the fixed 2 m/s cut it by 0.3
    assert tcl_filter(1.0, 40.0, spins(40, 40, 45, 45), R, RWD, ratio) == 1.0
    assert tcl_filter(1.0, 40.0, spins(40, 40, 45, 45), R, RWD) == pytest.approx(0.7, abs=1e-12)
    # 11 m/s of slip at 40 m/s: cut by (11 - 6) / 10
    assert tcl_filter(1.0, 40.0, spins(40, 40, 51, 51), R, RWD, ratio) == pytest.approx(0.5, abs=1e-12)
    # at 10 m/s the ratio allows 1.5 m/s, less than the fixed 2 m/s, which stays the floor
    assert tcl_filter(1.0, 10.0, spins(10, 10, 17, 17), R, RWD, ratio) == pytest.approx(0.5, abs=1e-12)


def test_tcl_ratio_capped_by_the_slip_a_turn_leaves():
    ratio = SlipParams(tcl_slip_ratio=0.15)
    # a tyre peaking at slip 0.26: a straight leaves it all, a turn at 90 % of the grip 0.113
    assert spare_slip_ratio(0.26, 0.0) == pytest.approx(0.26)
    assert spare_slip_ratio(0.26, 0.9) == pytest.approx(0.26 * (1 - 0.81) ** 0.5)
    assert spare_slip_ratio(0.26, 1.0) == 0.0 and spare_slip_ratio(0.26, 1.2) == 0.0
    # 5 m/s of slip at 40 m/s: free on a straight (0.15 allows 6), cut in the turn (0.113 allows 4.5)
    assert tcl_filter(1.0, 40.0, spins(40, 40, 45, 45), R, RWD, ratio, spare_slip_ratio(0.26, 0.0)) == 1.0
    cut = tcl_filter(1.0, 40.0, spins(40, 40, 45, 45), R, RWD, ratio, spare_slip_ratio(0.26, 0.9))
    assert cut == pytest.approx(1.0 - (5.0 - 40.0 * 0.26 * 0.19 ** 0.5) / 10.0)
    # at the grip's limit only the fixed 2 m/s is left
    assert tcl_filter(1.0, 40.0, spins(40, 40, 45, 45), R, RWD, ratio, 0.0) == pytest.approx(0.7)


def test_tcl_range_ratio_shuts_the_throttle_within_the_peaks_slip_at_low_speed():
    # pro, a tyre peaking at slip 0.26: at 16 m/s the range is 0.26 x 16 = 4.16 m/s, not 10
    held = SlipParams(tcl_range_ratio=0.26)
    # 7 m/s of slip at 16 m/s (44 %, mixed-2's spin out of a hairpin at pro): the tutorial's range kept half
    assert tcl_filter(1.0, 16.0, spins(16, 16, 23, 23), R, RWD) == pytest.approx(0.5)
    assert tcl_filter(1.0, 16.0, spins(16, 16, 23, 23), R, RWD, held) == 0.0
    assert tcl_filter(1.0, 16.0, spins(16, 16, 20, 20), R, RWD, held) == pytest.approx(1.0 - 2.0 / 4.16)
    # at speed the fixed 10 m/s is the smaller range and holds as without the ratio
    assert tcl_filter(1.0, 50.0, spins(50, 50, 55, 55), R, RWD, held) == pytest.approx(0.7)


def test_combined_slip_room_keeps_the_combined_slip_at_the_peak():
    # no side slip: r / (1 + r) = peak, r = p / (1 - p); the room shrinks as the side slip grows
    assert combined_slip_room(0.25, 0.0) == pytest.approx(0.25 / 0.75)
    r = combined_slip_room(0.25, 0.15)
    assert ((r * r + 0.15**2) ** 0.5) / (1.0 + r) == pytest.approx(0.25)
    assert combined_slip_room(0.25, -0.15) == pytest.approx(r) and 0.0 < r < 0.25 / 0.75
    # sliding sideways at or past the peak: no room at all
    assert combined_slip_room(0.25, 0.25) == 0.0 and combined_slip_room(0.25, -0.4) == 0.0
    assert combined_slip_room(1.2, 0.3) == float("inf")


def test_combined_slip_room_cuts_the_throttle_of_a_car_sliding_out_of_a_turn():
    # car1-ow1 out of e-track-2's right-hander (tyre peak 0.214): 36.7 m/s, rear side slip 0.26,
    # 27 % wheelspin (9.9 m/s).  The turn's share (0.5 here) left 0.15 x 36.7 = 5.5 m/s and 56 % of
    # the throttle; the measured slip leaves the fixed 2 m/s, and 21 %
    ratio = SlipParams(tcl_slip_ratio=0.15)
    wheels = spins(36.7, 36.7, 46.6, 46.6)
    assert tcl_filter(1.0, 36.7, wheels, R, RWD, ratio, spare_slip_ratio(0.214, 0.5)) == pytest.approx(
        1.0 - (9.9 - 0.15 * 36.7) / 10.0)
    room = min(spare_slip_ratio(0.214, 0.5), combined_slip_room(0.214, 0.26))
    assert tcl_filter(1.0, 36.7, wheels, R, RWD, ratio, room) == pytest.approx(1.0 - (9.9 - 2.0) / 10.0)
    # gripping (side slip 0.05): the turn's share still sets the room, nothing changes
    assert combined_slip_room(0.214, 0.05) > spare_slip_ratio(0.214, 0.5) > 0.15


def test_throttle_for_torque_adds_what_the_engine_brake_takes():
    # simuv2: torque = full x (throttle x (1 + b) - b); 40 % of the full torque at b = 0.25 needs 52 %
    assert throttle_for_torque(0.4, 0.25) == pytest.approx(0.52)
    assert (0.52 * 1.25 - 0.25) == pytest.approx(0.4)
    assert throttle_for_torque(0.4, 0.0) == pytest.approx(0.4)
    assert throttle_for_torque(0.0, 0.3) == pytest.approx(0.3 / 1.3)  # no torque: not no throttle
    assert throttle_for_torque(1.0, 0.3) == 1.0 and throttle_for_torque(1.5, 0.3) == 1.0
    assert throttle_for_torque(-1.0, 0.3) == 0.0


def test_axle_force_room_is_the_friction_circle_on_the_load_the_force_leaves():
    mu, load, lateral = 1.2, 5000.0, 3000.0
    circle = math.sqrt((mu * load) ** 2 - lateral**2)
    assert axle_force_room_n(mu, load, lateral, 1.0, 0.0) == pytest.approx(circle)
    # the rear gains load as the force pitches the car: more room, met exactly at the room
    rear = axle_force_room_n(mu, load, lateral, 1.0, 0.12)
    assert rear > circle and rear**2 + lateral**2 == pytest.approx((mu * (load + 0.12 * rear)) ** 2)
    # a driven front loses it: less
    front = axle_force_room_n(mu, load, lateral, 1.0, -0.12)
    assert front < circle and front**2 + lateral**2 == pytest.approx((mu * (load - 0.12 * front)) ** 2)
    # half the force on the axle (four-wheel drive): twice the force for the same circle, without shift
    assert axle_force_room_n(mu, load, lateral, 0.5, 0.0) == pytest.approx(2.0 * circle)
    # a turn beyond the axle's grip: no drive force at all
    assert axle_force_room_n(mu, load, 6100.0, 1.0, 0.12) == 0.0
    # not driven: no limit unless the force takes its load, then as long as it still holds the turn
    assert axle_force_room_n(mu, load, lateral, 0.0, 0.0) == math.inf
    assert axle_force_room_n(mu, load, lateral, 0.0, 0.12) == math.inf
    assert axle_force_room_n(mu, load, lateral, 0.0, -0.12) == pytest.approx((mu * load - lateral) / (mu * 0.12))


def _rwd_car(**kw) -> Car:
    base = dict(mass_kg=1000.0, front_weight_share=0.5, gc_height_m=0.3, front_axle_x_m=1.3, rear_axle_x_m=-1.3,
                drivetrain=RWD)
    base.update(kw)
    return Car(**base)


def test_drive_axles_split_the_force_by_drivetrain_and_move_load_rearwards():
    front, rear = drive_axles(_rwd_car())
    assert (front.force_share, rear.force_share) == (0.0, 1.0)
    assert rear.load_per_force == pytest.approx(0.3 / 2.6) and front.load_per_force == -rear.load_per_force
    assert front.weight_n == pytest.approx(500 * G_MPS2) and rear.weight_n == pytest.approx(500 * G_MPS2)
    assert [a.force_share for a in drive_axles(_rwd_car(drivetrain=FWD))] == [1.0, 0.0]
    assert [a.force_share for a in drive_axles(_rwd_car(drivetrain=AWD))] == [0.5, 0.5]


def test_near_its_limit_a_rear_driven_car_is_held_by_the_front_it_unloads():
    """g-track-1's long turn at pro: full throttle unloaded the steering front and the car spun off;
    the rear axle's own circle alone would allow more force than the front can take off its load."""
    axles = drive_axles(_rwd_car())
    mu, t, half_w = 1.2, 0.3 / 2.6, 500 * G_MPS2
    # straight: the rear's grip, grown by the load its own force moves onto it
    assert drive_force_room_n(axles, mu, 30.0, 0.0) == pytest.approx(mu * half_w / (1.0 - mu * t))
    # a turn taking 95 % of the grip: the front limits, below the rear's circle
    k = 0.95 * mu * G_MPS2 / 30.0**2
    lateral = 0.95 * mu * half_w
    room = drive_force_room_n(axles, mu, 30.0, k)
    assert room == pytest.approx((mu * half_w - lateral) / (mu * t))
    assert room < axle_force_room_n(mu, half_w, lateral, 1.0, t)
