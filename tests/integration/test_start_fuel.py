"""Real races: the tutorial robot's start fuel from its simulated lap (control/fuel.py)."""

from __future__ import annotations

import math

from helpers import read_json, run_boxbox


def test_no_pit_lane_starts_with_the_race_s_fuel_not_a_full_tank(tmp_path, overlay):
    """e-track-5 has no pit lane: TORCS's default would start car1-trb1 with 94 l; the robot takes
    the race and a lap with margins, and still finishes every lap at its pace (no running dry)."""
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "e-track-5", "--laps", "3", "--learning", "fresh", "--json", str(out),
                      "--quiet")
    assert proc.returncode == 0, proc.stderr
    [me] = read_json(out)["drivers"]
    assert me["laps"] == 3 and me["pit_stops"] == 0
    assert 3.0 < me["start_fuel_l"] < 8.0, me["start_fuel_l"]  # a lap takes about 1 l here
    laps = me["lap_times"]
    assert laps[2] < laps[1] + 1.0, laps


def test_the_bridge_sends_the_engine_s_fuel_constants(tmp_path, overlay):
    """The engine constants the fuel model needs come from the car file (car1-trb1: tickover 900
    rpm, revs maxi 10000 rpm; no brake coefficient, so simuv2's 0.33)."""
    from boxbox.torcs.track_record import recorded_track

    _, car = recorded_track("g-track-1", "car1-trb1")
    rpm = math.pi / 30.0
    assert abs(car.engine_tickover_radps - 900 * rpm) < 0.01
    assert abs(car.engine_revs_max_radps - 10000 * rpm) < 0.01
    assert abs(car.engine_brake_coeff - 0.33) < 1e-6
    assert abs(car.fuel_cons_factor - 1.19) < 1e-6
