"""The race report renders whatever a run dir holds, and a report that fails never hides the race's
own error and exit status (issue 48, items 3 and 8)."""

from __future__ import annotations

import json

import pytest

import boxbox
from helpers import ROBOTS, read_json, run_boxbox

FAULTY = ROBOTS / "faulty.py"
CONTRACT = ROBOTS / "contract.py"


def error_lines(proc) -> list[str]:
    return [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]


def test_a_fault_before_the_first_lap_still_gets_its_report_and_exit_status(tmp_path, overlay):
    """Faulted at t > 1 s: no lap done, the telemetry holds only lap 0."""
    run_dir, rep = tmp_path / "run", tmp_path / "rep"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--robot", f"{FAULTY}:RaisesInDrive",
                      "--run-dir", str(run_dir), "--report", str(rep), "--quiet", timeout=60)
    assert proc.returncode == 4, proc.stderr
    [line] = error_lines(proc)
    assert "ValueError: deliberate failure in drive" in line
    assert "Traceback (most recent call last)" in proc.stderr  # the robot's, not the report's
    page = (rep / "report.html").read_text()
    assert "The race stopped early" in page and "Track map" in page
    # boxbox report on the same run dir
    (run_dir / "report.html").unlink(missing_ok=True)
    proc = run_boxbox("report", str(run_dir), "--no-limit")
    assert proc.returncode == 0, proc.stderr
    assert (run_dir / "report.html").exists()


def test_the_python_api_reports_a_fault_before_the_first_lap(tmp_path, overlay):
    result = boxbox.race("g-track-1", laps=2, robots=[f"{FAULTY}:RaisesInDrive"], run_dir=tmp_path / "run",
                         report=True)
    assert "deliberate failure in drive" in (result.error or "")
    assert (tmp_path / "run" / "report.html").exists()


def test_a_report_that_cannot_be_written_keeps_the_race_error_and_exit_status(tmp_path, overlay):
    rep = tmp_path / "rep"
    (rep / "report.html").mkdir(parents=True)  # the page cannot be written where a folder is
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--robot", f"{FAULTY}:RaisesInDrive",
                      "--run-dir", str(tmp_path / "run"), "--report", str(rep), "--quiet", timeout=60)
    assert proc.returncode == 4, proc.stderr
    [line] = error_lines(proc)
    assert "ValueError: deliberate failure in drive" in line
    assert "the report was not written" in proc.stderr


def test_the_python_api_returns_the_result_when_its_report_cannot_be_written(tmp_path, overlay):
    rep = tmp_path / "rep"
    (rep / "report.html").mkdir(parents=True)
    with pytest.warns(UserWarning, match=r"the report was not written: .*; try result\.report\(\)"):
        result = boxbox.race("g-track-1", laps=1, run_dir=tmp_path / "run", report=rep)
    assert result.error is None and result.drivers[0].laps == 1  # the race's result is not lost
    assert result.report(tmp_path / "elsewhere").exists()


def test_a_result_json_of_the_wrong_shape_is_one_line(tmp_path):
    for text in ('[1, 2]', '{"track": "x", "drivers": "none"}', '{"drivers": [1]}', '{"laps": "three"}',
                 '{"drivers": [{"name": 3, "lap_times": "fast"}]}'):
        (tmp_path / "result.json").write_text(text)
        proc = run_boxbox("report", str(tmp_path), "--no-limit")
        assert proc.returncode == 2, (text, proc.stderr)
        assert "Traceback" not in proc.stderr, proc.stderr
        assert len(error_lines(proc)) == 1 and "result.json" in error_lines(proc)[0], proc.stderr


def test_pit_stops_without_pit_events_and_an_emoji_name(tmp_path, overlay):
    """A robot using PitStops without race_report: the report counts its stop (the results table
    says 1 pit) instead of "No pit events"; an emoji in its name leaks no matplotlib warning."""
    robot_file = tmp_path / "emoji.py"
    robot_file.write_text(f"import sys\nsys.path.insert(0, {str(ROBOTS)!r})\nfrom contract import Stops\n"
                          "class Emoji(Stops):\n    name = 'pit \U0001F3CE'\n    def race_report(self):\n"
                          "        return {}\n")
    run_dir, rep = tmp_path / "run", tmp_path / "rep"
    proc = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--pit-laps", "1", "--robot",
                      f"{robot_file}:Emoji", "--run-dir", str(run_dir), "--report", str(rep), "--quiet", timeout=90)
    assert proc.returncode == 0, proc.stderr
    assert read_json(run_dir / "result.json")["drivers"][0]["pit_stops"] == 1
    assert "Glyph" not in proc.stderr and "Warning" not in proc.stderr, proc.stderr
    page = (rep / "report.html").read_text()
    assert "No pit events" not in page
    assert "1 pit stop" in page
    json.loads((run_dir / "result.json").read_text())
