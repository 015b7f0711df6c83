"""bench-gym's pixel and multi-car rows, small (the real figures are in docs/gym.md)."""

from __future__ import annotations

import re

from click.testing import CliRunner

from boxbox.cli import main_group
from boxbox.gym.bench_multi import run_multi_bench
from boxbox.gym.env import DEFAULT_ACTION_REPEAT


def number(text: str) -> float:
    return float(re.match(r"[\d,.]+", text).group(0).replace(",", ""))


def test_pixel_and_multi_car_rows(overlay):
    rows = run_multi_bench(steps=1500, episode_steps=500)
    assert [r.measure.split(" with ")[1].split(" (")[0] for r in rows] == [
        "96x96 pixel observations", "96x96 pixels and the numbers in one Dict, the dashboard, 100 m ahead",
        "2 learning cars in one race", "4 learning cars in one race"]
    # drive steps a second (an env step is DEFAULT_ACTION_REPEAT of them), loosely: a loaded CI machine
    # is slower (pixels: 410 env steps/s there, load 6 on 2 cores)
    assert number(rows[0].value) * DEFAULT_ACTION_REPEAT > 500 and number(rows[3].value) * DEFAULT_ACTION_REPEAT > 300
    assert number(rows[1].value) * DEFAULT_ACTION_REPEAT > 300
    share = number(rows[1].value.split("(")[1])
    assert abs(share - number(rows[1].value) / number(rows[0].value)) < 0.01  # its share of the view alone's
    per_car = number(rows[3].value.split("(")[1])
    assert abs(per_car - 4 * number(rows[3].value)) <= 4  # per car: 4 times the env steps


def test_bench_gym_takes_multi_steps():
    result = CliRunner().invoke(main_group, ["bench-gym", "--multi-steps", "-1"])
    assert result.exit_code == 2 and "Invalid value for '--multi-steps'" in result.output  # the option, checked
