"""The race recording (torcs/recording.py) on DRIVE messages packed as the bridge packs them."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from boxbox.model import Controls
from boxbox.torcs import wire
from boxbox.torcs.racefile import Entry, race_xml
from boxbox.torcs.recording import (
    RaceRecorder,
    add_track_columns,
    decode,
    load_recording,
    merge_rows,
    pit_lane_outline,
    write_recording,
)
from boxbox.torcs.rundir import RunDir
from trackdata import build_track, load

H = wire.HEADER.size


def drive_message(buf: bytearray, t: float, me: dict, others: list[dict]) -> int:
    """A DRIVE message in buf (header, our state, the others in race order); returns the count."""
    state = dict.fromkeys(wire.STATE_FIELDS, 0.0) | {"sim_time_s": t} | me
    wire.STATE_REC.pack_into(buf, H, *(state[f] for f in wire.STATE_FIELDS))
    for i, o in enumerate(others):
        rec = dict.fromkeys(wire.OPPONENT_FIELDS, 0.0) | {"length_m": 4.5, "width_m": 1.9} | o
        wire.OPPONENT_REC.pack_into(buf, H + wire.STATE_REC.size + i * wire.OPPONENT_REC.size,
                                    *(rec[f] for f in wire.OPPONENT_FIELDS))
    return len(others)


def race_of_two_python_cars(rec: RaceRecorder, buf: bytearray, steps: int = 16, first: int = 0) -> None:
    """Python cars 0 and 1 (robots 0 and 1) and a TORCS car 2, every 0.02 s: car 1 leads, then car 2,
    then car 0; each Python car sees the other two."""
    for k in range(first, first + steps):
        t = round(k * 0.02, 3)
        cars = {c: {"car_index": float(c), "x_m": 10.0 * c + t, "y_m": float(c), "damage": 7.0 * c} for c in range(3)}
        for robot, others in ((0, [1, 2]), (1, [2, 0])):
            me = {"x_m": cars[robot]["x_m"], "y_m": cars[robot]["y_m"], "position": 3.0 if robot == 0 else 1.0,
                  "damage": cars[robot]["damage"], "gear": 3.0, "laps": 1.0}
            count = drive_message(buf, t, me, [cars[o] for o in others])
            rec.step(robot, t, count, Controls(steer=0.1 * robot, accel=0.5, brake=0.0, gear=3))


def test_every_car_once_per_sample_the_python_cars_with_their_controls():
    buf = bytearray(wire.MAX_MESSAGE_BYTES)
    rec = RaceRecorder(buf)
    race_of_two_python_cars(rec, buf)
    records = decode(rec.data())
    assert len(records) == 2 * 4  # samples at 0, 0.1 (the 6th step), 0.2, 0.3: two Python cars each
    cols = merge_rows(records, {0: 0, 1: 1})
    assert len(cols["car"]) == 4 * 3
    times = np.unique(cols["time_s"])
    assert np.allclose(times, [0.0, 0.1, 0.2, 0.3])
    at = cols["time_s"] == times[1]
    assert cols["car"][at].tolist() == [0, 1, 2]
    assert cols["python"][at].tolist() == [True, True, False]
    assert np.allclose(cols["x_m"][at], [0.1, 10.1, 20.1]) and cols["damage"][at].tolist() == [0, 7, 14]
    assert cols["place"][at].tolist() == [3, 1, 2]  # the TORCS car's place from the order the cars come in
    assert np.allclose(cols["steer"][at][:2], [0.0, 0.1]) and math.isnan(cols["steer"][at][2])
    assert cols["gear"][at][0] == 3 and math.isnan(cols["gear"][at][2])


def test_a_python_car_not_driven_is_kept_as_another_saw_it():
    """Car 1 standing in its pit (no drive step of its own): car 0's sighting of it fills in."""
    buf = bytearray(wire.MAX_MESSAGE_BYTES)
    rec = RaceRecorder(buf)
    count = drive_message(buf, 0.0, {"x_m": 1.0, "position": 2.0}, [{"car_index": 1.0, "x_m": 5.0, "car_state": 1.0}])
    rec.step(0, 0.0, count, Controls())
    cols = merge_rows(decode(rec.data()), {0: 0, 1: 1})
    assert cols["car"].tolist() == [0, 1] and cols["python"].tolist() == [True, False]
    assert cols["x_m"].tolist() == [1.0, 5.0] and cols["place"].tolist() == [2, 1]


def test_a_record_cut_short_ends_the_recording_there():
    buf = bytearray(wire.MAX_MESSAGE_BYTES)
    rec = RaceRecorder(buf)
    race_of_two_python_cars(rec, buf)
    data = rec.data()
    assert len(decode(data[:-8])) == len(decode(data)) - 1 and len(decode(b"")) == 0


def test_the_spool_takes_the_buffer_and_a_full_disk_stops_the_recording(tmp_path):
    buf = bytearray(wire.MAX_MESSAGE_BYTES)
    rec = RaceRecorder(buf, tmp_path / "spool")
    race_of_two_python_cars(rec, buf, steps=6)
    assert rec.spill() and not rec.rows and (tmp_path / "spool").stat().st_size > 0
    race_of_two_python_cars(rec, buf, steps=11, first=6)  # 0.12 to 0.32 s: samples at 0.2 and 0.3 s
    assert len(decode(rec.data())) == 4 + 4  # the spooled records first, then the buffered ones
    broken = RaceRecorder(buf, tmp_path / "missing" / "spool")
    race_of_two_python_cars(broken, buf, steps=6)
    assert not broken.spill() and broken.storage_error and "No such file" in broken.storage_error
    race_of_two_python_cars(broken, buf, steps=6)
    assert broken.data() == b""  # nothing more kept after the failure


def test_track_columns_off_track_heading_and_the_pit_lane():
    track = build_track([("S", 200.0), ("L", 50.0, 180.0), ("S", 200.0), ("L", 50.0, 180.0)], width_m=12.0)
    cols = {"car": np.zeros(4), "seg_id": np.array([2.0, 2.0, 45.0, np.nan]), "to_start": np.array([1.0, 1.0, 0.02, 0]),
            "to_middle_m": np.array([0.0, -6.5, 0.0, 0.0]), "yaw_rad": np.array([0.1, 0.0, 0.0, 0.0])}
    add_track_columns(cols, track)
    assert cols["off_track"].tolist() == [False, True, False, False]
    h = cols["heading_to_track_rad"]
    assert h[0] == pytest.approx(0.1)
    turn = 45  # a segment of the first turn: the track's direction there is its start angle + to_start
    expected = (0.0 - (track.seg["start_angle_rad"][turn] + 0.02) + math.pi) % (2 * math.pi) - math.pi
    assert h[2] == pytest.approx(expected) and math.isnan(h[3])


def test_the_pit_lane_outline_runs_beside_the_pit_side_edge():
    track, _ = load("g-track-1")
    lane = pit_lane_outline(track)
    assert lane is not None and len(lane["outer_x"]) == len(lane["edge_x"]) > 10
    gap = np.hypot(np.subtract(lane["outer_x"], lane["edge_x"]), np.subtract(lane["outer_y"], lane["edge_y"]))
    assert gap[0] < 0.01 and gap.max() == pytest.approx(track.pit.width_m, abs=0.02)


def test_written_and_read_back_with_the_grid_and_the_track(tmp_path):
    run_dir = RunDir(tmp_path)
    run_dir.race_file.write_text(race_xml("g-track-1", "road", 2, [Entry("boxbox", 0), Entry("boxbox", 1),
                                                                   Entry("bt", 2)]))
    buf = bytearray(wire.MAX_MESSAGE_BYTES)
    rec = RaceRecorder(buf, run_dir.recording_spool)
    race_of_two_python_cars(rec, buf)
    rec.spill()
    track, car = load("g-track-1")
    slots = [SimpleNamespace(car=SimpleNamespace(car_index=i, length_m=4.7, width_m=2.0, pit_seg=-1), track=track,
                             name=f"boxbox {i + 1}", spec="boxbox") for i in range(2)]
    assert write_recording(rec, run_dir, slots) == []
    assert not run_dir.recording_spool.exists()
    r = load_recording(run_dir.recording)
    assert r.rows == 12 and r.cars == [0, 1, 2]
    assert r.meta["grid"] == [{"car": 0, "module": "boxbox", "idx": 0}, {"car": 1, "module": "boxbox", "idx": 1},
                              {"car": 2, "module": "bt", "idx": 2}]
    assert r.meta["cars"]["0"] == {"length_m": 4.7, "width_m": 2.0} and r.meta["cars"]["2"]["length_m"] == 4.5
    assert r.meta["track"]["pit_lane"] and len(r.meta["track"]["edges"]["left_x"]) > 100
    assert r.columns["x_m"].dtype == np.float64 and np.isnan(r.columns["accel"][r.columns["car"] == 2]).all()
