"""The search space of boxbox tune: read from a robot's declared parameters."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from boxbox.errors import UsageError
from boxbox.robot.base import RaceOptions, Robot
from boxbox.robot.params import BOUNDS, Bound, TutorialParams
from boxbox.robot.tunable import param_space, read_setup, robot_params, write_setup
from boxbox.robot.tutorial import TutorialRobot
from boxbox.tune.space import defaults_in_space, distributions, suggest


@dataclass(frozen=True)
class GainParams:
    gain: float = 1.0
    steps: int = 3
    wide: bool = False
    mode: str = "calm"
    free: float = 2.0  # no declared range: not searchable


class GainRobot(Robot):
    name = "gain"
    param_class = GainParams
    param_bounds = {"gain": Bound(0.1, 10.0, log=True), "steps": Bound(1, 9)}
    param_choices = {"mode": ("calm", "wild")}


def test_tutorial_robot_space_comes_from_its_params():
    space = param_space(TutorialRobot)
    assert space.defaults["mu_scale"] == TutorialParams().mu_scale
    names = space.searchable_names()
    assert {"mu_scale", "brake_mu_scale", "steering", "friction_circle"} <= set(names)
    assert "stuck_time_s" not in names  # no finite declared range
    assert all(n in BOUNDS or space.kind(n) in (bool, str) for n in names)


def test_distributions_follow_bounds_and_log_scale():
    from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution

    dists = distributions(param_space(GainRobot), ["gain", "steps", "wide", "mode"])
    assert dists["gain"] == FloatDistribution(0.1, 10.0, log=True)
    assert dists["steps"] == IntDistribution(1, 9)
    assert dists["wide"] == CategoricalDistribution((False, True))
    assert dists["mode"] == CategoricalDistribution(("calm", "wild"))


def test_log_range_from_zero_starts_above_it():
    @dataclass(frozen=True)
    class P:
        x: float = 0.5

    class R(Robot):
        param_class = P
        param_bounds = {"x": Bound(0.0, 2.0, log=True)}

    assert distributions(param_space(R), ["x"])["x"].low == pytest.approx(0.002)


@pytest.mark.parametrize("names, message", [(["gian"], "did you mean gain?"), (["free"], "has no range to search"),
                                            (["nothing"], "is not a parameter"), ([], "at least one")])
def test_pick_refuses_unknown_names_naming_the_nearest_and_where_all_are_listed(names, message):
    with pytest.raises(UsageError, match=message) as info:
        param_space(GainRobot).pick(names)
    assert str(info.value).endswith("`boxbox params` lists every one, with its range")


def test_robot_without_declaration():
    class Plain(Robot):
        name = "plain"

    with pytest.raises(UsageError, match="declares no tunable parameters"):
        param_space(Plain)


def test_defaults_first_and_clipped():
    space = param_space(GainRobot)
    assert defaults_in_space(space, distributions(space, ["gain", "mode"])) == {"gain": 1.0, "mode": "calm"}


def test_settings_checked_and_applied():
    robot = GainRobot(RaceOptions(robot_args={"set": {"gain": 2.5, "mode": "wild"}}))
    assert robot_params(robot) == GainParams(gain=2.5, mode="wild")
    for bad, message in (({"gain": 20.0}, "from 0.1 to 10"), ({"mode": "mad"}, "one of calm, wild"),
                         ({"steps": 2.5}, "whole number"),
                         ({"wide": 1}, "wide must be true or false, got 1; e.g. --set wide=false")):
        with pytest.raises(UsageError, match=message):
            GainRobot.check_setup(RaceOptions(robot_args={"set": bad}), "g-track-1", "car1-trb1")


def test_suggest_uses_the_distributions():
    import optuna

    space = param_space(GainRobot)
    dists = distributions(space, ["gain", "steps", "mode"])
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=1))
    for _ in range(20):
        values = suggest(study.ask(), dists)
        assert 0.1 <= values["gain"] <= 10 and values["steps"] in range(1, 10) and values["mode"] in ("calm", "wild")
        space.check(values, "trial")


def test_setup_file_round_trip(tmp_path):
    path = tmp_path / "best.toml"
    write_setup(path, {"gain": 0.123456789, "wide": True, "mode": 'wi"ld', "steps": 4}, ["a header"])
    assert read_setup(path) == {"gain": 0.123456789, "wide": True, "mode": 'wi"ld', "steps": 4}
    assert path.read_text().startswith("# a header\n")


@pytest.mark.parametrize("text, message", [("gain = [\n", "not valid TOML"), ("[table]\nx = 1\n", "not a dict")])
def test_bad_setup_files(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(UsageError, match=message):
        read_setup(path)
