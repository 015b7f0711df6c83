"""Racecraft on a real race with TORCS's robots: a pass from the back."""

from __future__ import annotations

from helpers import read_json, run_boxbox


def _boxbox(result: dict) -> dict:
    return next(d for d in result["drivers"] if d["module"] == "boxbox")


def test_boxbox_passes_two_torcs_robots_from_the_back_without_contact(tmp_path):
    out = tmp_path / "r.json"
    r = run_boxbox("race", "--track", "g-track-1", "--laps", "2", "--learning", "fresh", "--grid-position", "last",
                   "--opponents", "bt:2,berniw:3", "--json", str(out))
    assert r.returncode == 0, r.stderr
    me = _boxbox(read_json(out))
    assert me["rank"] == 1, me  # from third of three
    assert me["damage"] < 100, me
    # the first lap, standing start behind two cars, costs little against the same lap alone (42.48 s)
    assert me["lap_times"][0] < 42.48 + 2.5, me["lap_times"]
