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
        "96x96 pixel observations", "2 learning cars in one race", "4 learning cars in one race"]
    # drive steps a second (an env step is DEFAULT_ACTION_REPEAT of them), loosely: a loaded CI machine
    # is slower (pixels: 410 env steps/s there, load 6 on 2 cores)
    assert number(rows[0].value) * DEFAULT_ACTION_REPEAT > 500 and number(rows[2].value) * DEFAULT_ACTION_REPEAT > 300
    per_car = number(rows[2].value.split("(")[1])
    assert abs(per_car - 4 * number(rows[2].value)) <= 4  # per car: 4 times the env steps


def test_bench_gym_takes_multi_steps():
    result = CliRunner().invoke(main_group, ["bench-gym", "--multi-steps", "-1"])
    assert result.exit_code == 2 and "Invalid value for '--multi-steps'" in result.output  # the option, checked
