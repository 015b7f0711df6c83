"""bench-field on a real race: the robot from last of ten, the anchor race, the report's places."""

from __future__ import annotations

from helpers import read_json, run_boxbox


def test_bench_field_one_lap_and_its_report(tmp_path):
    out = tmp_path / "f.json"
    r = run_boxbox("bench-field", "--tracks", "g-track-1", "--laps", "1", "--no-cache", "--json", str(out),
                   timeout=600)
    assert r.returncode == 0, r.stderr
    f = read_json(out)
    assert f["field"][0] == "inferno:4" and f["anchor"] == "inferno:3" and len(f["field"]) == 9
    robot, anchor = f["rows"]
    assert (robot["role"], anchor["role"]) == ("robot", "anchor")
    for row in (robot, anchor):
        assert row["error"] is None and row["laps"] == 1 and 1 <= row["rank"] <= 10, row
        assert row["field_damage"] >= row["damage"] >= 0
    # the robot's race has every car's laps (its host sees them): lap-1 gain from slot 10
    assert robot["lap1_gain"] is not None and robot["lap1_gain"] == 10 - robot["rank"]
    # no Python car in the anchor race: only a one-lap race gives every car's lap 1 (its race time)
    assert anchor["lap1_gain"] == 10 - anchor["rank"]
    assert "skill level semi-pro" in r.stdout and "inferno:3" in r.stdout

    page = tmp_path / "race.html"
    rep = run_boxbox("report", robot["run_dir"], "--out", str(page), timeout=300)
    assert rep.returncode == 0, rep.stderr
    assert "Places lap by lap" in page.read_text()


def test_bench_field_refuses_a_robot_of_the_field():
    r = run_boxbox("bench-field", "--robot", "bt:2", "--tracks", "g-track-1")
    assert r.returncode == 2 and "already in the field" in r.stderr


def test_bench_field_repeats_race_the_robot_again_with_more_fuel(tmp_path):
    out = tmp_path / "g.json"
    r = run_boxbox("bench-field", "--tracks", "g-track-1", "--laps", "1", "--repeats", "2", "--jobs", "2",
                   "--json", str(out), timeout=600)
    assert r.returncode == 0, r.stderr
    g = read_json(out)
    assert g["labels"] == ["1 #1", "1 #2"]
    first, second = g["runs"]
    assert (first["fuel_offset_l"], second["fuel_offset_l"]) == (0.0, 0.05)
    robot_dirs = [run["rows"][0]["run_dir"] for run in g["runs"]]
    assert robot_dirs[0] != robot_dirs[1]  # two races of the robot
    assert first["rows"][1]["run_dir"] == second["rows"][1]["run_dir"]  # one anchor race, TORCS's alone
    assert "mean" in r.stdout and "1 #2" in r.stdout
