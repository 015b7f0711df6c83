"""report/contacts.py: each damage incident put down to a cause, on plain numbers."""

from __future__ import annotations

import numpy as np
import pytest

from boxbox.report.contacts import (
    AFTER,
    AHEAD,
    ALONE,
    BEHIND_HELD,
    BEHIND_MOVED,
    SIDE_IT,
    SIDE_NEITHER,
    SIDE_WE,
    Contact,
    RaceContacts,
    ahead_rows,
    find_contacts,
    usual_lines,
)
from boxbox.report.incidents import Frames

TRACK_M = 300.0
RADIUS_M = TRACK_M / (2.0 * np.pi)
T = np.round(np.arange(0.0, 60.0, 0.1), 1)  # 6 laps at 30 m/s: every 5 m of track seen six times
LENGTHS = {0: 4.5, 1: 4.5, 2: 4.5}


def car(raced: np.ndarray, mid: np.ndarray | float = 0.0, damage: np.ndarray | float = 0.0) -> dict:
    raced = np.asarray(raced, dtype=float)
    return {"raced": raced, "mid": np.broadcast_to(np.asarray(mid, dtype=float), raced.shape).copy(),
            "damage": np.broadcast_to(np.asarray(damage, dtype=float), raced.shape).copy(),
            "speed": np.gradient(raced, T)}


def columns(cars: dict[int, dict]) -> dict[str, np.ndarray]:
    """A recording's columns of these cars (TORCS index -> car()) at the samples T."""
    cols: dict[str, list] = {k: [] for k in ("car", "time_s", "lap", "dist_m", "dist_raced_m", "to_middle_m",
                                             "speed_mps", "damage", "x_m", "y_m", "yaw_rad")}
    for index, c in cars.items():
        # a round track, driven anticlockwise: the middle line's radius RADIUS_M, the left inwards
        angle = c["raced"] / RADIUS_M
        cols["x_m"] += list((RADIUS_M - c["mid"]) * np.cos(angle))
        cols["y_m"] += list((RADIUS_M - c["mid"]) * np.sin(angle))
        cols["yaw_rad"] += list(angle + np.pi / 2.0)
        cols["car"] += [index] * len(T)
        cols["time_s"] += list(T)
        cols["lap"] += list(c["raced"] // TRACK_M + 1)
        cols["dist_m"] += list(c["raced"] % TRACK_M)
        cols["dist_raced_m"] += list(c["raced"])
        cols["to_middle_m"] += list(c["mid"])
        cols["speed_mps"] += list(c["speed"])
        cols["damage"] += list(c["damage"])
    return {k: np.asarray(v, dtype=float) for k, v in cols.items()}


def frames(cars: dict[int, dict]) -> Frames:
    return Frames.from_columns(columns(cars))


def hit_at(t_s: float, points: float = 100.0) -> np.ndarray:
    return np.where(T >= t_s, points, 0.0)


def contacts(cars: dict[int, dict], ours: int = 0) -> list[Contact]:
    c = cars[ours]
    return find_contacts(frames(cars), ours, T, c["damage"], TRACK_M, LENGTHS)


def test_usual_line_is_the_median_over_laps():
    mid = np.where((T > 30.0) & (T < 31.0), 3.0, 1.0)  # one lap off the line for a second
    lines = usual_lines(frames({0: car(30.0 * T, mid)}), TRACK_M)
    assert lines.shape == (60, 1)
    assert np.allclose(lines[:, 0], 1.0)


def test_hit_from_behind_on_our_line():
    us = car(30.0 * T, 0.0, hit_at(40.0))
    # it comes from 20 m behind at 32 m/s, 0.2 m to our left, reaching our tail at 40 s
    it = car(30.0 * T - 20.0 + np.clip(T - 30.0, 0.0, None) * 1.55, 0.2, hit_at(40.0, 50.0))
    [c] = contacts({0: us, 1: it})
    assert (c.kind, c.other, c.cause, c.lap) == ("behind", 1, BEHIND_HELD, 5)
    assert c.closing_mps == pytest.approx(-1.55, abs=0.01)
    assert c.ahead_m == pytest.approx(-4.5, abs=0.2)
    assert c.other_damage == 50
    assert c.lapping == ""


def test_hit_from_behind_braking():
    raced = np.where(T < 39.0, 30.0 * T, 30.0 * 39.0 + 30.0 * (T - 39.0) - 4.0 * (T - 39.0) ** 2)  # 8 m/s2
    us = car(raced, 0.0, hit_at(40.0))
    it = car(30.0 * T - 8.5, 0.0, hit_at(40.0))  # 8.5 m behind at 30 m/s: at our tail after a second of it
    [c] = contacts({0: us, 1: it})
    assert (c.kind, c.cause) == ("behind", BEHIND_HELD)
    assert c.we_slowed_mps == pytest.approx(8.0, abs=0.5)


def test_hit_from_behind_after_moving_across_its_nose():
    mid = -2.0 * np.clip(T - 39.0, 0.0, 1.0)  # we move 2 m right in the last second, onto it
    us = car(30.0 * T, mid, hit_at(40.0))
    it = car(30.0 * T - 4.5, -2.0, hit_at(40.0))
    assert contacts({0: us, 1: it})[0].cause == BEHIND_MOVED


def test_we_hit_the_car_ahead():
    us = car(30.0 * T - 20.0 + np.clip(T - 30.0, 0.0, None) * 1.55, 0.0, hit_at(40.0))
    it = car(30.0 * T, 0.5)
    [c] = contacts({0: us, 1: it})
    assert (c.kind, c.cause) == ("ahead", AHEAD)
    assert c.closing_mps == pytest.approx(1.55, abs=0.01)


def test_how_we_hit_the_car_ahead_headway_turning_and_its_slide():
    """1 s before the hit the bumper gap is 20 - 1.55 * 9 - 4.5 = 1.55 m at 31.55 m/s; the round
    track turns us at 30^2 / 47.7 m = 19 m/s^2; a heading 0.3 rad off the track's from 39.2 s on is a
    slide of 0.8 s at the hit (40 s), which the table counts as begun early."""
    us = car(30.0 * T - 20.0 + np.clip(T - 30.0, 0.0, None) * 1.55, 0.0, hit_at(40.0))
    it = car(30.0 * T, 0.5)
    cols = columns({0: us, 1: it})
    cols["heading_to_track_rad"] = np.where((cols["car"] == 1) & (cols["time_s"] >= 39.2), 0.3, 0.0)
    [c] = find_contacts(Frames.from_columns(cols), 0, T, us["damage"], TRACK_M, LENGTHS)
    assert c.headway_s == pytest.approx(1.55 / 31.55, abs=0.005)
    assert c.turning_mps2 == pytest.approx(31.55 ** 2 / RADIUS_M, rel=0.03)
    assert c.it_slid_s == pytest.approx(0.8, abs=0.11)
    rows = ahead_rows([RaceContacts("run", "round", 0, c.damage, [c])])
    assert [r["incidents"] for r in rows] == [1, 0, 0, 0]
    calm = contacts({0: us, 1: it})[0]  # no heading recorded: not known to slide, so in a turn
    assert [r["incidents"] for r in ahead_rows([RaceContacts("run", "round", 0, calm.damage, [calm])])] == [0, 0, 1, 0]


@pytest.mark.parametrize(("ours", "its", "cause"), [
    (0.0, 3.0 - np.clip(T - 39.0, 0.0, 1.0) * 1.2, SIDE_IT),   # it moves 1.2 m in towards us
    (np.clip(T - 39.0, 0.0, 1.0) * 1.2, 3.0, SIDE_WE),         # we move 1.2 m towards it
    (0.0, 1.8, SIDE_NEITHER),                                  # both on their lines, 1.8 m apart
])
def test_side_by_side_who_changed_line(ours, its, cause):
    us = car(30.0 * T, ours, hit_at(40.0))
    it = car(30.0 * T + 1.0, its, hit_at(40.0, 20.0))
    [c] = contacts({0: us, 1: it})
    assert (c.kind, c.cause) == ("side", cause)


def test_alone_and_just_after_a_contact():
    # an inside hit at 40 s, a wall at 42 s (its aftermath), another wall at 50 s
    dmg = hit_at(40.0) + hit_at(42.0, 300.0) + hit_at(50.0, 7.0)
    us = car(30.0 * T, 0.0, dmg)
    it = car(np.where(T <= 40.0, 30.0 * T - 4.5, 30.0 * 40.0 - 4.5 - 20.0 * (T - 40.0) ** 2), 0.0)
    found = contacts({0: us, 1: it})
    assert [c.cause for c in found] == [BEHIND_HELD, AFTER, ALONE]
    assert found[2].nearest_m > 20.0
    assert found[1].after == BEHIND_HELD and found[1].root_cause == BEHIND_HELD
    assert [c.damage for c in found] == [100, 300, 7]


def test_lapping_and_the_car_that_took_damage_too():
    us = car(30.0 * T, 0.0, hit_at(40.0))
    lapped = car(30.0 * T - TRACK_M + 3.0, 1.0, hit_at(40.0, 10.0))  # a lap down, 3 m ahead on the road
    bystander = car(30.0 * T + 0.5, -2.0)  # nearer, untouched
    [c] = contacts({0: us, 1: lapped, 2: bystander})
    assert (c.other, c.lapping) == (1, "we lap it")
    assert c.ahead_m == pytest.approx(3.0, abs=0.1)


def test_no_damage_no_contacts_and_car_not_recorded():
    us = car(30.0 * T)
    assert contacts({0: us, 1: car(30.0 * T - 4.5)}) == []
    assert find_contacts(frames({1: us}), 5, T, hit_at(3.0), TRACK_M, LENGTHS) == []


def write_recording(run_dir, cars: dict[int, dict]) -> None:
    """RUN_DIR/recording.parquet of these cars (car 0 the Python car), as the host writes it."""
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    meta = {"python": [{"car": 0, "robot_index": 0}], "cars": {str(k): {"length_m": 4.5} for k in cars},
            "track": {"length_m": TRACK_M, "name": "oval"}}
    table = pa.table(columns(cars))
    run_dir.mkdir()
    pq.write_table(table.replace_schema_metadata({b"boxbox": json.dumps(meta).encode()}), run_dir / "recording.parquet")


def test_contacts_command_prints_the_causes_and_writes_json(tmp_path):
    import json

    from click.testing import CliRunner

    from boxbox.cli import main_group

    us = car(30.0 * T, 0.0, hit_at(40.0))
    it = car(30.0 * T - 20.0 + np.clip(T - 30.0, 0.0, None) * 1.55, 0.2, hit_at(40.0, 50.0))
    write_recording(tmp_path / "race", {0: us, 1: it})
    bench = tmp_path / "bench.json"
    bench.write_text(json.dumps({"runs": [{"rows": [{"role": "robot", "run_dir": str(tmp_path / "race")},
                                                    {"role": "anchor", "run_dir": str(tmp_path / "nowhere")}]}]}))
    result = CliRunner().invoke(main_group, ["contacts", "--bench", str(bench), "--each", "--json",
                                             str(tmp_path / "out.json")], terminal_width=200)
    assert result.exit_code == 0, result.output
    assert "hit from behind, our line held" in result.output and "1/1" in result.output
    assert "we hit the car ahead: how" in result.output
    [race] = json.loads((tmp_path / "out.json").read_text())
    assert [c["cause"] for c in race["contacts"]] == [BEHIND_HELD] and race["damage"] == 100
    assert race["contacts"][0]["headway_s"] < 0.0  # the car behind us: a gap behind, over our speed


def test_contacts_command_needs_run_dirs_with_a_recording(tmp_path):
    from click.testing import CliRunner

    from boxbox.cli import main_group
    from boxbox.errors import UsageError

    result = CliRunner().invoke(main_group, ["contacts"])
    assert isinstance(result.exception, UsageError) and "give run dirs" in str(result.exception)
    (tmp_path / "empty").mkdir()
    result = CliRunner().invoke(main_group, ["contacts", str(tmp_path / "empty")])
    assert isinstance(result.exception, UsageError) and "no recording.parquet" in str(result.exception)


def test_the_report_the_recording_and_the_contacts_merge_damage_alike():
    """One rule (report/damage.py's damage_rises): the race report's incidents (one car's
    telemetry), the recording's (every car) and the contacts count the same incidents."""
    from boxbox.report.damage import damage_incidents as report_incidents
    from boxbox.report.incidents import damage_incidents as recording_incidents

    dmg = hit_at(3.0, 10.0) + hit_at(3.5, 20.0) + hit_at(4.5, 1.0) + hit_at(12.0, 5.0)
    cars = {0: car(30.0 * T, damage=dmg)}
    cols = columns(cars)
    report = [(i.time_s, i.damage) for i in report_incidents({k: v for k, v in cols.items() if k != "car"})]
    recording = [(i.time_s, i.damage) for i in recording_incidents(frames(cars), LENGTHS)]
    found = [(c.time_s, c.damage) for c in contacts(cars)]
    assert report == recording == found == [(3.0, 31), (12.0, 5)]
