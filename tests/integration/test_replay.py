"""`boxbox replay` on real races, the page driven in Debian's chromium with Playwright: every car
drawn where the recording puts it, play, an incident's click; a race stopped by Ctrl-C, one stopped
by a robot fault, a bench-field race, and a race of TORCS robots alone (no recording: one line).

The 3-car test keeps a screenshot in its tmp_path and in test-artifacts/replay.png."""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np

from boxbox.torcs.recording import load_recording
from helpers import BOXBOX, ROBOTS, ROOT, VIEWPORT, open_page, read_json, run_boxbox

ARTIFACTS = ROOT / "test-artifacts"
def embedded_data(page_file: Path) -> dict:
    text = page_file.read_text()
    found = re.search(r'<script type="application/json" id="bbr-data">(.*?)</script>', text, re.S)
    assert found, "no replay data in the page"
    return json.loads(found.group(1))


def hex_rgb(color: str) -> tuple[int, int, int]:
    return int(color[1:3], 16), int(color[3:5], 16), int(color[5:7], 16)


def pixel(page, x: float, y: float) -> tuple[int, int, int]:
    return tuple(page.evaluate("([x, y]) => Array.from(replay.canvas.getContext('2d').getImageData("
                               "Math.round(x * devicePixelRatio), Math.round(y * devicePixelRatio), 1, 1).data)"
                               ".slice(0, 3)", [x, y]))


def spread_sample(rec, cars: list[int], after_s: float = 10.0) -> float:
    """A sample time after after_s with every car seen and every two at least 60 m apart (so no car
    or label covers another's centre), the widest such."""
    c = rec.columns
    best_t, best_gap = math.nan, 0.0
    for t in np.unique(c["time_s"][c["time_s"] > after_s])[::5]:
        at = c["time_s"] == t
        if sorted(c["car"][at].tolist()) != cars or c["out"][at].any():
            continue
        xy = np.column_stack([c["x_m"][at], c["y_m"][at]])
        gap = min(np.hypot(*(xy[i] - xy[j])) for i in range(len(xy)) for j in range(i + 1, len(xy)))
        if gap > best_gap:
            best_t, best_gap = float(t), gap
    assert best_gap > 60.0, f"no sample with the cars {best_gap:.0f} m apart"
    return best_t


def assert_cars_drawn_where_recorded(page, rec, data: dict, t: float) -> None:
    page.evaluate("t => replay.seek(t)", t)
    c = rec.columns
    for car in data["cars"]:
        row = np.flatnonzero((c["time_s"] == t) & (c["car"] == car["car"]))[0]
        sx, sy = page.evaluate("([x, y]) => replay.worldToScreen(x, y)", [float(c["x_m"][row]), float(c["y_m"][row])])
        assert 0 < sx < VIEWPORT["width"] and 0 < sy < 700, (car, sx, sy)
        got, want = pixel(page, sx, sy), hex_rgb(car["color"])
        assert max(abs(a - b) for a, b in zip(got, want, strict=True)) < 25, (car["name"], t, got, want)


def test_replay_of_a_three_car_race_in_chromium(tmp_path, overlay, browser):
    run_dir = tmp_path / "run"
    proc = run_boxbox("race", "--track", "aalborg", "--laps", "1", "--opponents", "bt:2,inferno:3",
                      "--learning", "off", "--run-dir", str(run_dir), "--report", str(tmp_path / "report"), "--quiet")
    assert proc.returncode == 0, proc.stderr
    made = run_boxbox("replay", str(run_dir))
    assert made.returncode == 0 and made.stdout.strip() == str(run_dir / "replay.html"), made.stderr
    page_file = run_dir / "replay.html"
    data = embedded_data(page_file)
    rec = load_recording(run_dir / "recording.parquet")
    result = read_json(run_dir / "result.json")
    assert sorted(c["car"] for c in data["cars"]) == rec.cars == sorted(d["car_index"] for d in result["drivers"])
    assert {c["name"] for c in data["cars"]} == {d["name"] for d in result["drivers"]}
    page, errors = open_page(browser, page_file)

    t = spread_sample(rec, rec.cars)
    assert_cars_drawn_where_recorded(page, rec, data, t)
    page.screenshot(path=str(tmp_path / "replay.png"))
    ARTIFACTS.mkdir(exist_ok=True)
    shutil.copy(tmp_path / "replay.png", ARTIFACTS / "replay.png")
    me = next(c for c in data["cars"] if c["python"])
    page.evaluate("car => { replay.view('follow'); replay.follow(car); }", me["car"])
    assert_cars_drawn_where_recorded(page, rec, {"cars": [me]}, t)  # zoomed in, the car in the middle
    assert me["name"] in page.inner_text(".bbr-panel") and "km/h" in page.inner_text(".bbr-panel")

    page.evaluate("() => { replay.view('track'); replay.seek(replay.start + 5); replay.setSpeed(4); replay.play(); }")
    page.wait_for_timeout(1000)
    played = page.evaluate("() => replay.time() - replay.start - 5")
    page.evaluate("() => replay.pause()")
    assert 1.5 < played < 8.0, played  # 4x for about a second (rendering in a loaded machine is slower)

    assert data["incidents"], "a lap of aalborg with three cars has incidents"
    k = len(data["incidents"]) // 2
    incident = data["incidents"][k]
    page.click(f".bbr-list tbody tr >> nth={k}")
    now = page.evaluate("() => replay.time()")
    page.evaluate("() => replay.pause()")
    assert incident["time_s"] - 3.2 <= now <= incident["time_s"] - 1.0, (now, incident)
    if incident["cars"]:
        followed = next(c for c in data["cars"] if c["car"] == incident["cars"][0])
        assert followed["label"] in page.inner_text(".bbr-panel")
    assert errors == []

    report, report_errors = open_page(browser, tmp_path / "report" / "report.html")  # the report has the viewer
    assert report.evaluate("() => replay.cars.length") == 3 and report_errors == []


def wait_for(predicate, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return False


def test_replay_of_a_race_stopped_by_ctrl_c(tmp_path, overlay, browser):
    run_dir = tmp_path / "run"
    proc = subprocess.Popen([*BOXBOX, "race", "--track", "g-track-1", "--laps", "5", "--robot",
                             f"{ROBOTS / 'faulty.py'}:Slow", "--opponents", "bt:2", "--learning", "off", "--quiet",
                             "--run-dir", str(run_dir)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=ROOT, env=dict(os.environ, COLUMNS="200"))
    try:
        # TORCS prints a lap's line as the leader starts it: lap 2's, then lap 1 is done
        assert wait_for(lambda: "Leader Laps:    2" in (run_dir / "torcs.out").read_text(errors="replace")
                        if (run_dir / "torcs.out").exists() else False, 60), "lap 1 was not done"
        time.sleep(0.3)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    made = run_boxbox("replay", str(run_dir), "--out", str(tmp_path / "stopped.html"))
    assert made.returncode == 0, made.stderr
    data = embedded_data(tmp_path / "stopped.html")
    result = read_json(run_dir / "result.json")
    lap_s = min(d["lap_times"][0] for d in result["drivers"] if d["lap_times"])
    assert len(data["cars"]) == 2 and data["samples"] > 10 * lap_s  # up to the Ctrl-C, after the first lap
    assert data["incidents"][-1]["kind"] == "stopped" and "interrupted" in data["incidents"][-1]["text"]
    page, errors = open_page(browser, tmp_path / "stopped.html")
    assert page.evaluate("() => replay.end - replay.start") > lap_s and errors == []


def test_replay_of_a_race_stopped_by_a_robot_fault(tmp_path, overlay):
    robot_file = tmp_path / "late.py"
    robot_file.write_text(
        "from boxbox.robot.simple import MiddleRobot\n"
        "class FailsAtTwenty(MiddleRobot):\n"
        "    def drive(self, s):\n"
        "        if s.sim_time_s > 20: raise RuntimeError('late failure')\n"
        "        return super().drive(s)\n")
    run_dir = tmp_path / "run"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--robot", f"{robot_file}:FailsAtTwenty",
                      "--opponents", "bt:2", "--run-dir", str(run_dir), "--quiet")
    assert proc.returncode == 4, proc.stderr
    made = run_boxbox("replay", str(run_dir))
    assert made.returncode == 0, made.stderr
    data = embedded_data(run_dir / "replay.html")
    me = next(c for c in data["cars"] if c["python"])
    [fault] = [i for i in data["incidents"] if i["kind"] == "fault"]
    assert fault["cars"] == [me["car"]] and 19.9 < fault["time_s"] < 20.2 and "late failure" in fault["text"]
    assert fault["dist_m"] > 100.0  # where the car was on the track then
    rec = load_recording(run_dir / "recording.parquet")
    # up to the fault: then the bridge stops asking the robot host (it brakes the car itself)
    assert 19.5 < rec.columns["time_s"].max() <= 20.0 and len(rec.cars) == 2


def test_replay_of_a_bench_field_race_and_the_footer_naming_it(tmp_path, overlay):
    out = tmp_path / "f.json"
    r = run_boxbox("bench-field", "--tracks", "g-track-1", "--laps", "1", "--no-cache", "--json", str(out),
                   timeout=600)
    assert r.returncode == 0, r.stderr
    robot, anchor = read_json(out)["rows"]
    assert f"replay: boxbox replay {robot['run_dir']}" in r.stdout  # the anchor race has no Python car
    made = run_boxbox("replay", robot["run_dir"], "--out", str(tmp_path / "field.html"))
    assert made.returncode == 0, made.stderr
    data = embedded_data(tmp_path / "field.html")
    assert len(data["cars"]) == 10 and any(i["kind"] == "pass" for i in data["incidents"])
    none = run_boxbox("replay", anchor["run_dir"])
    assert none.returncode == 2 and "no recording" in none.stderr


def test_a_race_of_torcs_robots_alone_has_no_replay(tmp_path, overlay):
    from boxbox.torcs import launch

    run_dir = tmp_path / "run"
    cfg = launch.RaceConfig(track="g-track-1", category="road", laps=1, robots=[], opponents=[("bt", 2)],
                            run_dir=run_dir)
    result = launch.run_race(cfg, overlay)
    assert result.error is None and not (run_dir / "recording.parquet").exists()
    proc = run_boxbox("replay", str(run_dir))
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1 and "no recording" in lines[0], proc.stderr
    assert not (run_dir / "replay.html").exists()


def test_bench_and_sweep_tables_end_with_how_to_replay_a_race(tmp_path, overlay):
    bench = run_boxbox("bench", "--tracks", "g-track-1", "--robots", "boxbox", "--laps", "1", "--no-cache",
                       "--no-limit", "--json", str(tmp_path / "b.json"), timeout=300)
    assert bench.returncode == 0, bench.stderr
    [row] = read_json(tmp_path / "b.json")["rows"]
    assert bench.stdout.strip().splitlines()[-1] == f"replay: boxbox replay {row['run_dir']}"
    sweep = run_boxbox("sweep", "--tracks", "g-track-1", "--cars", "car1-trb1", "--laps", "1", "--no-cache",
                       "--json", str(tmp_path / "s.json"), timeout=300)
    assert sweep.returncode == 0, sweep.stderr
    run_dir = read_json(tmp_path / "s.json")["rows"][0]["run_dir"]
    assert f"replay: boxbox replay {run_dir}" in sweep.stdout
    assert run_boxbox("replay", run_dir, "--out", str(tmp_path / "sweep.html")).returncode == 0
