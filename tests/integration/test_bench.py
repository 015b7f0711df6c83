"""`boxbox bench`: robot entries, cache keys, and real benches (raced, then from the cache)."""

from __future__ import annotations

import csv
import dataclasses

import pytest

from boxbox.bench.cache import cache_key, python_robot_version, torcs_robot_version
from boxbox.bench.solo import BenchSpec, classify_robot, expand_all, plan
from boxbox.cli.types import CommaList
from boxbox.errors import UsageError
from boxbox.report.tables import fmt_time
from boxbox.torcs import catalog
from helpers import ROBOTS, read_json, run_boxbox


def test_robot_entries_are_told_apart():
    assert classify_robot("bt:2") == ("torcs", ("bt", 2))
    assert classify_robot("olethros:2") == ("torcs", ("olethros", 2))
    assert classify_robot("boxbox") == ("python", "boxbox")
    assert classify_robot("middle") == ("python", "middle")
    assert classify_robot("boxbox.robot.simple:MiddleRobot") == ("python", "boxbox.robot.simple:MiddleRobot")
    spec = f"{ROBOTS / 'faulty.py'}:Plain"
    assert classify_robot(spec) == ("python", spec)
    with pytest.raises(UsageError, match="not a number"):
        classify_robot("bt:x")
    with pytest.raises(UsageError, match="no index 99"):
        classify_robot("bt:99")
    with pytest.raises(UsageError, match="needs an index"):
        classify_robot("inferno")


def test_lists_and_all():
    assert CommaList().convert("a, b,a", None, None) == ["a", "b"]
    assert CommaList(unique=False).convert("bt:1,bt:1", None, None) == ["bt:1", "bt:1"]
    assert expand_all(["all"], list(catalog.tracks())) == list(catalog.tracks())
    assert expand_all(["aalborg"], list(catalog.tracks())) == ["aalborg"]


def test_cache_key_follows_the_race_inputs():
    py = [{"entry": "boxbox", "kind": "python", "version": python_robot_version("boxbox")}]
    bt = [{"entry": "bt:2", "kind": "torcs", "version": torcs_robot_version("bt")}]
    base = cache_key("g-track-1", "car1-trb1", 3, py, None, "fresh")
    assert base == cache_key("g-track-1", "car1-trb1", 3, py, None, "fresh")
    assert base != cache_key("g-track-1", "car1-trb1", 4, py, None, "fresh")  # laps
    assert base != cache_key("michigan", "car1-trb1", 3, py, None, "fresh")
    assert base != cache_key("g-track-1", "car2-trb1", 3, py, None, "fresh")
    assert base != cache_key("g-track-1", "car1-trb1", 3, py, {"mu_scale": 0.7}, "fresh")
    assert base != cache_key("g-track-1", "car1-trb1", 3, py, None, "off")
    assert base != cache_key("g-track-1", "car1-trb1", 3, [{**py[0], "version": "other"}], None, "fresh")
    # a TORCS robot drives its own car: --cars and Python-only settings do not change its race
    torcs = cache_key("g-track-1", "car1-trb1", 3, bt, None, "fresh")
    assert torcs == cache_key("g-track-1", "car2-trb1", 3, bt, {"mu_scale": 0.7}, "off")
    assert torcs != cache_key("g-track-1", "car1-trb1", 2, bt, None, "fresh")
    # a robot file's own contents are part of its version
    assert python_robot_version(f"{ROBOTS / 'faulty.py'}:Plain") != python_robot_version("boxbox")


def test_bad_names_fail_before_racing():
    for spec, message in [(BenchSpec(["g-trak-1"], ["car1-trb1"], ["bt:2"], 1), "did you mean g-track-1"),
                          (BenchSpec(["g-track-1"], ["car1-trb"], ["bt:2"], 1), "unknown car"),
                          (BenchSpec(["g-track-1"], ["car1-trb1"], ["boxbx"], 1), "did you mean boxbox"),
                          (BenchSpec(["g-track-1"], ["car1-trb1"], ["boxbox"], 1, settings={"nope": 1}), "nope"),
                          (BenchSpec(["g-track-1"], ["car1-trb1"], ["bt:2"], 0), "laps")]:
        with pytest.raises(UsageError, match=message):
            plan(spec)


def test_plan_races_each_torcs_robot_by_its_index_in_that_car():
    spec = BenchSpec(["g-track-1"], ["car1-trb1", "car2-trb1", "car1-ow1"], ["boxbox", "bt:2", "inferno:3"], 1)
    mixed, _ = plan(spec)  # bench-field's way: each TORCS robot in its own car
    assert {robot.entry for *_, robot, _ in mixed} == {"boxbox", "bt:2", "inferno:3"}
    rows, _ = plan(dataclasses.replace(spec, match_cars=True))
    entries = [(car, robot.entry) for _, car, robot, _ in rows]
    # bt drives car2-trb1 with index 3 and no car1-ow1 at all (drivers/bt/bt.xml); inferno:1 drives car1-ow1
    assert entries == [("car1-trb1", "boxbox"), ("car1-trb1", "bt:2"), ("car1-trb1", "inferno:3"),
                       ("car2-trb1", "boxbox"), ("car2-trb1", "bt:3"), ("car2-trb1", "inferno:4"),
                       ("car1-ow1", "boxbox"), ("car1-ow1", "inferno:1")]
    keys = {(car, robot.entry): job.key for _, car, robot, job in rows}
    assert keys[("car1-trb1", "boxbox")] != keys[("car2-trb1", "boxbox")]
    together, _ = plan(BenchSpec(["g-track-1", "michigan"], ["car1-trb1"], ["boxbox", "bt:2"], 1, together=True))
    assert len({job.key for *_, job in together}) == 2  # one race per track


def test_bench_cars_races_the_torcs_robots_that_drive_each_car(tmp_path, overlay):
    out = tmp_path / "cars.json"
    done = run_boxbox("bench", "--tracks", "michigan", "--laps", "1", "--cars", "car1-ow1,car1-stock1", "--robots",
                      "boxbox,bt:2,inferno:3", "--no-limit", "--jobs", "1", "--json", str(out), timeout=600)
    assert done.returncode == 0, done.stderr
    rows = read_json(out)["rows"]
    assert [(r["car"], r["robot"]) for r in rows] == [("car1-ow1", "boxbox"), ("car1-ow1", "inferno:1"),
                                                      ("car1-stock1", "boxbox"), ("car1-stock1", "bt:0")]
    for r in rows:  # each in the car of its section, and raced
        assert r["car_driven"] == r["car"] and r["error"] is None and r["laps"] == 1 and r["time"] > 0, r
    assert "bt:0" in done.stdout and "inferno:1" in done.stdout


def test_bench_races_then_reads_the_cache(tmp_path, overlay):
    args = ["bench", "--tracks", "g-track-1,michigan", "--robots", "boxbox,bt:2", "--laps", "1"]
    first_json, second_json, first_csv = tmp_path / "b.json", tmp_path / "b2.json", tmp_path / "b.csv"
    # --no-cache: really race (and refresh the cache), whatever earlier runs left there
    first = run_boxbox(*args, "--no-cache", "--json", str(first_json), "--csv", str(first_csv), timeout=600)
    assert first.returncode == 0, first.stderr
    b = read_json(first_json)
    assert {"laps", "tracks", "cars", "robots", "rows"} <= set(b)
    assert b["laps"] == 1 and b["tracks"] == ["g-track-1", "michigan"] and b["robots"] == ["boxbox", "bt:2"]
    rows = b["rows"]
    assert sorted((r["track"], r["robot"]) for r in rows) == [("g-track-1", "boxbox"), ("g-track-1", "bt:2"),
                                                            ("michigan", "boxbox"), ("michigan", "bt:2")]
    for r in rows:
        assert r["error"] is None and not r["cached"], r
        assert r["time"] > 0 and r["laps"] == 1 and 0 < r["best_lap"] <= r["time"] + 1e-6, r
        assert fmt_time(r["time"]) in first.stdout, (r, first.stdout)  # the table agrees with the JSON
        assert r["limit_lap"] > 0 and r["limit_gap_pct"] > 0, r  # no lap beats the limit (docs/limit.md)
    for track in ("g-track-1", "michigan"):
        gaps = sorted(r["gap_to_best_s"] for r in rows if r["track"] == track)
        assert gaps[0] == 0.0 and gaps[1] >= 0.0
    assert b["raced"] == 4 and b["cached"] == 0
    with open(first_csv) as f:
        assert [(r["track"], r["robot"]) for r in csv.DictReader(f)] == [(r["track"], r["robot"]) for r in rows]

    second = run_boxbox(*args, "--json", str(second_json), timeout=600)
    assert second.returncode == 0, second.stderr
    b2 = read_json(second_json)
    assert b2["raced"] == 0 and b2["cached"] == 4
    assert all(r["cached"] for r in b2["rows"])
    assert [(r["track"], r["robot"], r["time"], r["best_lap"]) for r in b2["rows"]] == \
        [(r["track"], r["robot"], r["time"], r["best_lap"]) for r in rows]
    assert second.stdout.count("cached") >= 4
    for r in b2["rows"]:
        assert fmt_time(r["time"]) in second.stdout
    assert b2["wall_s"] < 0.5 * b["wall_s"]  # nothing raced the second time


def test_sigterm_stops_a_parallel_bench_its_workers_and_their_races(tmp_path, overlay):
    """SIGTERM reaches the bench's own process only (Ctrl-C the whole process group): the bench
    passes it to its workers, whose races stop at once, and no new race starts; exit 130 with one
    line saying the finished races are cached, no process of it left."""
    import signal
    import subprocess
    import time

    import psutil

    from helpers import BOXBOX, ROOT

    proc = subprocess.Popen([*BOXBOX, "bench", "--tracks", "e-track-2,e-track-4,alpine-1,wheel-2", "--laps", "60",
                             "--robots", "boxbox", "--jobs", "2", "--no-cache", "--learning", "fresh"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    seen: dict[int, psutil.Process] = {}

    def torcs_seen() -> bool:
        for child in psutil.Process(proc.pid).children(recursive=True):
            try:
                if child.name() == "torcs-bin":
                    seen.setdefault(child.pid, child)
                    return True
                seen.setdefault(child.pid, child)
            except psutil.Error:  # gone meanwhile
                pass
        return False

    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not torcs_seen():
            time.sleep(0.1)
        assert time.monotonic() < deadline, "no race started"
        time.sleep(1.0)
        stopped = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        took_s = time.monotonic() - stopped
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert took_s < 10.0, took_s  # the four 60-lap races take far longer
    lines = [ln for ln in err.splitlines() if ln.startswith("boxbox: error:")]
    assert len(lines) == 1 and "the bench was stopped" in lines[0], err
    assert "Traceback" not in err
    assert not [p for p in seen.values() if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]


@pytest.mark.parametrize("command", ["bench", "sweep"])
def test_a_slow_robot_gets_the_step_budget_its_error_names(tmp_path, overlay, command):
    """The error of a late robot says 'give more time with --step-budget-ms': the benches take it."""
    robot = f"{ROBOTS / 'faulty.py'}:SleepsOnce"  # one drive step of 1 s
    args = {"bench": ["bench", "--robots", robot, "--tracks", "g-track-1", "--no-limit"],
            "sweep": ["sweep", "--robot", robot, "--tracks", "g-track-1", "--cars", "car1-trb1"]}[command]
    run_boxbox(*args, "--laps", "1", "--no-cache", "--json", str(tmp_path / "late.json"), timeout=300)
    for row in read_json(tmp_path / "late.json")["rows"]:
        assert "did not answer within its step budget of 200 ms" in row["error"], row["error"]
    given = run_boxbox(*args, "--laps", "1", "--no-cache", "--step-budget-ms", "3000", "--json",
                       str(tmp_path / "given.json"), timeout=300)
    assert given.returncode in (0, 1), given.stderr  # (sweep: 1 when a race misses a target: 1 s blind costs damage)
    assert all(r["error"] is None for r in read_json(tmp_path / "given.json")["rows"])  # every race ran to its end
