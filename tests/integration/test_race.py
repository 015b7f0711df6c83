"""Real races: the CLI finishes races, lists every driver, writes the JSON the docs describe."""

from __future__ import annotations

from helpers import ROBOTS, processes_mentioning, read_json, run_boxbox

DRIVER_KEYS = {"name", "module", "idx", "car", "laps", "time", "best_lap", "lap_times", "damage", "pit_stops",
               "penalty_time", "top_speed"}


def test_two_laps_g_track_1(tmp_path, overlay):
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--json", str(out), "--run-dir",
                      str(tmp_path / "run"), "--quiet")
    assert proc.returncode == 0, proc.stderr
    r = read_json(out)
    assert {"track", "category", "car", "laps", "wall_s", "drivers"} <= set(r)
    assert (r["track"], r["category"], r["car"], r["laps"]) == ("g-track-1", "road", "car1-trb1", 2)
    [me] = r["drivers"]
    assert DRIVER_KEYS <= set(me)
    assert me["module"] == "boxbox" and me["laps"] == 2
    assert len(me["lap_times"]) == 2 and all(30 < t < 200 for t in me["lap_times"])
    assert me["best_lap"] == min(me["lap_times"])
    # the race time TORCS reports covers both laps
    assert abs(me["time"] - sum(me["lap_times"])) < 5.0
    assert "boxbox" in proc.stdout and "g-track-1" in proc.stdout  # the results table
    assert processes_mentioning(str(tmp_path)) == []


def test_against_bt_lists_both(tmp_path, overlay):
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--opponents", "bt:2", "--json", str(out),
                      "--quiet")
    assert proc.returncode == 0, proc.stderr
    r = read_json(out)
    modules = sorted((d["module"], d["idx"]) for d in r["drivers"])
    assert modules == [("boxbox", 0), ("bt", 2)]
    bt = next(d for d in r["drivers"] if d["module"] == "bt")
    assert bt["laps"] >= 1 and bt["time"] > 0 and bt["lap_times"], bt
    assert sorted(d["rank"] for d in r["drivers"]) == [1, 2]


def test_two_python_cars_and_a_user_robot_file(tmp_path, overlay):
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "michigan", "--laps", "1", "--robot", "middle", "--robot",
                      f"{ROBOTS / 'faulty.py'}:Plain", "--json", str(out), "--quiet")
    assert proc.returncode == 0, proc.stderr
    r = read_json(out)
    assert [d["module"] for d in r["drivers"]] == ["boxbox", "boxbox"]
    assert {d["idx"] for d in r["drivers"]} == {0, 1}


def test_fuel_laps_sets_the_starting_fuel(tmp_path, overlay):
    from boxbox.robot.base import RaceOptions
    from boxbox.torcs import launch

    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=["middle"],
                            options=RaceOptions(fuel_laps=2.0), run_dir=tmp_path)
    result = launch.run_race(cfg, overlay)
    assert result.error is None
    from boxbox.robot.base import FUEL_L_PER_M_ESTIMATE
    from trackdata import load

    track, car = load("g-track-1")
    expected = 2.0 * FUEL_L_PER_M_ESTIMATE * car.fuel_cons_factor * track.length_m
    assert abs(result.drivers[0].start_fuel_l - expected) < 0.1, (result.drivers[0].start_fuel_l, expected)
    assert expected < car.initial_fuel_l  # so the default would have failed this test


def test_fuel_offset_adds_to_the_robot_s_choice(tmp_path, overlay):
    """RaceConfig.fuel_offset_l (bench-field --repeats) adds to the fuel the robot chose, and takes
    it off a full tank."""
    from boxbox.robot.base import RaceOptions
    from boxbox.torcs import launch

    starts = []
    for offset, sub in ((0.0, "a"), (0.5, "b")):
        cfg = launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=["middle"],
                                options=RaceOptions(fuel_laps=2.0), run_dir=tmp_path / sub, fuel_offset_l=offset)
        result = launch.run_race(cfg, overlay)
        assert result.error is None
        starts.append(result.drivers[0].start_fuel_l)
    assert abs(starts[1] - starts[0] - 0.5) < 0.01, starts
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=["middle"],
                            options=RaceOptions(fuel_laps=1000.0), run_dir=tmp_path / "c", fuel_offset_l=0.5)
    full = launch.run_race(cfg, overlay)
    assert full.error is None
    from trackdata import load

    tank_l = load("g-track-1")[1].tank_l
    assert abs(full.drivers[0].start_fuel_l - (tank_l - 0.5)) < 0.01, (full.drivers[0].start_fuel_l, tank_l)


def test_track_limits_torcs_uses_the_sides_without_a_penalty(tmp_path, overlay):
    """aalborg has asphalt beside its track: with track_limits=torcs the line goes there (the car's
    centre beyond the track's edge) and TORCS gives no cutting penalty."""
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "aalborg", "--laps", "2", "--set", "track_limits=torcs", "--json", str(out),
                      timeout=120)
    assert proc.returncode == 0, proc.stderr
    d = read_json(out)["drivers"][0]
    assert d["laps"] == 2 and d["penalty_time"] == 0.0
    assert d["off_track_s"] > 1.0  # the centre beyond an edge: on the sides, where the strict line never goes
