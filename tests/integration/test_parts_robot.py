"""A robot built from the parts docs/robots.md's table lists, each with its defaults (the robot
`boxbox new-robot` writes, robot/template.py: `SpeedProfile.from_track(track, model)`,
`steer_to_line` on the track's middle, the pit part, getting unstuck), finishes a lap fast and
whole: the defaults fit one another at speed.  With turns under a quarter turn taken as cut and
the whole grip (the earlier defaults) it wrecked on e-track-2's first fast turn (damage 10,590, no
lap)."""

from __future__ import annotations

import pytest

from helpers import read_json, run_boxbox, template_robot


@pytest.mark.parametrize("track", ["e-track-2", "g-track-1"])
def test_the_documented_parts_with_their_defaults_finish_a_lap(tmp_path, overlay, track):
    out = tmp_path / "parts.json"
    proc = run_boxbox("race", "--robot", f"{template_robot(tmp_path)}:Parts", "--track", track, "--laps", "1",
                      "--step-budget-ms", "5000", "--json", str(out), "--quiet", timeout=300)
    assert proc.returncode == 0, proc.stderr
    result = read_json(out)
    [me] = result["drivers"]
    assert result["error"] is None and me["laps"] == 1, result
    assert me["damage"] < 100 and me["top_speed"] > 40.0, me  # fast, well past 25 m/s, and whole
