"""The robot host's incident counters and bounded step timing; the sweep's targets; soak figures;
atomic files; the run-dir lock; the setups folder from BOXBOX_SETUPS."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import trackdata
from boxbox.bench.soak import Series, forked_children, slope
from boxbox.bench.sweep import MAX_DAMAGE, misses
from boxbox.errors import UsageError
from boxbox.files import write_json_atomic
from boxbox.model import State
from boxbox.model.state import CAR_STATE_PIT
from boxbox.model.track import LEFT
from boxbox.robot import params as params_mod
from boxbox.torcs import carwatch, host
from boxbox.torcs.rundir import RunDir


def state(**kw) -> State:
    values: dict[str, object] = dict.fromkeys(State._fields, 0.0)
    values.update(sim_time_s=10.0, speed_x_mps=30.0, to_left_m=5.0, to_right_m=5.0, seg_id=0.0)
    values.update(kw)
    values["opponents"] = ()
    return State(**values)


def slot_on(track_name: str) -> carwatch.HostedCar:
    track, car = trackdata.load(track_name)
    slot = carwatch.HostedCar(robot=None, spec="x", name="x 1", car=car, track=track)
    slot.pit_zone = carwatch.pit_zone(track)
    return slot


def test_stuck_and_off_track_steps_are_counted():
    slot = slot_on(trackdata.TRACKS[0])
    no_pit = next(i for i in range(len(slot.track.seg["type"])) if not (slot.pit_zone and slot.pit_zone[i]))
    for _ in range(10):
        carwatch.watch_step(slot, state(seg_id=no_pit))  # driving normally
    for _ in range(50):
        carwatch.watch_step(slot, state(seg_id=no_pit, speed_x_mps=0.2))  # stuck, on the track
    carwatch.watch_step(slot, state(seg_id=no_pit))
    for _ in range(20):
        carwatch.watch_step(slot, state(seg_id=no_pit, speed_x_mps=0.0, to_right_m=-1.0))  # stuck in the gravel
    assert (slot.stuck_steps, slot.longest_stuck_steps, slot.off_track_steps) == (70, 50, 20)
    assert carwatch.incidents(slot) == {"stuck_s": 1.4, "longest_stuck_s": 1.0, "off_track_s": 0.4}


def test_the_pit_is_neither_stuck_nor_off_track():
    name = next(t for t in trackdata.TRACKS if trackdata.load(t)[0].pit is not None)
    slot = slot_on(name)
    pit = slot.track.pit
    side = {"to_left_m": -3.0} if pit.side == LEFT else {"to_right_m": -3.0}
    other = {"to_right_m": -3.0} if pit.side == LEFT else {"to_left_m": -3.0}
    for _ in range(30):
        carwatch.watch_step(slot, state(seg_id=pit.start_seg, speed_x_mps=0.0, car_state=CAR_STATE_PIT))  # in the box
        carwatch.watch_step(slot, state(seg_id=pit.start_seg, speed_x_mps=0.5, **side))  # the pit lane
    assert (slot.stuck_steps, slot.off_track_steps) == (0, 0)
    carwatch.watch_step(slot, state(seg_id=pit.start_seg, **other))  # off on the other side: off the track
    assert slot.off_track_steps == 1


def test_before_the_start_nothing_is_stuck():
    slot = slot_on(trackdata.TRACKS[0])
    carwatch.watch_step(slot, state(sim_time_s=-0.5, speed_x_mps=0.0))
    assert slot.stuck_steps == 0


def test_step_times_stay_bounded_and_representative():
    slot = carwatch.HostedCar(robot=None, spec="x", name="x 1")
    n = 5 * carwatch.MAX_STEP_SAMPLES
    for i in range(n):
        carwatch.record_step_time(slot, i)
    assert slot.steps_timed == n
    assert len(slot.step_ns) < carwatch.MAX_STEP_SAMPLES
    median = sorted(slot.step_ns)[len(slot.step_ns) // 2]
    assert abs(median - n / 2) < n * 0.01


def test_sweep_targets():
    row = {"error": None, "laps": 3, "damage": 10, "longest_stuck_s": 0.2}
    assert misses(row, 3) == []
    assert misses(dict(row, laps=2), 3) == ["not finished: 2/3 laps"]
    assert misses(dict(row, damage=MAX_DAMAGE), 3) == [f"damage {MAX_DAMAGE} >= {MAX_DAMAGE}"]
    assert misses(dict(row, longest_stuck_s=10.5), 3) == ["stuck 10.5 s > 10 s"]
    assert misses(dict(row, error="TORCS was killed\nmore"), 3) == ["TORCS was killed"]
    assert misses(dict(row, longest_stuck_s=None), 3) == ["stuck time not measured"]


def test_soak_slope_and_figures():
    assert slope([1, 2, 3, 4], [10, 12, 14, 16]) == pytest.approx(2.0)
    s = Series("memory", "kB")
    for i in range(1, 101):
        s.add(i, 1000 + (50 if i < 5 else 0))  # a warm-up bump, then flat
    f = s.figures()
    assert f["first"] == 1050 and f["last"] == 1000 and f["slope_per_100"] == 0.0


def test_json_is_written_whole(tmp_path):
    path = tmp_path / "r.json"
    write_json_atomic(path, {"a": 1}, indent=1)
    assert json.loads(path.read_text()) == {"a": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_run_dir_lock_refuses_a_second_race(tmp_path):
    with RunDir(tmp_path).locked():
        with pytest.raises(UsageError, match="is in use by another race"):
            with RunDir(tmp_path).locked():
                pass
    with RunDir(tmp_path).locked():  # released
        pass


def test_setups_folder_from_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("BOXBOX_SETUPS", str(tmp_path))
    assert params_mod.setup_files("car1-trb1", "g-track-1")[0] == tmp_path / "default.toml"
    (tmp_path / "default.toml").write_text("mu_scale = 0.7\n")
    p, sources = params_mod.load_params("car1-trb1", "g-track-1")
    assert p.mu_scale == 0.7 and Path(sources["mu_scale"]) == tmp_path / "default.toml"
    monkeypatch.delenv("BOXBOX_SETUPS")
    assert params_mod.setup_files("car1-trb1", "g-track-1")[0] == params_mod.SETUPS / "default.toml"


def test_the_final_lap_comes_from_the_race_time():
    from boxbox.torcs.results import DriverResult
    from boxbox.torcs.results import add_final_lap as _add_final_lap

    d = DriverResult(name="b", module="boxbox", idx=0, car="c", laps=3, time=200.078, best_lap=64.914,
                     lap_times=[70.092, 65.072])
    _add_final_lap(d)
    assert d.lap_times == [70.092, 65.072, 64.914]
    odd = DriverResult(name="b", module="boxbox", idx=0, car="c", laps=3, time=100.0, best_lap=60.0,
                       lap_times=[70.0, 20.0])
    _add_final_lap(odd)  # 10 s is faster than the best lap: not a lap time, left out
    assert odd.lap_times == [70.0, 20.0]


def test_forked_children_finds_a_forked_copy_of_this_process():
    """The robot host is forked from the launcher, so its command line is the launcher's: the soak
    finds it as a child running the same program (and counts it as left over if it outlives a race)."""
    import os
    import signal
    import time

    before = forked_children()
    pid = os.fork()
    if pid == 0:  # the child: wait to be killed, never return into pytest
        try:
            time.sleep(30)
        finally:
            os._exit(0)
    try:
        deadline = time.monotonic() + 5.0
        while pid not in forked_children() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert pid in forked_children()
        assert pid not in before
    finally:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    assert pid not in forked_children()


def test_a_failed_atomic_write_leaves_the_old_file_and_no_temporary(tmp_path):
    from boxbox.files import atomic_path

    path = tmp_path / "r.json"
    path.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(path) as tmp:
            tmp.write_text("half")
            raise RuntimeError("the writer failed")
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_saving_a_result_reports_the_paths_it_could_not_write(tmp_path):
    from boxbox.torcs.results import RaceResult, save_result

    result = RaceResult(track="t", category="road", car="c", laps=1)
    good, bad = tmp_path / "result.json", tmp_path / "no-such-folder" / "r.json"
    failed = save_result(result, [good, bad])
    assert [p for p, _ in failed] == [bad] and "No such file" in failed[0][1]
    assert json.loads(good.read_text())["track"] == "t"
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]


def test_faults_have_one_schema(tmp_path):
    from boxbox.torcs.faults import Fault

    fault = Fault(kind="exit", message="the robot called sys.exit() (in drive, step 3)", where="drive",
                  robot_index=0, robot="r.py:R", name="r 1", step=3, sim_time_s=0.06, traceback="Traceback ...")
    fault.write(tmp_path / "fault.json")
    assert Fault.read(tmp_path / "fault.json") == fault
    assert Fault.from_json({**fault.to_json(), "unknown": 1}) == fault
    assert Fault.read(tmp_path / "absent.json") is None
    assert fault.line().startswith("robot 'r.py:R' (r 1) failed: the robot called sys.exit()")
    assert [p.name for p in tmp_path.iterdir()] == ["fault.json"]


def test_the_host_reports_survive_any_chunking():
    import os

    from boxbox.torcs.faults import Fault
    from boxbox.torcs.hostlink import HostLink, HostReports

    read_fd, write_fd = os.pipe()
    reports, link = HostReports(read_fd), HostLink(write_fd)
    link.send("connected")
    link.send("track", length_m=2057.5)
    link.send("progress", cars=[{"robot_index": 0, "lap_times": [61.8]}], other_lap_times={})
    link.send("fault", fault=Fault(kind="exception", message="boom", where="drive").to_json())
    os.write(write_fd, b'{"kind": "summary", "cars": [{"robot_index": 0, "lap_')  # half a line, then the rest
    reports.read()
    assert reports.connected and reports.track_length_m == 2057.5 and reports.fault.message == "boom"
    assert reports.cars()["cars"][0]["lap_times"] == [61.8] and reports.summary is None
    os.write(write_fd, b'times": [61.8, 60.1]}]}\nnot json\n')
    os.close(write_fd)
    assert reports.drain(1.0) and reports.closed
    assert reports.cars()["cars"][0]["lap_times"] == [61.8, 60.1]


def test_the_wall_limit_covers_every_step_at_its_budget():
    from boxbox.torcs.timing import START_S, STEP_S, TimeModel

    model = TimeModel(step_budget_ms=200, setup_budget_ms=120_000, min_speed_mps=5.0)
    assert model.sim_limit_s(3, 2000.0) == 1200.0
    steps = model.steps(3, 2000.0)
    assert steps == 60_000 == 1200.0 / STEP_S
    wall = model.wall_limit_s(3, 2000.0, python_cars=2, cars=5)
    assert wall >= steps * 2 * 0.2 + START_S + 2 * 3 * 120 + 2 * 3 * 120  # every call at its full budget
    # not a set-up budget + 60 s + 10 s a lap and car, which is 5 ms a step over 200 laps
    assert model.wall_limit_s(200, 2000.0, 1, 1) / model.steps(200, 2000.0) > 0.2


def test_old_automatic_run_dirs_are_pruned_and_chosen_ones_never(tmp_path, monkeypatch):
    import time

    from boxbox.torcs.rundir import RunDir, runs_root

    monkeypatch.setenv("BOXBOX_CACHE", str(tmp_path))
    made = []
    for _ in range(4):
        made.append(RunDir.new(keep=10).path)
        time.sleep(1.01)  # names are by the second
    chosen = runs_root() / "0000-mine"  # a --run-dir under the runs folder: no .auto mark
    chosen.mkdir()
    with RunDir(made[0]).locked():  # a race still running in the oldest
        newest = RunDir.new(keep=2).path
    left = sorted(p for p in runs_root().iterdir())
    assert left == sorted([chosen, made[0], made[3], newest])
    monkeypatch.setenv("BOXBOX_KEEP_RUNS", "1")
    last = RunDir.new().path
    assert sorted(runs_root().iterdir()) == sorted([chosen, last])


def test_elf_problem_finds_a_truncated_module():
    from boxbox.torcs.setup import bridge_module, elf_problem

    data = bridge_module().read_bytes() if bridge_module().exists() else None
    if data is None:
        pytest.skip("the bridge is not built (run boxbox setup)")
    assert elf_problem(data) is None
    assert "truncated" in elf_problem(data[: len(data) // 2])
    assert elf_problem(b"#!/bin/sh\n" * 10) == "no ELF header"


def pit_states(track, car, speeds_mps, side_m: float, offsets_m):
    """States of a car in the pit lane around its box: one per (speed, offset from the box centre)."""
    box = track.dist_of(car.pit_seg, car.pit_to_start)
    out = []
    for speed, off in zip(speeds_mps, offsets_m, strict=True):
        dist = (box + off) % track.length_m
        seg = track.segment_at(dist)
        side = {"to_left_m": side_m} if track.pit.side == LEFT else {"to_right_m": side_m}
        out.append(state(seg_id=float(seg), dist_from_start_m=dist, speed_x_mps=speed, laps=2.0, **side))
    return out


def drive_through(watch, states_in_lane, track):
    exit_seg = (track.pit.exit_seg + 2) % track.n_segments
    for s in states_in_lane:
        watch.step(s, True)
    watch.step(state(seg_id=float(exit_seg), laps=2.0), True)  # out of the pit zone: judged


@pytest.mark.parametrize("speeds,offsets,reason,detail", [
    ([20.0] * 9, range(-40, 50, 10), "passed its box", "slowest 20.0 m/s"),
    ([8.0, 3.0, 0.5, 0.4, 2.0], [-60, -45, -35, -34, -20], "not captured", "stopped"),
    ([8.0, 4.0, 3.0, 3.0, 4.0], [-20, -5, 0, 3, 20], "not captured", "too fast in its box (slowest 3.0 m/s"),
])
def test_a_missed_stop_gets_its_reason(speeds, offsets, reason, detail):
    from boxbox.torcs.pitwatch import PitWatch

    name = next(t for t in trackdata.TRACKS if trackdata.load(t)[0].pit is not None)
    track, car = trackdata.load(name)
    watch = PitWatch(track, car, carwatch.pit_zone(track))
    drive_through(watch, pit_states(track, car, speeds, -3.0, offsets), track)
    [missed] = watch.finish()
    assert missed["lap"] == 2 and missed["reason"] == reason and detail in missed["detail"], missed


def test_a_stop_on_the_track_side_never_entered_and_a_made_stop_is_no_miss():
    from boxbox.torcs.pitwatch import PitWatch

    name = next(t for t in trackdata.TRACKS if trackdata.load(t)[0].pit is not None)
    track, car = trackdata.load(name)
    watch = PitWatch(track, car, carwatch.pit_zone(track))
    drive_through(watch, pit_states(track, car, [30.0] * 3, 4.0, [-10, 0, 10]), track)  # on the track
    assert [m["reason"] for m in watch.finish()] == ["never entered the pit lane"]
    made = PitWatch(track, car, carwatch.pit_zone(track))
    lane = pit_states(track, car, [5.0, 0.5], -3.0, [-5, 0])
    captured = lane[-1]._replace(car_state=float(CAR_STATE_PIT))
    drive_through(made, [*lane, captured], track)
    assert made.finish() == []


def test_asking_on_the_way_out_of_a_stop_is_no_miss_but_next_lap_counts():
    from boxbox.torcs.pitwatch import PitWatch

    name = next(t for t in trackdata.TRACKS if trackdata.load(t)[0].pit is not None)
    track, car = trackdata.load(name)
    watch = PitWatch(track, car, carwatch.pit_zone(track))
    lane = pit_states(track, car, [5.0, 0.5], -3.0, [-5, 0])
    watch.step(lane[0], True)
    watch.step(lane[1]._replace(car_state=float(CAR_STATE_PIT)), True)  # captured
    drive_through(watch, pit_states(track, car, [3.0, 10.0, 20.0], -3.0, [0, 10, 30]), track)  # still asking
    assert watch.finish() == []
    drive_through(watch, pit_states(track, car, [20.0] * 5, -3.0, [-20, -10, 0, 10, 20]), track)  # next lap
    assert [m["reason"] for m in watch.finish()] == ["passed its box"]


def test_the_stall_limit_covers_the_longest_call_and_a_heartbeat():
    from boxbox.torcs.timing import HEARTBEAT_S, STALL_MARGIN_S, TimeModel

    model = TimeModel(step_budget_ms=200, setup_budget_ms=120_000)
    assert model.stall_limit_s() == pytest.approx(120.2 + HEARTBEAT_S + STALL_MARGIN_S)
    assert model.stall_limit_s() < model.wall_limit_s(1, 2000.0, 1, 10) / 10


# --- TORCS losing every car (torcs/carwatch.py every_car_lost, torcs/host.py _check_breakdown) --------------------

NAN = float("nan")


def opponent(x_m: float, car_state: int = 0):
    from boxbox.model import Opponent
    return Opponent(**{**dict.fromkeys(Opponent._fields, 0.0), "x_m": x_m, "car_state": float(car_state)})


def with_opponents(s: State, *opps) -> State:
    return s._replace(opponents=tuple(opps))


def test_every_car_lost_only_when_ours_and_every_racing_car_have_no_position():
    from boxbox.model.state import CAR_STATE_OUT
    lost = state(x_m=NAN)
    assert carwatch.every_car_lost(with_opponents(lost, opponent(NAN), opponent(NAN)))
    # a car in its pit, or out of the race, is not simulated: its finite position does not count
    assert carwatch.every_car_lost(with_opponents(lost, opponent(NAN), opponent(5.0, CAR_STATE_PIT),
                                              opponent(7.0, CAR_STATE_OUT)))
    assert not carwatch.every_car_lost(with_opponents(lost, opponent(NAN), opponent(5.0)))  # one still racing
    assert not carwatch.every_car_lost(with_opponents(state(x_m=3.0), opponent(NAN)))  # ours is there


def test_a_breakdown_stops_the_race_after_a_second_of_every_car_lost():
    slot = carwatch.HostedCar(robot=None, spec="x", name="x 1")
    for t in (467.2, 467.6, 468.1):
        host.Host._check_breakdown(slot, with_opponents(state(x_m=NAN, sim_time_s=t), opponent(NAN)))
    with pytest.raises(host.RobotFault) as raised:
        host.Host._check_breakdown(slot, with_opponents(state(x_m=NAN, sim_time_s=468.3), opponent(NAN)))
    assert raised.value.kind == "sim-breakdown" and "broke down at 467.2 s" in str(raised.value)
    # a car found again resets the clock
    slot2 = carwatch.HostedCar(robot=None, spec="x", name="x 1")
    host.Host._check_breakdown(slot2, with_opponents(state(x_m=NAN, sim_time_s=1.0), opponent(NAN)))
    host.Host._check_breakdown(slot2, with_opponents(state(x_m=NAN, sim_time_s=1.5), opponent(4.0)))
    host.Host._check_breakdown(slot2, with_opponents(state(x_m=NAN, sim_time_s=2.2), opponent(NAN)))
    assert slot2.lost_since_s == 2.2


def test_a_breakdown_is_the_race_s_fault_not_the_robot_s():
    from boxbox.torcs.faults import Fault
    fault = Fault(kind="sim-breakdown", message="TORCS's simulation broke down at 467.2 s", where="drive")
    assert fault.line("my.py:Bot") == "TORCS's simulation broke down at 467.2 s"
