"""`boxbox limit` for real: the recorder robot's 0-lap race, the limit lap and its plot."""

import json
import re

import numpy as np
import pytest

from boxbox.bench.limit import limit_lap
from boxbox.model.skill import SkillLevel
from boxbox.robot.recorder import RECORD_FILE, load_track
from boxbox.torcs import launch
from helpers import run_boxbox


def test_the_recorder_saves_track_sides_and_car(tmp_path, overlay):
    cfg = launch.RaceConfig(track="aalborg", category="road", laps=0, telemetry=False,
                            robots=["boxbox.robot.recorder:Recorder"], run_dir=tmp_path / "run")
    result = launch.run_race(cfg, overlay)
    assert result.error is None, result.error
    track, car = load_track(tmp_path / "run" / RECORD_FILE)
    assert track.n_segments > 100 and track.length_m > 2000
    # aalborg has asphalt beside the track on both sides (track file: 3 m on the left at the start)
    assert track.seg["left_outer_start_width_m"][0] > 2.0 and track.seg["right_outer_friction"][0] > 1.0
    assert car.max_gear == 6 and len(car.torque_curve_nm) > 5 and abs(car.tyre_load_factor_max_rr - 1.6) < 1e-6
    strict = limit_lap(track, car, SkillLevel.SEMI_PRO, "strict", step_m=6.0)
    torcs = limit_lap(track, car, SkillLevel.SEMI_PRO, "torcs", step_m=6.0)
    assert torcs.lap_time_s <= strict.lap_time_s  # more room is never slower (the strict line is a candidate)
    assert np.all(torcs.left_m >= strict.left_m) and np.all(torcs.right_m >= strict.right_m)
    assert 50.0 < torcs.lap_time_s < 66.96  # below the championship robot's best lap there


def test_limit_prints_the_time_and_writes_the_plot(tmp_path):
    proc = run_boxbox("limit", "--track", "michigan", "--plot", str(tmp_path / "michigan.png"),
                      "--json", str(tmp_path / "michigan.json"))
    assert proc.returncode == 0, proc.stderr
    lap = float(re.search(r"limit lap ([0-9.]+) s", proc.stdout).group(1))
    assert 25.0 < lap < 34.1  # below every robot's best lap on michigan (34.12 s, boxbox at semi-pro)
    saved = json.loads((tmp_path / "michigan.json").read_text())
    assert saved["lap_time_s"] == pytest.approx(lap, abs=0.01) and len(saved["speed_mps"]) == len(saved["dist_m"]) > 500
    assert (tmp_path / "michigan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_limit_refuses_bad_input():
    for args in (["--track", "nosuch"], ["--track", "aalborg", "--track-limits", "wide"],
                 ["--track", "aalborg", "--skill-level", "expert"]):
        proc = run_boxbox("limit", *args)
        assert proc.returncode == 2, (args, proc.stderr)
        assert proc.stderr.count("\n") == 1, proc.stderr
