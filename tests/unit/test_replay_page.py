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
