"""The replay page's pieces without a race: names for the cars, the held samples, the benches' footer."""

from __future__ import annotations

import numpy as np

from boxbox.report.incidents import Frames
from boxbox.report.replay import car_names, encode_frames, replay_line

GRID = [{"car": 0, "module": "bt", "idx": 2}, {"car": 1, "module": "boxbox", "idx": 0}]
META = {"grid": GRID, "python": [{"car": 1, "robot_index": 0, "name": "boxbox 1", "robot": "boxbox"}]}


def test_names_from_the_result_else_from_the_grid():
    """A race stopped before TORCS wrote its results has no car index in result.json: race.xml's
    grid (module and idx) still finds each car."""
    result = {"drivers": [{"name": "bt 3", "module": "bt", "idx": 2, "car_index": -1},
                          {"name": "boxbox 1", "module": "boxbox", "idx": 0, "car_index": -1}]}
    cars = car_names(META, result)
    assert cars[0] == {"name": "bt 3", "label": "bt 3 (bt:2)", "python": False}
    assert cars[1]["name"] == "boxbox 1" and cars[1]["python"]
    assert car_names(META, {})[0]["name"] == "bt 2"  # no result at all: the grid's module and idx


def test_a_car_not_seen_is_held_where_it_was_last_seen():
    cols = {"car": np.array([0, 1, 0, 0]), "time_s": np.array([0.0, 0.0, 0.1, 0.2]),
            "x_m": np.array([1.0, 5.0, 2.0, 3.0]), "y_m": np.zeros(4), "yaw_rad": np.zeros(4),
            "speed_mps": np.zeros(4), "damage": np.zeros(4), "place": np.array([1.0, 2.0, 1.0, 1.0]),
            "lap": np.ones(4), "gear": np.array([3.0, np.nan, 3.0, 4.0]), "accel": np.array([1.0, np.nan, 0.5, 0.0]),
            "brake": np.zeros(4), "steer": np.zeros(4)}
    for flag in ("in_pit", "in_pit_lane", "off_track", "out", "python"):
        cols[flag] = np.zeros(4, bool)
    frames = encode_frames(Frames.from_columns(cols))
    import base64

    x = np.frombuffer(base64.b64decode(frames["x"]), "<f4").reshape(2, 3)
    flags = np.frombuffer(base64.b64decode(frames["flags"]), "u1").reshape(2, 3)
    accel = np.frombuffer(base64.b64decode(frames["accel"]), "i1").reshape(2, 3)
    assert x.tolist() == [[1.0, 2.0, 3.0], [5.0, 5.0, 5.0]]  # car 1 seen once, held after
    assert (flags[:, :] & 1).tolist() == [[1, 1, 1], [1, 0, 0]]  # ... and marked not seen
    assert accel.tolist() == [[100, 50, 0], [-128, -128, -128]]  # a TORCS robot's controls: unknown


def test_the_footer_names_a_recorded_run_dir(tmp_path):
    kept, gone = tmp_path / "kept", tmp_path / "gone"
    kept.mkdir()
    (kept / "recording.parquet").write_bytes(b"")
    assert replay_line([str(gone), str(kept), str(kept), ""]) == f"replay: boxbox replay {kept}"
    assert replay_line([str(gone)]).startswith("replay: none of these races has a recording")


def _no_replay(run_dir) -> str:
    """The one line `boxbox replay` answers for run_dir (a UsageError's)."""
    import pytest

    from boxbox.errors import UsageError
    from boxbox.report.replay import build_replay

    with pytest.raises(UsageError) as raised:
        build_replay(run_dir)
    text = str(raised.value)
    assert "\n" not in text
    return text


def _write_json(path, data) -> None:
    import json

    path.write_text(json.dumps(data))


def test_each_race_without_a_recording_gets_its_own_sentence(tmp_path):
    """An empty folder, a race of TORCS robots alone, one stopped before its first drive step and
    one run with --no-telemetry: each says why it has no recording, not the same sentence for all."""
    empty = tmp_path / "empty"
    empty.mkdir()
    assert "is not a race's run dir" in _no_replay(empty)

    alone = tmp_path / "alone"
    alone.mkdir()
    _write_json(alone / "result.json", {"drivers": [{"name": "bt 3", "module": "bt", "idx": 2, "laps": 1,
                                                     "time": 80.0, "lap_times": [80.0]}], "error": None})
    assert "TORCS robots alone" in _no_replay(alone)

    early = tmp_path / "early"
    early.mkdir()
    _write_json(early / "host-spec.json", {"robots": [{"spec": "mine.py:Mine", "name": "mine 1"}], "telemetry": True})
    _write_json(early / "result.json", {"drivers": [{"name": "mine 1", "module": "boxbox", "idx": 0, "laps": 0,
                                                     "time": 0.0, "lap_times": []}],
                                        "error": "robot 'mine.py:Mine' (mine 1) failed: RuntimeError: x (in on_track)"
                                                 "\nTraceback (most recent call last):\n  ..."})
    line = _no_replay(early)
    assert "stopped before its first drive step" in line and "RuntimeError: x (in on_track)" in line
    assert "Traceback" not in line

    untimed = tmp_path / "untimed"
    untimed.mkdir()
    _write_json(untimed / "host-spec.json", {"robots": [{"spec": "mine.py:Mine", "name": "mine 1"}],
                                             "telemetry": False})
    assert "--no-telemetry" in _no_replay(untimed)
    assert len({_no_replay(d).split(": ", 1)[1] for d in (empty, alone, early, untimed)}) == 4


def test_an_empty_recording_and_a_recording_of_other_columns_are_one_line_each(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from boxbox.torcs.recording import COLUMNS

    empty = tmp_path / "empty"
    empty.mkdir()
    pq.write_table(pa.table({name: pa.array([], pa.float64()) for name, _ in COLUMNS}), empty / "recording.parquet")
    assert "is empty" in _no_replay(empty)

    other = tmp_path / "other"
    other.mkdir()
    pq.write_table(pa.table({"time_s": [0.0, 0.1], "speed": [1.0, 2.0]}), other / "recording.parquet")
    assert "is not a boxbox race recording (no column car, python, lap, ...)" in _no_replay(other)
