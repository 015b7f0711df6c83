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
from boxbox.torcs import host
from boxbox.torcs.rundir import RunDir


def state(**kw) -> State:
    values = dict.fromkeys(State._fields, 0.0)
    values.update(sim_time_s=10.0, speed_x_mps=30.0, to_left_m=5.0, to_right_m=5.0, seg_id=0.0)
    values.update(kw)
    values["opponents"] = ()
    return State(**values)


def slot_on(track_name: str) -> host.Slot:
    track, car = trackdata.load(track_name)
    slot = host.Slot(robot=None, spec="x", name="x 1", car=car, track=track)
    slot.pit_zone = host.pit_zone(track)
    return slot


def test_stuck_and_off_track_steps_are_counted():
    slot = slot_on(trackdata.TRACKS[0])
    no_pit = next(i for i in range(len(slot.track.seg["type"])) if not (slot.pit_zone and slot.pit_zone[i]))
    for _ in range(10):
        host.watch_step(slot, state(seg_id=no_pit))  # driving normally
    for _ in range(50):
        host.watch_step(slot, state(seg_id=no_pit, speed_x_mps=0.2))  # stuck, on the track
    host.watch_step(slot, state(seg_id=no_pit))
    for _ in range(20):
        host.watch_step(slot, state(seg_id=no_pit, speed_x_mps=0.0, to_right_m=-1.0))  # stuck in the gravel
    assert (slot.stuck_steps, slot.longest_stuck_steps, slot.off_track_steps) == (70, 50, 20)
    assert host.incidents(slot) == {"stuck_s": 1.4, "longest_stuck_s": 1.0, "off_track_s": 0.4}


def test_the_pit_is_neither_stuck_nor_off_track():
    name = next(t for t in trackdata.TRACKS if trackdata.load(t)[0].pit is not None)
    slot = slot_on(name)
    pit = slot.track.pit
    side = {"to_left_m": -3.0} if pit.side == LEFT else {"to_right_m": -3.0}
    other = {"to_right_m": -3.0} if pit.side == LEFT else {"to_left_m": -3.0}
    for _ in range(30):
        host.watch_step(slot, state(seg_id=pit.start_seg, speed_x_mps=0.0, car_state=CAR_STATE_PIT))  # in the box
        host.watch_step(slot, state(seg_id=pit.start_seg, speed_x_mps=0.5, **side))  # the pit lane
    assert (slot.stuck_steps, slot.off_track_steps) == (0, 0)
    host.watch_step(slot, state(seg_id=pit.start_seg, **other))  # off on the other side: off the track
    assert slot.off_track_steps == 1


def test_before_the_start_nothing_is_stuck():
    slot = slot_on(trackdata.TRACKS[0])
    host.watch_step(slot, state(sim_time_s=-0.5, speed_x_mps=0.0))
    assert slot.stuck_steps == 0


def test_step_times_stay_bounded_and_representative():
    slot = host.Slot(robot=None, spec="x", name="x 1")
    n = 5 * host.MAX_STEP_SAMPLES
    for i in range(n):
        host.record_step_time(slot, i)
    assert slot.steps_timed == n
    assert len(slot.step_ns) < host.MAX_STEP_SAMPLES
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
