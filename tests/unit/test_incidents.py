"""Incidents found in a race recording (report/incidents.py), on constructed recordings whose
contacts, passes, spins, off-track spells and pit stops are known."""

from __future__ import annotations

import math

import numpy as np

from boxbox.report.incidents import PASS_HOLD_S, describe, find_incidents

DT = 0.1
N = 200  # 20 s at 10 samples a second
T = np.round(np.arange(N) * DT, 3)
META = {"cars": {"0": {"length_m": 4.5}, "1": {"length_m": 4.5}, "2": {"length_m": 4.5}},
        "python": [{"car": 0, "robot_index": 0, "name": "boxbox 1", "robot": "boxbox"}],
        "track": {"pit": {"entry_m": 100.0, "exit_m": 300.0}}}


def car(index: int, x: np.ndarray, place: np.ndarray, **extra) -> dict[str, np.ndarray]:
    """One car's rows along the x axis (y = 0, heading +x, on lap 1, distance = x)."""
    n = len(x)
    cols = {"car": np.full(n, index), "time_s": T[:n].copy(), "x_m": x.astype(float), "y_m": np.zeros(n),
            "yaw_rad": np.zeros(n), "speed_mps": np.full(n, 50.0), "lap": np.ones(n), "place": place.astype(float),
            "dist_m": x.astype(float), "damage": np.zeros(n), "heading_to_track_rad": np.zeros(n),
            "to_middle_m": np.zeros(n), "off_track": np.zeros(n, bool), "in_pit": np.zeros(n, bool),
            "in_pit_lane": np.zeros(n, bool), "out": np.zeros(n, bool)}
    cols.update(extra)
    return cols


def recording(*cars: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {k: np.concatenate([c[k] for c in cars]) for k in cars[0]}


def two_cars_with_a_pass_and_a_contact():
    """Car 1 starts 20 m ahead of car 0 at 50 m/s; car 0 at 55 m/s closes in, touches it at t = 4 s
    (both take damage, 1.5 m apart) and is ahead from t = 6 s on."""
    x0 = 55.0 * T
    x1 = 20.0 + 50.0 * T
    place0 = np.where(T >= 6.0, 1, 2)
    dmg0 = np.where(T >= 4.0, 40.0, 0.0)
    dmg1 = np.where(T >= 4.0, 25.0, 0.0) + np.where(T >= 4.3, 5.0, 0.0)  # two hits 0.3 s apart: one incident
    return car(0, x0, place0, damage=dmg0), car(1, x1, 3 - place0, damage=dmg1)


def test_a_known_contact_names_both_cars_with_each_ones_damage():
    a, b = two_cars_with_a_pass_and_a_contact()
    found = find_incidents(recording(a, b), META)
    contacts = [i for i in found if i.kind == "contact"]
    assert [(i.cars, i.damage) for i in contacts] == [((0, 1), 40), ((1, 0), 30)]
    assert all(i.time_s == 4.0 and i.lap == 1 for i in contacts)
    assert contacts[0].dist_m == 55.0 * 4.0  # the place on the track of the car that took it
    assert "car 1 within a car's length" in describe(contacts[0], {0: "boxbox 1"})


def test_damage_with_no_car_near_is_not_a_contact():
    a, b = two_cars_with_a_pass_and_a_contact()
    b["x_m"] = b["x_m"] + 100.0  # far ahead now: car 0's hit was a barrier
    b["dist_m"] = b["x_m"]
    kinds = {(i.kind, i.cars) for i in find_incidents(recording(a, b), META) if i.damage}
    assert kinds == {("damage", (0,)), ("damage", (1,))}


def test_a_known_pass_is_found_once_with_the_car_now_ahead_first():
    a, b = two_cars_with_a_pass_and_a_contact()
    passes = [i for i in find_incidents(recording(a, b), META) if i.kind == "pass"]
    assert [(i.cars, i.time_s, i.detail) for i in passes] == [((0, 1), 6.0, "for place 1")]
    assert describe(passes[0], {0: "boxbox 1", 1: "bt 3"}) == "boxbox 1 passed bt 3 for place 1"


def test_places_swapping_back_within_the_hold_time_are_no_pass():
    a, b = two_cars_with_a_pass_and_a_contact()
    flicker = (T >= 6.0) & (T < 6.0 + PASS_HOLD_S - 0.5)  # ahead for 1.5 s only, then behind again
    a["place"] = np.where(flicker, 1.0, 2.0)
    b["place"] = 3.0 - a["place"]
    assert not [i for i in find_incidents(recording(a, b), META) if i.kind == "pass"]


def test_a_car_out_of_the_race_is_not_passed():
    a, b = two_cars_with_a_pass_and_a_contact()
    b["out"] = T >= 5.0
    assert not [i for i in find_incidents(recording(a, b), META) if i.kind == "pass"]


def test_off_track_spells_and_spins_with_their_lengths():
    off = (T >= 3.0) & (T < 4.0) | (T >= 4.5) & (T < 5.0)  # 0.5 s back on: one spell of 2 s
    heading = np.where((T >= 10.0) & (T < 12.0), math.radians(170.0), 0.0)
    c = car(2, 40.0 * T, np.ones(N), off_track=off, to_middle_m=np.where(off, -7.0, 0.0), heading_to_track_rad=heading)
    found = find_incidents(recording(c), META)
    [spell] = [i for i in found if i.kind == "off-track"]
    assert (spell.time_s, round(spell.duration_s, 2), spell.detail) == (3.0, 1.9, "off the right edge for 1.9 s")
    [spin] = [i for i in found if i.kind == "spin"]
    assert spin.time_s == 10.0 and spin.cars == (2,) and "170 deg" in spin.detail


def test_pit_stops_held_by_the_race_engine_and_a_python_cars_pause_in_its_box():
    held = car(1, np.full(N, 200.0), np.full(N, 2.0), in_pit=(T >= 5.0) & (T < 15.0), in_pit_lane=np.ones(N, bool))
    # the Python car's own drive steps pause 8 s in the pit lane (TORCS holds it: no drive step)
    keep = (T < 5.0) | (T >= 13.0)
    own = car(0, np.where(T < 5.0, 150.0 + T, 160.0), np.ones(N), in_pit_lane=np.ones(N, bool))
    own = {k: v[keep] for k, v in own.items()}
    stops = [i for i in find_incidents(recording(held, own), META) if i.kind == "pit-stop"]
    assert [(i.cars, round(i.time_s, 1), round(i.duration_s, 1)) for i in stops] == [((0,), 4.9, 8.1), ((1,), 5.0, 9.9)]


def test_the_result_adds_the_fault_and_the_missed_stops():
    a, b = two_cars_with_a_pass_and_a_contact()
    result = {"error": "robot 'x' failed", "drivers": [
        {"name": "boxbox 1", "module": "boxbox", "idx": 0, "car_index": 0,
         "missed_pit_stops": [{"lap": 1, "reason": "passed its box", "detail": "it drove past its box"}]}]}
    fault = {"robot_index": 0, "sim_time_s": 12.0, "message": "ValueError: deliberate (in drive)\nmore"}
    found = find_incidents(recording(a, b), META, result, fault)
    [f] = [i for i in found if i.kind == "fault"]
    assert (f.cars, f.time_s, f.detail, f.dist_m) == ((0,), 12.0, "ValueError: deliberate (in drive)", 55.0 * 12.0)
    [m] = [i for i in found if i.kind == "missed-stop"]
    assert m.cars == (0,) and m.dist_m >= 100.0 and m.time_s == T[np.argmax(55.0 * T >= 100.0)]
    stopped = find_incidents(recording(a, b), META, {"error": "the race was interrupted (Ctrl-C)"})
    assert [(i.kind, i.time_s) for i in stopped if i.kind == "stopped"] == [("stopped", T[-1])]


def test_incidents_come_in_time_order_and_an_empty_recording_has_none():
    a, b = two_cars_with_a_pass_and_a_contact()
    found = find_incidents(recording(a, b), META)
    assert [i.time_s for i in found] == sorted(i.time_s for i in found)
    assert find_incidents({"time_s": np.zeros(0)}, META) == []
