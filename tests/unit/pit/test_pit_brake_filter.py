"""control.pit_brake: the tutorial's phases, its three fixes and the constant-deceleration stop."""

from __future__ import annotations

import pytest

from boxbox.control.pit_brake import (
    ENTRY,
    EXIT,
    FREE,
    GAVE_UP,
    HOLD,
    LANE,
    LIMIT,
    PIT_LOOKAHEAD_M,
    STOP,
    PitBrakeFilter,
)
from boxbox.control.stop import SpeedTracker

G = 9.81
DT = 0.02
LIMIT_MPS = 24.5
GEOM = dict(limit_start_m=100.0, box_m=150.0, limit_end_m=400.0, speed_limit_mps=LIMIT_MPS, box_length_m=15.0)


def bd(v1: float, v2: float, mu: float) -> float:
    """Closed-form braking distance at a constant deceleration mu g (no aero)."""
    return (v1 * v1 - v2 * v2) / (2.0 * mu * G)


SLOW_MU = 0.4  # the braking grip of the lane the tests brake on: a lane of 1.0 braked with 0.4 of it


def make(**kw) -> PitBrakeFilter:
    return PitBrakeFilter(bd, **{**GEOM, "pit_mu": 1.0, "surface_mu_scale": SLOW_MU, **kw})


def first_brake_s(f: PitBrakeFilter, v: float, s_from: float, s_to: float, on_path, **kw) -> float:
    """Scan positions at a fixed speed: the first s where the filter brakes fully."""
    s = s_from
    while s < s_to:
        if f.filter(0.0, v, s, True, on_path(s), **kw).brake == 1.0:
            return s
        s += 0.1
    return float("nan")


def drive(f: PitBrakeFilter, v: float, s: float, true_mu: float = 1.0, s_end: float = 160.0,
          cruise_mps: float = 60.0, t_max: float = 120.0):
    """Crude car: brake gives brake * true_mu * g of deceleration; without brake it holds or reaches
    the filter's target (or cruise speed) at 3 m/s/s.  Logs (s, v, result) each step."""
    log = []
    t = 0.0
    while t < t_max and s < s_end:
        r = f.filter(0.0, v, s, True, s >= 0.0)
        log.append((s, v, r))
        if r.phase == HOLD and v == 0.0:
            break
        if r.brake > 0.0:
            v = max(0.0, v - r.brake * true_mu * G * DT)
        else:
            target = cruise_mps if r.target_speed_mps is None else r.target_speed_mps
            v = min(target, v + 3.0 * DT) if v < target else v
        s += v * DT
        t += DT
    return log


def test_constants():
    assert PIT_LOOKAHEAD_M == 6.0


def test_free_when_no_stop_or_off_path():
    f = make()
    r = f.filter(0.3, 60.0, -50.0, False, False)
    assert (r.brake, r.phase, r.target_speed_mps, r.gave_up) == (0.3, FREE, None, False)
    # stop wanted but driving past the pit (not on the path, inside the pit range): nothing to do
    assert f.filter(0.3, 60.0, 120.0, True, False).phase == FREE


def test_brake_to_limit_before_zone():
    f = make()
    # 50 m before the limit: 40 -> 24.5 needs (1600 - 600.25) / 7.848 = 127 m > 50
    r = f.filter(0.0, 40.0, 50.0, True, True)
    assert (r.brake, r.phase, r.target_speed_mps) == (1.0, LIMIT, LIMIT_MPS)
    # 26 m/s at the entry: 9.7 m needed to reach the limit, 86 m to stop, both fit
    r = f.filter(0.1, 26.0, 0.0, True, True)
    assert (r.brake, r.phase) == (0.1, LANE)


def test_hold_limit_in_zone():
    f = make()
    r = f.filter(0.0, LIMIT_MPS + 0.5, 105.0, True, True)
    assert (r.brake, r.phase) == (1.0, LIMIT)
    r = f.filter(0.0, LIMIT_MPS - 0.5, 105.0, True, True)  # stop needs 73 m, 45 left
    assert (r.brake, r.phase) == (1.0, STOP)


def test_stop_bang_bang_and_hold():
    f = make()
    v = 20.0
    need = bd(v, 0.0, SLOW_MU)  # 51 m
    r = f.filter(0.0, v, GEOM["box_m"] - need + 1.0, True, True)
    assert (r.brake, r.phase, r.target_speed_mps) == (1.0, STOP, 0.0)
    r = f.filter(0.0, v, GEOM["box_m"] - need - 1.0, True, True)
    assert (r.brake, r.phase) == (0.0, LANE)
    # past the centre: full brake, whatever the speed
    assert f.filter(0.0, 0.0, 151.0, True, True).phase == HOLD
    assert f.filter(0.0, 3.0, 155.0, True, True).brake == 1.0
    # captured by the race engine: hold
    r = f.filter(0.0, 0.0, 149.0, True, True, in_pit=True)
    assert (r.brake, r.phase) == (1.0, HOLD)


def test_exit_holds_limit_until_its_end():
    f = make()
    r = f.filter(0.0, LIMIT_MPS + 1.0, 200.0, False, True)
    assert (r.brake, r.phase, r.target_speed_mps) == (1.0, EXIT, LIMIT_MPS)
    r = f.filter(0.4, LIMIT_MPS - 1.0, 200.0, False, True)
    assert (r.brake, r.phase) == (0.4, EXIT)
    r = f.filter(0.0, 40.0, 450.0, False, True)  # beyond the limit end
    assert (r.brake, r.phase, r.target_speed_mps) == (0.0, EXIT, None)


# --- fix 1: mu from the pit lane's own surface ------------------------------------------------

def test_the_lane_grip_moves_the_stop_braking_point():
    v = 24.0
    on = lambda s: True  # noqa: E731
    slow = first_brake_s(make(), v, 0.0, 160.0, on)
    grippy = first_brake_s(make(surface_mu_scale=0.9), v, 0.0, 160.0, on)
    assert slow == pytest.approx(150.0 - bd(v, 0.0, SLOW_MU), abs=0.15)  # 73 m before the box
    assert grippy == pytest.approx(150.0 - bd(v, 0.0, 0.9), abs=0.15)  # 33 m before the box
    assert grippy > slow + 30.0
    # a slippery pit lane brakes earlier
    slick = first_brake_s(make(pit_mu=0.3, surface_mu_scale=1.0), v, 0.0, 160.0, on)
    assert slick < slow


def test_bad_options_rejected():
    with pytest.raises(ValueError):
        make(stop_mode="crash")


# --- fix 2: braking point for the entry computed from the path's speeds -----------------------

ENTRY_CONSTRAINT = [(0.0, 30.0)]  # the path's curve into the pit lane allows 30 m/s at the entry


def test_computed_entry_braking_point():
    v = 60.0
    off = lambda s: s >= 0.0  # noqa: E731
    f = make(surface_mu_scale=0.9, entry_constraints=ENTRY_CONSTRAINT)
    comp = first_brake_s(f, v, -400.0, 0.0, off)
    assert comp == pytest.approx(-bd(v, 30.0, 0.9), abs=0.15)  # 153 m before the entry
    r = make(surface_mu_scale=0.9, entry_constraints=ENTRY_CONSTRAINT).filter(0.0, v, comp + 0.1, True, False)
    assert (r.phase, r.target_speed_mps) == (ENTRY, 30.0)


def test_computed_entry_meets_the_entry_speed_and_stops_at_the_box():
    comp_log = drive(make(surface_mu_scale=0.9, entry_constraints=ENTRY_CONSTRAINT), 60.0, -600.0)
    assert next(v for s, v, _ in comp_log if s >= 0.0) <= 30.5
    for s, v, _ in comp_log:
        if s >= 100.0:
            assert v <= LIMIT_MPS + 0.3  # no speeding in the limit zone
    s_end, v_end, r_end = comp_log[-1]
    assert v_end == 0.0 and r_end.phase == HOLD
    assert abs(s_end - 150.0) < 1.0


def test_computed_mode_does_not_brake_without_need():
    f = make(entry_constraints=ENTRY_CONSTRAINT, surface_mu_scale=0.9)
    assert f.filter(0.0, 25.0, -10.0, True, False).phase == FREE
    assert f.filter(0.0, 60.0, -1000.0, True, False).phase == FREE


# --- fix 3: give up when pushed past the box or left standing uncaptured ----------------------

def test_gives_up_when_pushed_past_the_box():
    f = make()
    assert f.give_up_past_m == pytest.approx(15.0 / 2.0 + 2.0)
    r = f.filter(0.0, 0.0, 150.0 + 9.0, True, True)  # within the distance: hold
    assert (r.brake, r.phase, r.gave_up) == (1.0, HOLD, False)
    r = f.filter(0.0, 0.0, 150.0 + 10.0, True, True)
    assert (r.brake, r.phase, r.gave_up) == (0.0, GAVE_UP, True)
    # latched while still on the path, even back inside the box range; the limit is still held
    r = f.filter(0.0, 0.0, 150.0, True, True)
    assert (r.brake, r.gave_up) == (0.0, True)
    r = f.filter(0.0, LIMIT_MPS + 2.0, 200.0, True, True)
    assert (r.brake, r.phase, r.gave_up) == (1.0, GAVE_UP, True)
    # off the path the attempt is over: next lap the approach brakes again
    assert f.filter(0.0, 60.0, -100.0, True, False).gave_up is False
    assert f.filter(0.0, 60.0, -40.0, True, False).brake == 1.0


def test_gives_up_after_standing_uncaptured():
    f = make(give_up_timeout_s=3.0)
    steps = 0
    while steps < 1000:
        r = f.filter(0.0, 0.0, 146.0, True, True, dt_s=DT)  # 4 m short, standing: never captured
        if r.gave_up:
            break
        assert (r.brake, r.phase) == (0.0, LANE)  # brakes released: the car may creep on
        steps += 1
    assert steps * DT == pytest.approx(3.0, abs=2 * DT)
    assert r.phase == GAVE_UP


def test_capture_and_moving_reset_the_timeout():
    f = make(give_up_timeout_s=1.0)
    for _ in range(40):
        f.filter(0.0, 0.0, 146.0, True, True)
    f.filter(0.0, 0.0, 146.0, True, True, in_pit=True)  # captured: the timer restarts
    assert f.standing_s == 0.0
    for _ in range(40):
        assert not f.filter(0.0, 0.0, 146.0, True, True).gave_up
    f.filter(0.0, 3.0, 146.0, True, True)  # moving: restarts too
    assert f.standing_s == 0.0


def test_stop_no_longer_wanted_resets_give_up():
    f = make()
    assert f.filter(0.0, 0.0, 170.0, True, True).gave_up
    assert f.filter(0.0, 0.0, 170.0, False, True).gave_up is False
    assert f.gave_up is False


# --- constant-deceleration final stop ----------------------------------------------------------

def test_constant_decel_stop_comes_to_rest_at_the_box():
    tracker = SpeedTracker(full_accel_mps2=5.0, full_brake_mps2=10.0)
    f = make(stop_mode="constant-decel", surface_mu_scale=0.9, tracker=tracker)
    assert f.stop.max_decel_mps2 == pytest.approx(0.5 * 1.0 * G)
    s, v = 0.0, LIMIT_MPS
    phases, decels = [], []
    for _ in range(3000):
        r = f.filter(0.0, v, s, True, True)
        phases.append(r.phase)
        if r.phase == HOLD:
            break
        a = -r.brake * 10.0 if r.brake > 0.0 else 0.0  # the car the tracker assumes; holds speed otherwise
        if r.phase == STOP:
            assert r.target_speed_mps is not None and r.target_speed_mps <= v
            if v > 3.0:
                decels.append(-a)
        v = max(0.0, v + a * DT)
        s += v * DT
    assert phases[0] == LANE and STOP in phases and phases[-1] == HOLD
    assert abs(s - 150.0) < 0.5
    assert v < 1.0  # slow enough for the race engine to capture
    # a constant deceleration of about half the grip (not bang-bang)
    assert min(decels) > 0.8 * 0.5 * G and max(decels) < 1.1 * 0.5 * G


def test_constant_decel_on_approach_latches_before_the_entry():
    f = make(stop_mode="constant-decel", surface_mu_scale=0.9)
    # 60 m/s, 4.9 m/s/s: the stop needs 367 m, so it starts before the entry
    r = f.filter(0.0, 60.0, 150.0 - 370.0, True, False)
    assert r.phase == FREE and not f.stop.stopping
    r = f.filter(0.0, 60.0, 150.0 - 360.0, True, False)
    assert r.phase == STOP and f.stop.stopping and 0.0 < r.brake < 1.0
    # no longer wanted: the latch goes
    f.filter(0.0, 60.0, 150.0 - 350.0, False, False)
    assert not f.stop.stopping
