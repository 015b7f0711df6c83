"""`boxbox sweep`: a small sweep races, checks its targets and writes its table with the command."""

from __future__ import annotations

from helpers import read_json, run_boxbox


def test_a_small_sweep(tmp_path, overlay):
    out, md = tmp_path / "s.json", tmp_path / "s.md"
    proc = run_boxbox("sweep", "--tracks", "g-track-1", "--cars", "car1-trb1", "--laps", "1", "--no-cache",
                      "--json", str(out), "--markdown", str(md), timeout=120)
    assert proc.returncode == 0, proc.stderr
    data = read_json(out)
    # one race serves both parts: g-track-1 is the track of every car, car1-trb1 the car on every track
    assert [(r["part"], r["track"], r["car"]) for r in data["rows"]] == [
        ("every track", "g-track-1", "car1-trb1"), ("every car", "g-track-1", "car1-trb1")]
    assert data["raced"] == 1
    for r in data["rows"]:
        assert r["finished"] and r["misses"] == [] and r["laps"] == 1
        assert 0 <= r["longest_stuck_s"] <= r["stuck_s"] < 10 and r["off_track_s"] >= 0
    text = md.read_text()
    assert "boxbox sweep --tracks g-track-1" in text and "| every car | g-track-1 (road) | car1-trb1 | yes |" in text
    assert "1 of 1 races met every target" in text


def test_sweep_checks_names_first():
    proc = run_boxbox("sweep", "--tracks", "g-trak-1", timeout=30)
    assert proc.returncode == 2 and "did you mean g-track-1" in proc.stderr


def test_a_sweep_at_pro_in_another_car(tmp_path, overlay):
    out = tmp_path / "pro.json"
    proc = run_boxbox("sweep", "--tracks", "michigan", "--cars", "car1-ow1", "--cars-track", "michigan",
                      "--car", "car1-ow1", "--skill-level", "pro", "--laps", "1", "--no-cache", "--json", str(out),
                      timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "skill level pro" in proc.stdout
    rows = read_json(out)["rows"]
    assert {(r["track"], r["car"]) for r in rows} == {("michigan", "car1-ow1")}
    assert all(r["finished"] and r["misses"] == [] for r in rows), rows
