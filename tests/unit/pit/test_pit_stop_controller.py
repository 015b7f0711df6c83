"""control.stop: the constant-deceleration stop controller and the speed tracker."""

from __future__ import annotations

import math

import pytest

from boxbox.control.stop import SpeedTracker, Stop, StopResult, StopStatus

DT = 0.02


def simulate(stop: Stop, speed: float, dist: float, threshold: float, command: float = 30.0,
             full_brake: float = 8.0, t_max: float = 20.0) -> tuple[float, float, list[StopResult]]:
    """Plain kinematics: while the stop controls, the car decelerates at its A (at most full_brake);
    otherwise (not stopping, creeping) it follows the commanded speed with a 1 s time constant.
    Returns (time, position error, results)."""
    pos, t, log = 0.0, 0.0, []
    while t < t_max:
        r = stop.control(command, speed, dist - pos, threshold)
        log.append(r)
        if r.status is StopStatus.FINISHED:
            break
        if r.speed_mps >= speed:
            accel = (r.speed_mps - speed) / 1.0
        else:
            accel = -min(r.decel_mps2, full_brake, speed / DT)
        speed = max(0.0, speed + accel * DT)
        pos += speed * DT
        t += DT
    return t, pos - dist, log


def test_seed_example_stops_in_4_s_at_1_25():
    stop = Stop(max_decel_mps2=1.0, latency_s=0.0)
    r = stop.control(30.0, 5.0, 10.0, 0.05)
    assert stop.stopping  # A = 1.25 >= 1.0: latched at once
    assert r.decel_mps2 == pytest.approx(1.25)
    assert r.speed_mps == pytest.approx(5.0 - 1.25)  # "A less in one second"
    stop.reset()
    t, err, log = simulate(stop, 5.0, 10.0, 0.05)
    assert t == pytest.approx(4.0, abs=0.1)
    assert abs(err) < 0.1
    # the deceleration stays constant on the way
    decels = [x.decel_mps2 for x in log[:150]]
    assert max(decels) - min(decels) < 0.05


def test_not_stopping_passes_command_through():
    stop = Stop(max_decel_mps2=2.0, latency_s=0.0)
    r = stop.control(17.0, 10.0, 100.0, 0.5)  # A = 0.5 < 2, D > 5
    assert (r.speed_mps, r.status, stop.stopping) == (17.0, StopStatus.OK, False)
    assert r.decel_mps2 == pytest.approx(0.5)


def test_latches_on_min_distance_and_keeps_latch():
    stop = Stop(max_decel_mps2=5.0, min_stop_dist_m=5.0, latency_s=0.0)
    r = stop.control(10.0, 1.0, 4.0, 0.2)  # A tiny, but D <= 5
    assert stop.stopping and r.speed_mps == pytest.approx(min(10.0, 1.0 - 1.0 / 8.0, 3.0))
    # latched: far away again (e.g. the target moved) it still controls
    r = stop.control(10.0, 1.0, 50.0, 0.2)
    assert stop.stopping and r.speed_mps < 1.0


def test_initial_speed_caps_command():
    stop = Stop(max_decel_mps2=1.0, latency_s=0.0)
    stop.control(50.0, 10.0, 40.0, 0.5)  # A = 1.25 -> latch at 10 m/s
    assert stop.initial_speed_mps == 10.0
    r = stop.control(50.0, 12.0, 40.0, 0.5)  # pushed faster: still capped at the latch speed
    assert r.speed_mps == pytest.approx(10.0)
    slow = Stop(max_decel_mps2=5.0, latency_s=0.0)
    slow.control(50.0, 1.0, 3.0, 0.5, topspeed_mps=3.0)
    assert slow.initial_speed_mps == 3.0  # max(topspeed, speed)


def test_reset_unlatches():
    stop = Stop(max_decel_mps2=1.0, latency_s=0.0)
    stop.control(30.0, 5.0, 10.0, 0.05)
    assert stop.stopping
    stop.reset()
    assert not stop.stopping and not stop.creeping
    r = stop.control(30.0, 1.0, 100.0, 0.05)
    assert r.speed_mps == 30.0


def test_threshold_commands_zero_and_finishes_when_standing():
    stop = Stop(max_decel_mps2=1.0, latency_s=0.0)
    stop.control(30.0, 5.0, 10.0, 0.5)
    r = stop.control(30.0, 0.8, 0.4, 0.5)
    assert r.speed_mps == 0.0 and r.status is StopStatus.OK  # still rolling
    r = stop.control(30.0, 0.0, 0.3, 0.5)
    assert r.speed_mps == 0.0 and r.status is StopStatus.FINISHED
    r = stop.control(30.0, 0.0, -0.7, 0.5)  # past the point: still zero
    assert r.speed_mps == 0.0 and math.isinf(r.decel_mps2)


def test_latency_shortens_distance():
    stop = Stop(max_decel_mps2=100.0, latency_s=0.5)
    r = stop.control(30.0, 10.0, 25.0, 0.5)  # D = 25 - 5 = 20
    assert r.decel_mps2 == pytest.approx(100.0 / 40.0)


def test_creeps_when_stopped_short_within_creep_distance():
    stop = Stop(max_decel_mps2=1.0, latency_s=0.0, max_creep_dist_m=10.0, creep_speed_mps=1.0)
    stop.control(30.0, 5.0, 10.0, 0.2)
    r = stop.control(30.0, 0.0, 3.0, 0.2)  # standing 3 m short
    assert r.speed_mps == 1.0 and stop.creeping
    r = stop.control(30.0, 0.9, 1.5, 0.2)  # keeps creeping while rolling
    assert r.speed_mps == 1.0
    r = stop.control(30.0, 1.0, 0.1, 0.2)  # arrived
    assert r.speed_mps == 0.0 and not stop.creeping
    # creep speed is not above the caller's command
    stop.reset()
    stop.control(0.5, 5.0, 10.0, 0.2)
    assert stop.control(0.5, 0.0, 3.0, 0.2).speed_mps == 0.5


def test_stopped_far_short_releases_latch():
    stop = Stop(max_decel_mps2=1.0, latency_s=0.0, max_creep_dist_m=10.0)
    stop.control(30.0, 5.0, 10.0, 0.2)
    r = stop.control(30.0, 0.0, 25.0, 0.2)  # standing 25 m short: drive on, latch again later
    assert r.speed_mps == 30.0 and not stop.stopping


def test_simulated_stop_with_latency_from_pit_speed():
    stop = Stop(max_decel_mps2=4.9, latency_s=0.02)
    t, err, log = simulate(stop, 24.5, 200.0, 0.3, command=24.5, t_max=60.0)
    assert log[-1].status is StopStatus.FINISHED
    assert abs(err) < 0.5
    latched = [x.decel_mps2 for x in log if x.speed_mps < 24.5 and math.isfinite(x.decel_mps2)]
    assert max(latched[:100]) < 4.9 * 1.1  # constant decel close to the max


def test_speed_tracker():
    tr = SpeedTracker(full_accel_mps2=5.0, full_brake_mps2=10.0, tau_s=1.0)
    assert tr.control(20.0, 20.0) == (0.0, 0.0)
    assert tr.control(22.0, 20.0) == pytest.approx((0.4, 0.0))  # 2 m/s/s of 5
    assert tr.control(15.0, 20.0) == pytest.approx((0.0, 0.5))  # 5 m/s/s of 10
    assert tr.control(0.0, 50.0) == (0.0, 1.0)  # clamped
    assert tr.control(50.0, 0.0) == (1.0, 0.0)
    # feed-forward: asked to decelerate 3 m/s/s at no speed error
    assert tr.control(20.0, 20.0, target_accel_mps2=-3.0) == pytest.approx((0.0, 0.3))
    # resistance feed-forward holds the speed on the throttle
    drag = SpeedTracker(full_accel_mps2=5.0, drag_k_per_m=0.001)
    assert drag.control(30.0, 30.0) == pytest.approx((0.9 / 5.0, 0.0))
    with pytest.raises(ValueError):
        SpeedTracker(tau_s=0.0)
    with pytest.raises(ValueError):
        Stop(max_decel_mps2=0.0)
