"""boxbox.testing without TORCS: make_state's defaults and its answer to a mistyped field, and the
drive steps a race records (states.parquet) read back by recorded_states exactly as the robot got
them, fast enough to run a robot over a 3-lap race in a unit test."""

from __future__ import annotations

import importlib.util
import time

import pytest

from boxbox.errors import UsageError
from boxbox.model import Opponent, State
from boxbox.testing import STATE_DEFAULTS, make_state, recorded_states
from boxbox.torcs import wire
from boxbox.torcs.rundir import RunDir
from boxbox.torcs.telemetry import FILE_NAME, NO_NEAR, Recorder, write_telemetry
from helpers import template_robot
from trackdata import load


def _parts_robot(folder):
    spec = importlib.util.spec_from_file_location("parts", template_robot(folder))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.Parts()


def test_make_state_fills_every_field_and_takes_the_named_ones():
    state = make_state(speed_x_mps=30, to_middle_m=-1.5, gear=3)
    assert isinstance(state, State) and state.speed_x_mps == 30.0 and isinstance(state.speed_x_mps, float)
    assert state.to_middle_m == -1.5 and state.gear == 3.0 and state.opponents == () and state.n_opponents == 0
    assert set(STATE_DEFAULTS) == set(State._fields) - {"opponents"}
    assert state.laps == 1 and state.to_left_m > 0 and state.to_right_m > 0 and state.travel_fr_m > 0
    other = Opponent(*[1.0] * len(Opponent._fields))
    assert make_state(opponents=[other]).n_opponents == 1.0


def test_a_mistyped_field_is_answered_with_the_nearest_ones():
    with pytest.raises(TypeError, match=r"State has no field 'speed_mps'; did you mean .*speed_x_mps"):
        make_state(speed_mps=10.0)
    with pytest.raises(TypeError, match="gear must be a number, not str"):
        make_state(gear="3")
    with pytest.raises(TypeError, match="opponents must be a tuple of boxbox.model.Opponent"):
        make_state(opponents=(1.0,))


def _record(rec: Recorder, states: list[State], steer: float) -> None:
    """What the host records per drive step: state, reply header, controls, nearest car."""
    for i, s in enumerate(states):
        rec.rows += wire.STATE_REC.pack(*s[:-1]) + wire.HEADER.pack(wire.CONTROLS, rec.index, i, 0)
        rec.rows += wire.CONTROLS_REC.pack(steer, 1.0, 0.0, 0.0, 1.0, 0.0) + NO_NEAR


def test_recorded_states_are_the_drive_steps_as_the_robot_got_them(tmp_path):
    first, second = Recorder(0, "a 1", "a"), Recorder(1, "b 1", "b", spool_dir=tmp_path)
    mine = [make_state(sim_time_s=0.02 * i, speed_x_mps=i / 3, n_opponents=1.0) for i in range(30)]
    _record(first, [make_state(sim_time_s=0.02 * i) for i in range(10)], 0.0)
    _record(second, mine[:20], -0.25)
    second.spill()  # a long race's steps come partly from the spool
    _record(second, mine[20:], -0.25)
    pit = make_state(sim_time_s=0.7, car_state=1.0)
    second.add(wire.STATE_REC.pack(*pit[:-1]), pit)  # the pit stop's row: not a drive step
    assert write_telemetry(tmp_path / FILE_NAME, [first, second]) == 41
    assert list(recorded_states(tmp_path, car=1)) == mine
    assert len(list(recorded_states(tmp_path))) == 10
    with pytest.raises(UsageError, match="no drive step of car 2"):
        next(recorded_states(tmp_path, car=2))
    RunDir(tmp_path).states.unlink()
    with pytest.raises(UsageError, match="no states.parquet in .*without --no-telemetry"):
        next(recorded_states(tmp_path))


def test_a_robot_drives_over_5000_recorded_states_in_well_under_a_second(tmp_path):
    track, car = load("g-track-1")
    rec = Recorder(0, "parts 1", "parts")
    length = track.length_m
    _record(rec, [make_state(sim_time_s=0.02 * i, dist_from_start_m=(i * 0.6) % length, speed_x_mps=30.0,
                             seg_id=float(track.segment_at((i * 0.6) % length)), gear=3.0) for i in range(5000)], 0.0)
    write_telemetry(tmp_path / FILE_NAME, [rec])
    robot = _parts_robot(tmp_path)
    robot.on_track(track, car)
    next(recorded_states(tmp_path))  # pyarrow's first read in a process: 0.2 to 0.5 s of set-up, once
    start_s = time.perf_counter()
    controls = [robot.drive(s) for s in recorded_states(tmp_path)]
    elapsed_s = time.perf_counter() - start_s
    assert len(controls) == 5000 and all(-1.0 <= c.steer <= 1.0 for c in controls)
    assert elapsed_s < 1.0, f"{elapsed_s:.2f} s"  # about 0.15 s on a loaded 2-core machine
