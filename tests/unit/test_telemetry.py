"""Telemetry recording (torcs/telemetry.py) and the race report page, on synthetic steps: no TORCS."""

from __future__ import annotations

import base64
import io
import json
import math
import re
from types import SimpleNamespace

import numpy as np
import pytest

import boxbox.robot.params as params_mod
from boxbox.model import State
from boxbox.report.figures import braking_points
from boxbox.report.race_report import build_report, write_report
from boxbox.robot.base import RaceOptions, Robot
from boxbox.robot.tutorial import PIT_PHASE_CODES, TutorialRobot
from boxbox.torcs import wire
from boxbox.torcs.telemetry import (
    COLUMNS,
    FILE_NAME,
    NEAR_REC,
    NO_NEAR,
    RAD_S_TO_RPM,
    ROW_DOUBLES,
    Recorder,
    load_telemetry,
    nearest_car,
    track_info,
    write_telemetry,
)
from trackdata import load


def state_bytes(**fields) -> bytes:
    values = dict.fromkeys(wire.STATE_FIELDS, 0.0)
    values.update(fields)
    return wire.STATE_REC.pack(*(values[f] for f in wire.STATE_FIELDS))


def controls_bytes(steer=0.0, accel=0.0, brake=0.0, clutch=0.0, gear=1, pit_request=0.0) -> bytes:
    return wire.CONTROLS_REC.pack(steer, accel, brake, clutch, float(gear), pit_request)


def as_state(record: bytes) -> State:
    return State._make(wire.STATE_REC.unpack(record) + ((),))


class Signals(Robot):
    def telemetry_fields(self):
        return ("target_speed_mps", "phase")

    def telemetry(self, state):
        return (state.speed_x_mps + 1.0, 2.0)


def record(rec: Recorder, n: int, near: bytes = NO_NEAR, **fields) -> None:
    """What the host does per drive step: the state, reply header and controls bytes, the nearest
    car, then the robot's tuple."""
    for i in range(n):
        rec_bytes = state_bytes(sim_time_s=0.02 * i, speed_x_mps=float(i), laps=1.0, rpm=100.0, **fields)
        reply = wire.HEADER.pack(wire.CONTROLS, 0, i, 0) + controls_bytes(steer=-0.5, accel=0.25, gear=2)
        rec.rows += rec_bytes + reply + near
        if rec.tel is not None:
            try:
                rec.sig_append(rec.tel(as_state(rec_bytes)))
            except Exception as exc:
                rec.drop_signals(exc)


def test_round_trip_columns_target_and_signals(tmp_path):
    rec = Recorder(0, "sig 1", "tests:Signals")
    rec.start(Signals())
    record(rec, 10, gear=3.0, car_state=0.0)
    rec.add(state_bytes(sim_time_s=0.5, car_state=1.0, speed_x_mps=0.3), as_state(state_bytes(speed_x_mps=0.3)))
    assert write_telemetry(tmp_path / FILE_NAME, [rec]) == 11
    t = load_telemetry(tmp_path / FILE_NAME)
    c = t.columns
    assert list(c)[: len(COLUMNS)] == [name for name, _ in COLUMNS]
    assert list(c)[len(COLUMNS):] == ["sig_phase"]
    assert (c["car"] == 0).all() and set(c["driver"]) == {"sig 1"}
    assert c["speed_mps"][:10].tolist() == [float(i) for i in range(10)]
    assert c["target_speed_mps"][:10].tolist() == [i + 1.0 for i in range(10)]
    assert c["rpm"][0] == pytest.approx(100.0 * RAD_S_TO_RPM)
    assert c["gear"][0] == 3 and c["accel"][0] == 0.25 and c["steer"][0] == -0.5
    # the pit stop row: in the pit, no controls
    assert c["in_pit"].tolist() == [False] * 10 + [True]
    assert math.isnan(c["accel"][10]) and not c["pit_request"][10]
    assert t.meta["cars"][0]["signals"] == ["target_speed_mps", "phase"] and t.meta["cars"][0]["error"] is None


def opponent(index: int, x_m: float, y_m: float):
    return SimpleNamespace(car_index=float(index), x_m=x_m, y_m=y_m)


def test_nearest_car_in_our_cars_frame():
    """The nearest car by centre distance, placed ahead and to the left along our own axis: heading
    north (yaw 90 degrees), a car 3 m north and 1 m west is 3 m ahead and 1 m to our left."""
    cars = [opponent(4, 10.0, 40.0), opponent(7, 9.0, 23.0), opponent(2, 30.0, 20.0)]
    index, ahead, left = NEAR_REC.unpack(nearest_car(10.0, 20.0, math.pi / 2, cars))
    assert index == 7 and ahead == pytest.approx(3.0) and left == pytest.approx(1.0)
    # heading east, the same car is 1 m behind and 3 m to the left
    _, ahead, left = NEAR_REC.unpack(nearest_car(10.0, 20.0, 0.0, cars))
    assert ahead == pytest.approx(-1.0) and left == pytest.approx(3.0)
    assert nearest_car(0.0, 0.0, 0.0, []) == NO_NEAR
    assert nearest_car(0.0, 0.0, 0.0, [opponent(3, math.nan, math.nan)]) == NO_NEAR  # a car TORCS lost


def test_nearest_car_columns_null_when_alone(tmp_path):
    """The near columns round-trip; with no other car the index is -1 and the place null (NaN back)."""
    rec = Recorder(0, "near", "s")
    record(rec, 3, near=nearest_car(0.0, 0.0, 0.0, [opponent(5, 2.0, -1.5)]))
    record(rec, 2)
    write_telemetry(tmp_path / FILE_NAME, [rec])
    c = load_telemetry(tmp_path / FILE_NAME).columns
    assert c["near_car"].tolist() == [5, 5, 5, -1, -1]
    assert c["near_ahead_m"][:3].tolist() == [2.0] * 3 and c["near_left_m"][:3].tolist() == [-1.5] * 3
    assert np.isnan(c["near_ahead_m"][3:]).all()
    import pyarrow.parquet as pq

    assert pq.read_table(tmp_path / FILE_NAME).column("near_left_m").null_count == 2


def test_spilled_steps_come_back_in_order_and_the_spool_goes(tmp_path):
    """The host spills the buffer to a spool file every SPILL_STEPS steps (flat memory in long
    races); the file written at the end holds the same rows as a recorder that never spilled."""
    kept, spilled = Recorder(0, "sig 1", "s"), Recorder(0, "sig 1", "s", spool_dir=tmp_path)
    for rec in (kept, spilled):
        rec.start(Signals())
    for chunk in (7, 5, 3):  # three spills, then 4 steps left in memory
        for rec in (kept, spilled):
            record(rec, chunk)
        spilled.spill()
        assert spilled.rows == bytearray() and spilled.signals == []
    for rec in (kept, spilled):
        record(rec, 4)
    assert spilled.spilled_steps == 15 and spilled.steps == kept.steps == 19
    assert (tmp_path / ".telemetry-0.rows").stat().st_size == 15 * 8 * ROW_DOUBLES
    a, b = kept.columns(), spilled.columns()
    assert list(a) == list(b)
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=a[name].dtype.kind == "f"), name
    out = tmp_path / "out"
    out.mkdir()
    assert write_telemetry(out / FILE_NAME, [spilled]) == 19
    assert not list(tmp_path.glob(".telemetry-*"))  # the spool is gone once the file is written


def test_signals_dropped_after_a_spill_drop_their_spool(tmp_path):
    rec = Recorder(0, "sig 1", "s", spool_dir=tmp_path)
    rec.start(Signals())
    record(rec, 5)
    rec.spill()
    assert (tmp_path / ".telemetry-0.sig").exists()
    rec.drop_signals(RuntimeError("boom"))
    assert not (tmp_path / ".telemetry-0.sig").exists()
    record(rec, 3)
    cols = rec.columns()
    assert len(cols["time_s"]) == 8 and not any(k.startswith("sig_") for k in cols)
    assert "target_speed_mps" not in cols


def test_no_signals_and_a_robot_without_target(tmp_path):
    rec = Recorder(1, "plain 2", "middle")
    rec.start(Robot())  # the base robot names nothing: no call per step
    assert rec.tel is None
    record(rec, 5)
    write_telemetry(tmp_path / FILE_NAME, [rec])
    c = load_telemetry(tmp_path / FILE_NAME).columns
    assert np.isnan(c["target_speed_mps"]).all() and not any(k.startswith("sig_") for k in c)


def test_signals_dict_is_the_default_hook():
    class Old(Robot):
        def signals(self):
            return {"a": 1.0, "b": 2.0}

    robot = Old()
    assert robot.telemetry_fields() == ("a", "b")
    assert robot.telemetry(None) == (1.0, 2.0)


def test_a_failing_telemetry_hook_costs_only_the_signals(tmp_path):
    class Fails(Signals):
        def telemetry(self, state):
            if state.sim_time_s > 0.05:
                raise KeyError("boom")
            return (1.0, 2.0)

    class BadNames(Robot):
        def telemetry_fields(self):
            return ("x", "x")

    rec = Recorder(0, "f 1", "f")
    rec.start(Fails())
    record(rec, 6)
    assert rec.tel is None and "KeyError" in rec.error
    bad = Recorder(1, "b 2", "b")
    bad.start(BadNames())
    assert bad.tel is None and "distinct" in bad.error
    record(bad, 3)
    write_telemetry(tmp_path / FILE_NAME, [rec, bad])
    t = load_telemetry(tmp_path / FILE_NAME)
    assert t.rows == 9 and np.isnan(t.columns["target_speed_mps"]).all()
    assert [m["error"] is not None for m in t.meta["cars"]] == [True, True]


def test_values_not_matching_the_names_are_dropped(tmp_path):
    class Short(Signals):
        def telemetry(self, state):
            return (1.0,)

    rec = Recorder(0, "s 1", "s")
    rec.start(Short())
    record(rec, 4)
    write_telemetry(tmp_path / FILE_NAME, [rec])
    t = load_telemetry(tmp_path / FILE_NAME)
    assert t.rows == 4 and "do not match" in t.meta["cars"][0]["error"]
    assert not any(k.startswith("sig_") for k in t.columns)


def test_two_cars_with_different_signals(tmp_path):
    a, b = Recorder(0, "a 1", "a"), Recorder(1, "b 2", "b")
    a.start(Signals())
    b.start(Robot())
    record(a, 3)
    record(b, 2)
    write_telemetry(tmp_path / FILE_NAME, [a, b])
    t = load_telemetry(tmp_path / FILE_NAME)
    assert t.rows == 5 and t.car(1)["sig_phase"].shape == (2,) and np.isnan(t.car(1)["sig_phase"]).all()
    assert t.car(0)["sig_phase"].tolist() == [2.0, 2.0, 2.0]


def test_nothing_recorded_writes_no_file(tmp_path):
    rec = Recorder(0, "a 1", "a")
    assert write_telemetry(tmp_path / FILE_NAME, [rec]) == 0
    assert not (tmp_path / FILE_NAME).exists()


@pytest.fixture
def no_setup_files(tmp_path_factory, monkeypatch):
    monkeypatch.setattr(params_mod, "SETUPS", tmp_path_factory.mktemp("setups"))


def test_tutorial_robot_signals(no_setup_files):
    track, car = load("g-track-1")
    car.name = "car1-trb1"
    robot = TutorialRobot(RaceOptions(learning_dir=None))
    robot.on_track(track, car)
    names = robot.telemetry_fields()
    assert names[0] == "target_speed_mps" and "pit_phase" in names
    s = as_state(state_bytes(dist_from_start_m=500.0, speed_x_mps=20.0, laps=1.0, gear=2.0, to_left_m=7.5,
                             to_right_m=7.5, fuel_l=50.0))
    robot.drive(s)
    values = robot.telemetry(s)
    assert len(values) == len(names)
    # the target drive() used: the profile a little ahead of the car
    ahead = 500.0 + 20.0 * robot.params.speed_lookahead_s
    assert values[0] == pytest.approx(robot.profile.speed_at(ahead))
    assert values[names.index("pit_phase")] == PIT_PHASE_CODES[None] == 0


# --- the report page -----------------------------------------------------------------------------------
def synthetic_run(run_dir, laps: int = 2):
    """A run dir with result.json and telemetry of a car going round g-track-1's middle line twice,
    slowing in the turns, with one pit stop in lap 1."""
    from boxbox.robot.racingline import middle_line

    track, car = load("g-track-1")
    mid = middle_line(track, step_m=2.0)
    length = track.length_m
    rec = Recorder(0, "boxbox 1", "boxbox")
    pit = track_info(track, {0: car})["pit"]
    t, d_total, k = 0.0, 0.0, 0
    prev_v = 0.0
    stop_t: float | None = None
    box = pit["box_m"]["0"]
    while d_total < laps * length:
        d = d_total % length
        j = int(d / mid.step_m) % mid.n
        v = 20.0 + 40.0 / (1.0 + 200.0 * abs(float(mid.curvature_1pm[j])))
        in_lane = d_total < length and pit["entry_m"] <= d <= pit["exit_m"]
        if in_lane:
            v = min(v, pit["speed_limit_mps"] - 1.0, 1.0 + abs(d - box))
        brake = 0.6 if v < prev_v - 0.05 else 0.0
        gear = 1 + min(4, int(v / 12.0))
        s = state_bytes(sim_time_s=t, x_m=float(mid.x_m[j]), y_m=float(mid.y_m[j]), speed_x_mps=v,
                        dist_from_start_m=d, dist_raced_m=d_total, laps=1.0 + d_total // length, gear=float(gear),
                        rpm=500.0, fuel_l=50.0 - d_total / 1000.0)
        rec.add(s, None, controls_bytes(accel=0.0 if brake else 0.8, brake=brake, gear=gear))
        if in_lane and stop_t is None and abs(d - box) < 1.5:
            stop_t = t
            rec.add(state_bytes(sim_time_s=t, x_m=float(mid.x_m[j]), y_m=float(mid.y_m[j]), dist_from_start_m=d,
                                laps=1.0, car_state=1.0, gear=1.0), None)
            t += 3.0
        prev_v = v
        d_total += v * 0.02
        t += 0.02
        k += 1
    rec.names = ("target_speed_mps",)  # filled below, as a robot would have
    rec.signals[:] = [(v + 5.0,) for v in np.frombuffer(rec.rows, "<f8").reshape(-1, ROW_DOUBLES)[:, 7]]
    write_telemetry(run_dir / FILE_NAME, [rec], track, {0: car})
    lap_times = [60.0, 55.0][:laps]
    assert stop_t is not None
    event = {"lap": 1, "entry_time": 20.0, "stop_time": stop_t, "leave_time": stop_t + 3.0, "exit_time": 40.0,
             "stop_error_m": 0.1, "fuel": 10.0, "repair": 0.0, "mode": "constant-decel"}
    result = {"track": "g-track-1", "category": "road", "car": "car1-trb1", "laps": laps, "wall_s": 2.0,
              "run_dir": str(run_dir), "error": None, "drivers": [
                  {"name": "boxbox 1", "module": "boxbox", "idx": 0, "car": "car1-trb1", "laps": laps, "time": 115.0,
                   "best_lap": 55.0, "lap_times": lap_times, "damage": 0, "pit_stops": 1, "penalty_time": 0.0,
                   "top_speed": 60.0, "rank": 1, "pit_events": [event], "step_us_median": 15.0},
                  {"name": "bt 3", "module": "bt", "idx": 2, "car": "car1-trb1", "laps": laps, "time": 110.0,
                   "best_lap": 54.0, "lap_times": [56.0, 54.0][:laps], "damage": 0, "pit_stops": 0,
                   "penalty_time": 0.0, "top_speed": 61.0, "rank": 2, "pit_events": []}]}
    (run_dir / "result.json").write_text(json.dumps(result))
    return result


def pngs(page: str) -> list[np.ndarray]:
    import matplotlib.image as mpimg

    return [mpimg.imread(io.BytesIO(base64.b64decode(b)), format="png")
            for b in re.findall(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)]


def test_report_page_has_every_figure_and_table(tmp_path):
    synthetic_run(tmp_path)
    page = build_report(tmp_path)
    images = pngs(page)
    # lap-time bars, the places lap by lap (two cars), track map, one pit stop, two laps
    assert page.count("<img ") == len(images) == 6
    assert all(im.shape[0] > 100 and im.shape[1] > 100 and im.std() > 0.01 for im in images)
    for text in ("Results", "Lap times", "Pit events", "boxbox 1 (boxbox:0)", "bt 3 (bt:2)", "Pit stop 1, lap 1",
                 "<b>55.000</b>", "telemetry.parquet"):
        assert text in page, text
    assert "http://" not in page and "https://" not in page  # self-contained
    out = write_report(tmp_path)
    assert out == tmp_path / "report.html" and out.read_text().count("<img ") == 6


def test_report_without_telemetry_and_with_an_error(tmp_path):
    synthetic_run(tmp_path, laps=1)
    (tmp_path / FILE_NAME).unlink()
    r = json.loads((tmp_path / "result.json").read_text())
    r["error"] = "robot 'x' failed: <boom>"
    (tmp_path / "result.json").write_text(json.dumps(r))
    page = build_report(tmp_path)
    assert "no telemetry recorded" in page and "&lt;boom&gt;" in page
    assert page.count("<img ") == len(pngs(page)) == 2  # the lap-time bars and the places lap by lap


def test_report_needs_a_run_dir(tmp_path):
    from boxbox.errors import UsageError

    with pytest.raises(UsageError, match="no result.json"):
        build_report(tmp_path)


def test_braking_points_count_each_zone_once():
    brake = np.zeros(400)
    brake[100:130:2] = 1.0  # a pulsing brake: one zone
    brake[300:310] = 0.5
    assert braking_points({"brake": brake}).tolist() == [100, 300]
