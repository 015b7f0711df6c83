"""`boxbox params --robot SPEC`: any robot's effective parameters, or that it declares none."""

from __future__ import annotations

from click.testing import CliRunner

from boxbox.cli import main_group

ROBOT = '''
from dataclasses import dataclass

from boxbox import Controls, Robot
from boxbox.robot.params import Bound


@dataclass(frozen=True)
class GainParams:
    gain: float = 1.0
    wide: bool = False


class Gainer(Robot):
    name = "gainer"
    param_class = GainParams
    param_bounds = {"gain": Bound(0.1, 10.0)}

    def drive(self, state):
        return Controls()
'''


def params(*args: str):
    return CliRunner().invoke(main_group, ["params", *args], standalone_mode=False, terminal_width=200)


def test_a_robot_that_declares_parameters_shows_them_with_set_applied(tmp_path):
    (tmp_path / "gainer.py").write_text(ROBOT)
    result = params("--robot", f"{tmp_path / 'gainer.py'}:Gainer", "--set", "gain=2.5")
    assert result.exception is None, result.output
    assert "gainer robot parameters" in result.output
    assert "gain" in result.output and "2.5" in result.output and "--set" in result.output
    assert "wide" in result.output and "False" in result.output and "mu_scale" not in result.output
    assert "│ 0.1 to 10 " in result.output and "│ false, true " in result.output  # what a study searches


def test_a_robot_that_declares_none_says_so():
    result = params("--robot", "middle")
    assert result.exception is None and "robot middle declares no parameters" in result.output


def test_set_for_a_robot_without_parameters_or_out_of_range_is_refused(tmp_path):
    result = params("--robot", "middle", "--set", "gain=2")
    assert "declares no parameters to set" in str(result.exception)
    (tmp_path / "gainer.py").write_text(ROBOT)
    result = params("--robot", f"{tmp_path / 'gainer.py'}:Gainer", "--set", "gain=20")
    assert "gain must be a finite number from 0.1 to 10" in str(result.exception)


def test_the_boxbox_robot_is_the_default():
    result = params()
    assert result.exception is None and "boxbox robot parameters" in result.output and "mu_scale" in result.output


def test_before_torcs_is_set_up_the_car_setup_says_so(tmp_path, monkeypatch):
    from boxbox.torcs import catalog

    monkeypatch.setenv("BOXBOX_TORCS_DATA", str(tmp_path))
    catalog.cars.cache_clear()
    try:
        result = params("--robot", "middle")
    finally:
        catalog.cars.cache_clear()
    assert result.exception is None, result.output
    assert "car1-trb1's settings are read from TORCS, which is not set up yet (`boxbox setup`)" in result.output
