"""The damage incidents of the race report, from plain telemetry arrays."""

import numpy as np
import pytest

from boxbox.report.damage import DamageRise, damage_by_lap, damage_incidents, damage_rises, moved_text, nearest_text


def _telemetry(damage: list[float], step_s: float = 0.02) -> dict[str, np.ndarray]:
    n = len(damage)
    t = np.arange(n) * step_s
    return {"time_s": t, "lap": (t // 1.0).astype(int) + 1, "dist_m": t * 50.0, "speed_mps": np.full(n, 50.0),
            "damage": np.asarray(damage, dtype=float), "x_m": t, "y_m": -t}


def test_hits_less_than_a_second_apart_are_one_incident_and_a_repair_is_none():
    dmg = [0.0] * 10 + [100.0] * 20 + [150.0] * 100 + [400.0] * 10 + [0.0] * 60 + [30.0] * 5
    inc = damage_incidents(_telemetry(dmg))
    assert [(i.damage, i.hits) for i in inc] == [(150, 2), (250, 1), (30, 1)]
    assert inc[0].time_s == pytest.approx(0.2) and inc[0].dist_m == pytest.approx(10.0)
    assert inc[1].lap == 3  # 2.6 s: the third lap of the fake one-second laps
    assert damage_by_lap(inc) == {1: 150, 3: 250, 5: 30}


def test_no_damage_no_incident_and_bad_input_is_refused():
    assert damage_incidents(_telemetry([0.0] * 50)) == []
    with pytest.raises(ValueError, match="merge_s"):
        damage_incidents(_telemetry([0.0, 1.0]), merge_s=float("nan"))
    c = _telemetry([0.0, 1.0])
    del c["x_m"]
    with pytest.raises(ValueError, match="x_m"):
        damage_incidents(c)


def test_the_nearest_car_at_the_first_hit_is_named():
    """The near_* columns at an incident's first hit, in words; none known (a file from before the
    columns) or too far is said so."""
    c = _telemetry([0.0] * 5 + [80.0] * 5 + [0.0] * 200 + [120.0] * 5)
    n = len(c["time_s"])
    assert [i.near_car for i in damage_incidents(c)] == [-1, -1]  # no near columns: none known
    c["near_car"] = np.where(np.arange(n) < 100, 4, 6)
    c["near_ahead_m"] = np.where(np.arange(n) < 100, 3.14, -40.0)
    c["near_left_m"] = np.where(np.arange(n) < 100, -1.75, 2.0)
    first, second = damage_incidents(c)
    assert (first.near_car, first.near_ahead_m, first.near_left_m) == (4, 3.14, -1.75)
    names = {4: "bt 2 (bt:2)"}
    assert nearest_text(first, names) == "bt 2 (bt:2): 3.1 m ahead, 1.8 m right"
    assert nearest_text(second, names) == "none within 15 m"  # 40 m behind
    assert nearest_text(second, names, near_m=50.0) == "car 6: 40.0 m behind, 2.0 m left"


def test_who_moved_in_before_the_hit():
    """Over the 0.5 s before the first hit we moved 1 m left towards a car on our left, which moved
    0.25 m right, towards us: we 1.0 m, it 0.2 m (rounded to even). Another car nearest at the start of
    the window, or none near: not known."""
    c = _telemetry([0.0] * 60 + [50.0] * 5)
    n = len(c["time_s"])
    c["to_middle_m"] = np.where(np.arange(n) < 40, 0.0, 1.0)  # the move: at 0.8 s, inside the window
    c["near_car"] = np.full(n, 3)
    c["near_ahead_m"] = np.full(n, 1.0)
    c["near_left_m"] = np.where(np.arange(n) < 40, 3.0, 1.75)  # it: 3.0 -> 2.75 across the road
    (i,) = damage_incidents(c)
    assert i.we_moved_in_m == 1.0 and i.it_moved_in_m == 0.25
    assert moved_text(i) == "we 1.0 m, it 0.2 m"
    c["near_car"] = np.where(np.arange(n) < 40, 5, 3)  # car 5 was nearest at the window's start
    (i,) = damage_incidents(c)
    assert np.isnan(i.we_moved_in_m) and moved_text(i) == ""


def test_damage_rises_merge_close_rises_and_skip_repairs():
    t = np.arange(10.0)
    d = np.array([0, 10, 10, 30, 30, 0, 0, 5, 5, 5], dtype=float)  # 1 and 3 s: two; 5: a repair; 7: one
    assert damage_rises(t, d, merge_s=1.0) == [DamageRise(1, 1, 1, 10), DamageRise(3, 3, 1, 20),
                                               DamageRise(7, 7, 1, 5)]
    assert damage_rises(t, d, merge_s=2.0) == [DamageRise(1, 3, 2, 30), DamageRise(7, 7, 1, 5)]


def test_damage_rises_skip_unknown_rows_and_merge_a_gap_of_merge_s_read_as_a_hair_more():
    # a car not seen (NaN) in rows 2-3: the rise counts from row 1; no hit where it was not seen
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 1.4000000000000004])
    d = np.array([0.0, 0.0, np.nan, np.nan, 40.0, 50.0])
    assert damage_rises(t, d) == [DamageRise(4, 5, 2, 50)]
    assert damage_rises(t, np.nan_to_num(d, nan=0.0)) == [DamageRise(4, 5, 2, 50)]
