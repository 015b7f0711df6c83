"""bench-gym's measurements, small: the rows are there and the figures meet the targets loosely
(the real figures are in docs/gym.md; a loaded CI machine is slower)."""

from __future__ import annotations

import re

from boxbox.gym.bench import markdown, run_bench


def number(text: str) -> float:
    return float(re.match(r"[\d,.]+", text).group(0).replace(",", ""))


def test_bench_gym_small(overlay):
    rows = run_bench(steps=3000, episode_steps=500, vector_envs=2, vector_steps=300, episodes=30)
    by = {r.measure.split(",")[0] + ("" if "Async" not in r.measure else " async"): r for r in rows}
    assert number(rows[0].value) > 2000  # one env (the target, 10,000, is met on a quiet machine)
    assert number(rows[1].value) > 1000  # with a reset every 500 steps
    assert number(by["env steps/s async"].value) > 500
    reset = rows[3].value
    assert number(reset) < 300  # ms, the median
    rss, fds, kids = (r.value for r in rows[4:7])
    first, last = (number(v) for v in rss.split(" / "))
    assert last - first < 5.0  # MB over 20 episodes after the 10th
    assert fds.split(" / ")[0] == fds.split(" / ")[1] and kids == "1 / 1"
    table = markdown(rows)
    assert table.count("\n") == len(rows) + 1 and "gym_torcs #31" in table
