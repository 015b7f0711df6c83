"""Telemetry and the race report on real races; the page opened in headless Chromium.

The Chromium test keeps test-artifacts/report.png (a screenshot) and test-artifacts/report.html.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from boxbox.torcs.telemetry import FILE_NAME, load_telemetry
from helpers import ROOT, read_json, run_boxbox

ARTIFACTS = ROOT / "test-artifacts"

# injected into a copy of the page: marks every image with its decoded size once it loaded (or failed)
PROBE = """<script>
for (const img of document.images) {
  const mark = () => img.setAttribute("data-natural", img.naturalWidth + "x" + img.naturalHeight);
  if (img.complete) { mark(); } else { img.addEventListener("load", mark); img.addEventListener("error", mark); }
}
</script>"""


@pytest.fixture(scope="session")
def chromium():
    """Debian's chromium, installed when missing (as the repo's setup does for TORCS)."""
    from boxbox.torcs import setup

    return setup.ensure_chromium()


def chromium_cmd(browser, profile, *args: str) -> list[str]:
    return [str(browser), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            f"--user-data-dir={profile}", *args]


def test_report_of_a_short_race_loads_every_figure_in_chromium(tmp_path, overlay, chromium):
    run_dir, report_dir = tmp_path / "run", tmp_path / "report"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--pit-laps", "1", "--opponents", "bt:2",
                      "--learning", "off", "--run-dir", str(run_dir), "--report", str(report_dir), "--quiet")
    assert proc.returncode == 0, proc.stderr
    r = read_json(run_dir / "result.json")
    assert r["skill_level"] == "semi-pro" and "skill level semi-pro" in (report_dir / "report.html").read_text()
    assert "skill level semi-pro" in proc.stdout  # the console table's title
    me = next(d for d in r["drivers"] if d["module"] == "boxbox")
    # telemetry beside result.json: every drive step, the robot's target speed and signals, the stop
    tel = load_telemetry(run_dir / FILE_NAME)
    c = tel.columns
    assert tel.rows > 0.9 * sum(me["lap_times"]) / 0.02
    # the stop itself is one row at the time of the last drive step before it
    assert np.all(np.diff(c["time_s"]) >= 0) and (np.diff(c["time_s"]) == 0).sum() <= 1
    assert set(np.unique(c["lap"])) >= {1, 2}
    assert np.isfinite(c["target_speed_mps"]).all() and "sig_pit_phase" in c and (c["sig_pit_phase"] > 0).any()
    assert c["in_pit"].sum() == 1 and c["speed_mps"][c["in_pit"]][0] < 1.5
    assert tel.meta["track"]["pit"]["speed_limit_mps"] > 0 and len(tel.meta["track"]["edges"]["left_x"]) > 100
    # the nearest other car every step: bt:2, the only one, on the grid a few metres off our car
    bt = next(d for d in r["drivers"] if d["module"] == "bt")
    driving = ~c["in_pit"]  # the stop's row is recorded off the drive step, with no other car
    assert set(np.unique(c["near_car"][driving])) == {bt["car_index"]} and c["near_car"][c["in_pit"]][0] == -1
    start = np.hypot(c["near_ahead_m"][0], c["near_left_m"][0])
    assert 2.0 < start < 20.0 and np.isfinite(c["near_left_m"][driving]).all()

    page_file = report_dir / "report.html"
    page = page_file.read_text()
    n_images = page.count("<img ")
    took = bool((np.diff(c["damage"]) > 0).any())  # then a map of where (the race's result may be after a repair)
    assert ("No damage taken." in page) != took and ("where the damage was taken" in page) == took
    # lap-time bars, the places lap by lap (two cars), track map, the pit stop, two laps
    assert n_images == 6 + took
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", PROBE + "</body>"))
    dom = subprocess.run(chromium_cmd(chromium, tmp_path / "profile-dom", "--virtual-time-budget=10000", "--dump-dom",
                                      probe.as_uri()), capture_output=True, text=True, timeout=120)
    assert dom.returncode == 0, dom.stderr[-2000:]
    sizes = [(int(w), int(h)) for w, h in re.findall(r'data-natural="(\d+)x(\d+)"', dom.stdout)]
    assert len(sizes) == n_images, dom.stdout[-2000:]
    assert all(w > 100 and h > 100 for w, h in sizes), sizes

    ARTIFACTS.mkdir(exist_ok=True)
    shot = ARTIFACTS / "report.png"
    shot.unlink(missing_ok=True)
    done = subprocess.run(chromium_cmd(chromium, tmp_path / "profile-shot", "--hide-scrollbars",
                                       "--window-size=1280,3000", f"--screenshot={shot}", page_file.as_uri()),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and shot.exists(), done.stderr[-2000:]
    shutil.copy(page_file, ARTIFACTS / "report.html")
    import matplotlib.image as mpimg

    pixels = mpimg.imread(shot)
    assert pixels.shape[:2] == (3000, 1280) and pixels[..., :3].std() > 0.05  # not a blank page


def test_telemetry_survives_a_robot_fault_and_can_be_turned_off(tmp_path, overlay):
    robot_file = tmp_path / "late.py"
    robot_file.write_text(
        "from boxbox.robot.simple import MiddleRobot\n"
        "class FailsInLapTwo(MiddleRobot):\n"
        "    def drive(self, s):\n"
        "        if s.laps >= 2 and s.cur_lap_time_s > 2: raise RuntimeError('late failure')\n"
        "        return super().drive(s)\n")
    run_dir = tmp_path / "run"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "3", "--robot", f"{robot_file}:FailsInLapTwo",
                      "--run-dir", str(run_dir), "--report", str(tmp_path / "rep"), "--quiet")
    assert proc.returncode == 4, proc.stderr
    c = load_telemetry(run_dir / FILE_NAME).columns
    assert c["lap"].max() == 2 and c["time_s"].max() > 30  # lap 1 whole, lap 2 up to the failure
    page = (tmp_path / "rep" / "report.html").read_text()
    assert "The race stopped early" in page and "late failure" in page

    off = tmp_path / "off"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--robot", "middle", "--no-telemetry",
                      "--run-dir", str(off), "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert not (off / FILE_NAME).exists()
    proc = run_boxbox("report", str(off))
    assert proc.returncode == 0, proc.stderr
    assert "no telemetry recorded" in (off / "report.html").read_text()


def test_bench_telemetry_prints_the_ratio(tmp_path, overlay):
    proc = run_boxbox("bench-telemetry", "--laps", "4", "--runs", "1", "--json", str(tmp_path / "b.json"))
    assert proc.returncode == 0, proc.stderr
    assert "step time ratio, telemetry on / off:" in proc.stdout
    b = read_json(tmp_path / "b.json")
    assert [r["mode"] for r in b["races"]] == ["on", "off"]
    assert b["races"][0]["telemetry_bytes"] > 0 and b["races"][1]["telemetry_bytes"] == 0
    assert b["ratio"] == pytest.approx(b["step_us_median_on"] / b["step_us_median_off"])
