"""The replay viewer and the report page in Debian's chromium with Playwright, on made-up data (no
TORCS: what is tested is the page): the clock at the start and after the finish, the labels of a
grid (none on another, none cut at the canvas's edge), a click on an incident at 16x, seek(NaN),
and the report's traceback in a fixed-width font."""

from __future__ import annotations

import json
import math

import numpy as np

from boxbox.report.incidents import Frames
from boxbox.report.replay import COLORS, Replay, encode_frames, replay_page
from helpers import open_page

LAPS = 3
T0_S = -0.02  # the first sample, a step before the start, as a race's recording has it
END_S = 60.0
INCIDENT_S = 30.0
GRID = [(-40.0 + 8.0 * (k // 2), -100.0 - 4.0 * (k % 2)) for k in range(10)]  # 10 cars, 8 m apart, in pairs
EDGE_CAR = (600.0, 0.0)  # the track's right-most point: at the canvas's right edge


def oval_edges(a_m: float = 600.0, b_m: float = 100.0, half_width_m: float = 6.0) -> dict:
    """An ellipse's edges: wide, so its ends reach the canvas's left and right edges."""
    u = np.linspace(0.0, 2.0 * math.pi, 121)
    return {f"{side}_{axis}": (np.cos(u) * (a_m + sign * half_width_m) if axis == "x"
                               else np.sin(u) * (b_m + sign * half_width_m)).round(2).tolist()
            for side, sign in (("left", 1.0), ("right", -1.0)) for axis in ("x", "y")}


def made_up_replay() -> Replay:
    """11 cars standing still (a grid of 10 and one at the track's end) from T0_S to END_S, the
    leader's lap counted past the race's laps at the end as TORCS counts a finished car's."""
    times = np.round(np.arange(T0_S, END_S, 0.1), 3)
    spots = [*GRID, EDGE_CAR]
    n_cars, n_t = len(spots), len(times)
    car = np.tile(np.arange(n_cars), n_t)
    cols = {"car": car, "time_s": np.repeat(times, n_cars),
            "x_m": np.array([spots[c][0] for c in car]), "y_m": np.array([spots[c][1] for c in car]),
            "yaw_rad": np.zeros(len(car)), "speed_mps": np.zeros(len(car)), "damage": np.zeros(len(car)),
            "place": car + 1.0, "lap": np.repeat(np.minimum(LAPS + 1, times // 15 + 1), n_cars),
            "gear": np.ones(len(car)), "accel": np.zeros(len(car)), "brake": np.zeros(len(car)),
            "steer": np.zeros(len(car))}
    for flag in ("in_pit", "in_pit_lane", "off_track", "out", "python"):
        cols[flag] = np.zeros(len(car), bool)
    cars = [{"car": c, "color": COLORS[c % len(COLORS)], "name": f"robot {c}", "label": f"robot {c} (bt:{c})",
             "python": c == 0, "length_m": 4.5, "width_m": 1.9} for c in range(n_cars)]
    incident = {"kind": "contact", "time_s": INCIDENT_S, "lap": 2, "cars": [3], "dist_m": 100.0, "damage": 50,
                "text": "robot 3 hit robot 4"}
    data = {"track": {"edges": oval_edges()}, "cars": cars, "incidents": [incident],
            "frames": encode_frames(Frames.from_columns(cols)), "samples": n_t, "laps": LAPS, "error": None}
    return Replay(data=data, title="made up, 3 laps, 11 cars")


def test_the_viewer_clock_labels_incident_click_and_seek(tmp_path, browser):
    page_file = tmp_path / "replay.html"
    page_file.write_text(replay_page(made_up_replay()))
    page, errors = open_page(browser, page_file)

    assert page.evaluate("() => replay.start") < 0
    assert page.inner_text(".bbr-clock").startswith("t 0:00.0 · lap ")  # not "t -0:00.0"
    page.evaluate("() => replay.seek(replay.end)")
    assert " · lap 3 of 3 · " in page.inner_text(".bbr-clock")  # not "lap 4 of 3" after the finish
    assert page.inner_text(".bbr-panel").count("3 of 3") == 1

    page.evaluate("() => replay.seek(replay.start)")
    labels = page.evaluate("() => replay.labels()")
    width, height = page.evaluate("() => [replay.canvas.clientWidth, replay.canvas.clientHeight]")
    assert sorted(r["car"] for r in labels) == list(range(11))  # every car labelled, the grid too
    for r in labels:  # none cut at the canvas's edge (the car at the track's end included)
        assert 0 <= r["x"] and r["x"] + r["w"] <= width and 0 <= r["y"] and r["y"] + r["h"] <= height, r
    for i, a in enumerate(labels):  # none on another
        for b in labels[i + 1:]:
            apart = (a["x"] + a["w"] <= b["x"] or b["x"] + b["w"] <= a["x"] or a["y"] + a["h"] <= b["y"]
                     or b["y"] + b["h"] <= a["y"])
            assert apart, (a, b)

    page.evaluate("() => replay.setSpeed(16)")
    page.click(".bbr-list tbody tr >> nth=0")
    assert page.input_value(".bbr-speed") == "1"
    page.wait_for_timeout(500)
    now = page.evaluate("() => replay.time()")
    page.evaluate("() => replay.pause()")
    assert INCIDENT_S - 3.2 <= now < INCIDENT_S, now  # played from 3 s before it, at 1x: not past it yet

    page.evaluate("() => replay.seek(12.5)")
    page.evaluate("() => replay.seek(NaN)")
    assert page.evaluate("() => replay.time()") == 12.5
    assert "NaN" not in page.inner_text(".bbr-clock") and errors == []


def test_the_report_shows_a_traceback_in_a_fixed_width_font(tmp_path, browser):
    from boxbox.report.race_report import write_report

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    error = ("robot 'mine.py:Mine' (mine 1) failed: RuntimeError: x (in drive)\nTraceback (most recent call last):\n"
             '  File "mine.py", line 9, in drive\n    raise RuntimeError("x")\nRuntimeError: x')
    (run_dir / "result.json").write_text(json.dumps({"track": "g-track-1", "category": "road", "car": "car1-trb1",
                                                     "laps": 1, "wall_s": 1.0, "drivers": [], "error": error}))
    page, errors = open_page(browser, write_report(run_dir), ready=None)
    font = page.evaluate("""() => {
        const all = [...document.querySelectorAll('.error, .error *')];
        const box = all.filter((e) => e.textContent.includes('Traceback (most recent call last)')).pop();
        return getComputedStyle(box).fontFamily;
    }""")
    assert "monospace" in font, font
    assert page.inner_text(".error").count("Traceback (most recent call last)") == 1 and errors == []
