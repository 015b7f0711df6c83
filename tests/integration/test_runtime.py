"""The runtime around a robot, in real races (issue 14's cases 1, 2, 8, 10, 11 and 12; issue 13's
comforts): relative run dirs, a full disk, a robot that exits, a damaged bridge build, robot
children in sessions of their own, the time model, robot output, missed pit stops.
Cases 3 and 9 (signals) are in test_torcs_faults.py."""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import time
from pathlib import Path

import pytest

from boxbox.cache import cache_dir
from boxbox.robot.base import RaceOptions
from boxbox.torcs import launch
from boxbox.torcs.paths import system_torcs
from boxbox.torcs.setup import bridge_fingerprint, bridge_problem
from boxbox.torcs.timing import STEP_S
from helpers import BOXBOX, ROBOTS, processes_mentioning, read_json, run_boxbox

HOSTILE = ROBOTS / "hostile.py"


def error_line(proc) -> str:
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]
    assert len(lines) == 1, proc.stderr
    return lines[0]


def leftovers(run_dir: Path) -> list[str]:
    """Temporary files a race must not leave: telemetry spool, half-written files."""
    return sorted(p.name for p in [*run_dir.glob(".telemetry-*"), *run_dir.glob(".*.tmp*")])


def test_a_relative_run_dir_works(tmp_path, overlay):
    """Case 1: `--run-dir out/r1` is the caller's, not TORCS's working directory's."""
    env = dict(os.environ, COLUMNS="200")
    proc = subprocess.run([*BOXBOX, "race", "--track", "g-track-1", "--laps", "1", "--robot", "middle", "--quiet",
                           "--run-dir", "out/r1", "--json", "r.json"], capture_output=True, text=True, timeout=60,
                          env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    r = read_json(tmp_path / "r.json")
    assert r["run_dir"] == str(tmp_path / "out" / "r1") and r["drivers"][0]["laps"] == 1
    assert read_json(tmp_path / "out" / "r1" / "result.json") == r


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MB tmpfs (the tests run as root): a full disk under the run dir."""
    mount = tmp_path / "disk"
    mount.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)], check=True)
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def test_a_full_disk_keeps_the_result_and_says_where(small_disk, tmp_path, overlay):
    """Case 2: the telemetry spool fills the disk; the car's telemetry is given up (its spool
    removed), the result is written to the run dir and the JSON, and one line says so."""
    run_dir = small_disk / "r1"
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--robot", "middle", "--run-dir", str(run_dir),
                      "--json", str(out), "--quiet", timeout=60)
    assert proc.returncode == 4, proc.stderr
    line = error_line(proc)
    assert "the telemetry was not kept" in line and "No space left on device" in line, line
    assert f"the result is in {run_dir / 'result.json'} and {out}" in line, line
    assert "Traceback" not in proc.stderr
    r = read_json(out)
    [me] = r["drivers"]
    assert me["laps"] == 2 and me["lap_times"] and me["rank"] == 1
    assert read_json(run_dir / "result.json")["drivers"] == r["drivers"]
    assert not (run_dir / "telemetry.parquet").exists()
    assert leftovers(run_dir) == []
    assert processes_mentioning(str(run_dir)) == []


@pytest.mark.parametrize("robot,cause", [
    ("ExitsInDrive", "the robot called sys.exit() (in drive, step"),
    ("ExitsInOnTrack", "the robot called sys.exit(3) (in on_track)"),
])
@pytest.mark.parametrize("host", ["fork", "exec"])
def test_sys_exit_in_a_robot_is_reported_at_once(robot, cause, host, tmp_path, overlay):
    """Case 8: SystemExit in a robot call is the robot's fault, said as such, without waiting for
    the step budget (10 s here) to run out."""
    run_dir = tmp_path / "run"
    started = time.monotonic()
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", f"{HOSTILE}:{robot}", "--quiet",
                      "--step-budget-ms", "10000", "--run-dir", str(run_dir),
                      env={"BOXBOX_HOST_EXEC": "1"} if host == "exec" else {})
    assert time.monotonic() - started < 8
    assert proc.returncode == 4, proc.stderr
    line = error_line(proc)
    assert f"robot '{HOSTILE}:{robot}'" in line and cause in line, line
    assert f"(run dir {run_dir})" in line
    assert "SystemExit" in proc.stderr  # the robot's traceback
    assert processes_mentioning(str(run_dir)) == []


@pytest.fixture
def own_bridge_cache(tmp_path, overlay) -> Path:
    """A cache of its own with a real copy of the bridge build (the shared one is never damaged)."""
    cache = tmp_path / "cache"
    cache.mkdir()
    for name in ("torcs-headers", "racing-lines", "pit-paths"):
        (cache_dir() / name).mkdir(exist_ok=True)
        (cache / name).symlink_to(cache_dir() / name)
    shutil.copytree(cache_dir() / "bridge" / bridge_fingerprint(), cache / "bridge" / bridge_fingerprint())
    assert run_boxbox("setup", env={"BOXBOX_CACHE": str(cache)}).returncode == 0
    return cache


def test_a_damaged_bridge_build_is_found_and_rebuilt(own_bridge_cache, tmp_path):
    """Case 10: a truncated boxbox.so in the cache: `doctor` says so, and the next race rebuilds
    it (saying so) before racing."""
    env = {"BOXBOX_CACHE": str(own_bridge_cache)}
    module = own_bridge_cache / "bridge" / bridge_fingerprint() / "boxbox.so"
    module.write_bytes(module.read_bytes()[: module.stat().st_size // 2])
    doctor = run_boxbox("doctor", env=env)
    assert doctor.returncode == 1 and "is damaged" in doctor.stdout, doctor.stdout
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", "middle", "--quiet",
                      "--run-dir", str(tmp_path / "run"), env=env)
    assert proc.returncode == 0, proc.stderr
    assert f"the bridge module {module} is damaged" in proc.stderr and "rebuilding it" in proc.stderr
    assert run_boxbox("doctor", env=env).returncode == 0
    # a file that is not an ELF shared object at all, with a matching hash, is refused too
    module.write_bytes(b"#!/bin/sh\n")
    (module.parent / "boxbox.so.sha256").write_text(hashlib.sha256(b"#!/bin/sh\n").hexdigest())
    assert bridge_problem(module, system_torcs()) == "is not a shared library: no ELF header"


def test_robot_children_in_their_own_sessions_end_with_the_race(tmp_path, overlay):
    """Case 11: a child started with setsid, and one that double-forks away, are swept at the end."""
    run_dir = tmp_path / "run"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", f"{HOSTILE}:StartsSessionChild",
                      "--quiet", "--run-dir", str(run_dir))
    assert proc.returncode == 0, proc.stderr
    assert processes_mentioning(str(run_dir)) == []


def test_daemons_a_robot_double_forks_end_with_the_race(tmp_path, overlay):
    """A daemon double-forked from the robot (fork, setsid, fork) with no exec, or exec'd with an
    empty environment, carries no mark of the race: it outlived the race (parent PID 1) until the
    forked host became the child subreaper of what its robot starts, and ends it."""
    run_dir = tmp_path / "run"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", f"{HOSTILE}:StartsDaemons",
                      "--quiet", "--no-telemetry", "--run-dir", str(run_dir))
    assert proc.returncode == 0, proc.stderr
    time.sleep(0.5)
    assert processes_mentioning(str(run_dir)) == []  # the Python daemon has the launcher's command line
    assert processes_mentioning("300.25") == []  # the exec'd one


def test_a_robot_past_its_memory_limit_is_one_clear_fault(tmp_path, overlay):
    """3 GiB mapped with --memory-limit 1: a MemoryError in the robot (RLIMIT_AS on the host), said
    as the robot's excess, instead of the machine's memory running out and the OOM killer's SIGKILL."""
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", f"{HOSTILE}:TakesTooMuchMemory",
                      "--memory-limit", "1", "--quiet", "--no-telemetry", "--run-dir", str(tmp_path / "run"))
    assert proc.returncode == 4, proc.stderr
    assert "failed: the robot used more than 1 GiB of memory (in drive, step" in error_line(proc)
    assert "give it more with --memory-limit" in error_line(proc)


def test_a_robot_within_its_step_budget_is_never_stopped_for_being_slow(tmp_path, overlay):
    """Case 12: 4 ms of every step with a 50 ms budget, a whole race: the wall limit is derived
    from the budget, so it cannot cut the race short. (A 20 ms budget was too close on a busy
    virtual machine: one step of the 2,000 took over 20 ms there once.)"""
    cfg = launch.RaceConfig(track="michigan", category="oval", laps=1, robots=[f"{HOSTILE}:NearItsBudget"],
                            run_dir=tmp_path / "run", step_budget_ms=50, setup_budget_ms=5000, telemetry=False)
    result = launch.run_race(cfg, overlay)
    assert result.error is None and result.drivers[0].laps == 1
    limits = result.limits
    steps = limits["sim_limit_s"] / STEP_S
    assert limits["wall_limit_s"] >= steps * 0.050 > result.wall_s
    assert result.wall_s > result.drivers[0].time / STEP_S * 0.004  # it did take 4 ms a step


def test_the_wall_limit_can_be_set(tmp_path, overlay):
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=2, robots=[f"{ROBOTS / 'faulty.py'}:Slow"],
                            run_dir=tmp_path / "run", wall_limit_s=1.5)
    started = time.monotonic()
    result = launch.run_race(cfg, overlay)
    assert time.monotonic() - started < 10
    assert result.error.startswith("the race did not finish within its wall limit of 1.5 s"), result.error
    assert processes_mentioning(str(tmp_path)) == []


def test_torcs_that_stops_calling_the_robots_is_stopped_after_the_stall_limit(tmp_path, overlay):
    """TORCS stopped mid-race (here SIGSTOP, seen as torcs-bin spinning at full CPU): the host's
    heartbeat stops, and the race ends after the stall limit (set-up budget + step budget + 6 s),
    not the wall limit (hours with the default budgets), with nothing left running."""
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=[f"{HOSTILE}:StopsTorcs"],
                            run_dir=tmp_path / "run", step_budget_ms=50, setup_budget_ms=1000, telemetry=False)
    started = time.monotonic()
    result = launch.run_race(cfg, overlay)
    assert time.monotonic() - started < 25
    assert re.match(r"TORCS stopped calling the robots \(last heard of at -?[\d.]+ s of simulated time\) and did "
                    r"not resume for 7 s; it was stopped", result.error), result.error
    if shutil.which("gdb"):  # where TORCS was: stopped while our bridge waited for the host's answer
        assert "inside boxbox's bridge (bb_recv in boxbox.so); torcs-stack.txt" in result.error, result.error
    assert result.limits["wall_limit_s"] > 100
    assert processes_mentioning(str(tmp_path)) == []


def test_a_crawling_car_is_stopped_by_the_simulated_time_limit(tmp_path, overlay):
    """Case 12's other half: a car at walking pace would need 1000 s of simulated time for a lap of
    g-track-1; with the slowest average set to 10 m/s the race stops at 206 s (laps x length at
    10 m/s), in about a second of wall time, with what was raced kept."""
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=[f"{HOSTILE}:Crawls"],
                            run_dir=tmp_path / "run", min_speed_mps=10.0, telemetry=False)
    started = time.monotonic()
    result = launch.run_race(cfg, overlay)
    assert time.monotonic() - started < 20
    assert result.error.startswith("the race did not finish within 206 s of simulated time "
                                   "(1 laps of 2058 m at 10 m/s on average); it was stopped"), result.error
    assert result.limits["sim_limit_s"] == 205.8
    [me] = result.drivers
    assert me.laps == 0 and me.rank == 0 and me.stuck_s is not None


def test_a_car_that_never_moves_has_no_laps_and_no_place(tmp_path, overlay):
    """Issue 13: TORCS ends a race whose only car never moves (after about 280 s of simulated time);
    its result is 0 laps and no place, not '-1 of 1 laps' and rank 1."""
    out = tmp_path / "r.json"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", f"{HOSTILE}:NeverMoves", "--quiet",
                      "--json", str(out), "--run-dir", str(tmp_path / "run"))
    assert proc.returncode == 0, proc.stderr
    [me] = read_json(out)["drivers"]
    assert me["laps"] == 0 and me["rank"] == 0 and me["lap_times"] == []
    assert "did not finish: 0 of 1 laps" in proc.stderr and "-1 of" not in proc.stderr


def test_what_a_robot_prints_is_kept_and_shown_with_show_prints(tmp_path, overlay, capfd):
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=[f"{HOSTILE}:Talks"],
                            run_dir=tmp_path / "run", show_prints=True, telemetry=False)
    result = launch.run_race(cfg, overlay)
    assert result.error is None
    err = capfd.readouterr().err
    assert "hello from the robot" in err and "a warning from the robot" in err
    log = (tmp_path / "run" / "host.log").read_text()
    assert "hello from the robot" in log and "a warning from the robot" in log
    quiet = launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=[f"{HOSTILE}:Talks"],
                              run_dir=tmp_path / "quiet", telemetry=False)
    launch.run_race(quiet, overlay)
    assert "hello from the robot" not in capfd.readouterr().err


def test_a_stop_asked_for_on_the_track_is_reported_as_missed(tmp_path, overlay):
    """Issue 13: pit_request all race long, on the racing line: the stop is never made, and the
    result says why, per lap."""
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=2, robots=[f"{HOSTILE}:AsksForAStopOnTheTrack"],
                            run_dir=tmp_path / "run", telemetry=False)
    result = launch.run_race(cfg, overlay)
    [me] = result.drivers
    assert me.pit_stops == 0
    assert [(m["lap"], m["reason"]) for m in me.missed_pit_stops] == [(1, "never entered the pit lane"),
                                                                      (2, "never entered the pit lane")]
    assert read_json(tmp_path / "run" / "result.json")["drivers"][0]["missed_pit_stops"] == me.missed_pit_stops


def test_a_car_pushed_past_its_box_is_reported_and_a_made_stop_is_not(tmp_path, overlay):
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=3,
                            robots=[f"{ROBOTS / 'faulty.py'}:OvershootsTheBoxOnce"], telemetry=False,
                            options=RaceOptions(pit_laps=(1,)), run_dir=tmp_path / "run")
    result = launch.run_race(cfg, overlay)
    [me] = result.drivers
    assert me.pit_stops == 1  # made on lap 2
    [missed] = me.missed_pit_stops
    assert missed["lap"] == 1 and missed["reason"] == "passed its box", missed


def test_the_race_command_shows_robot_output_and_missed_stops(tmp_path, overlay):
    """What the robot prints is shown as it comes, each line marked with its car (--quiet hides
    it); a stop asked for and not made is a warning line per lap."""
    talks = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", f"{HOSTILE}:Talks",
                       "--no-telemetry", "--run-dir", str(tmp_path / "talks"))
    assert talks.returncode == 0, talks.stderr
    assert "[middle 1] hello from the robot\n" in talks.stderr, talks.stderr
    assert "[middle 1] a warning from the robot\n" in talks.stderr
    asks = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--robot", f"{HOSTILE}:AsksForAStopOnTheTrack",
                      "--quiet", "--no-telemetry", "--run-dir", str(tmp_path / "asks"))
    assert asks.returncode == 0, asks.stderr
    assert "warning: middle 1 asked for a pit stop on lap 1 that was not made: never entered the pit lane" \
        in asks.stderr, asks.stderr


@pytest.mark.parametrize("quiet", [False, True])
def test_a_fault_shows_the_robots_last_five_printed_lines(tmp_path, overlay, quiet):
    """The robot reads its own prints back from host.log, marked, while the race runs (it raises
    if they are not there); its fault's line then shows the last five and where host.log is; they
    are on the terminal as they came unless --quiet."""
    run_dir = tmp_path / "run"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", f"{HOSTILE}:TalksThenFails",
                      "--no-telemetry", "--run-dir", str(run_dir), *(["--quiet"] if quiet else []))
    assert proc.returncode == 4, proc.stderr
    [error] = [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]
    assert "RuntimeError: done talking" in error and f"its prints are in {run_dir / 'host.log'}" in error
    shown = "the last 5 lines talker 1 printed:\n" + "".join(f"[talker 1] line {i}\n" for i in range(3, 8))
    assert shown in proc.stderr, proc.stderr
    assert ("[talker 1] line 1\n" in proc.stderr) is not quiet  # as they came: all seven lines, before the fault


def test_numpy_scalars_in_controls_drive_a_real_race(tmp_path, overlay):
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=2, telemetry=False, run_dir=tmp_path / "run",
                            robots=[f"{ROBOTS / 'hostile.py'}:NumpyControls"])
    result = launch.run_race(cfg, overlay)
    assert result.error is None, result.error
    assert result.drivers[0].laps == 2
