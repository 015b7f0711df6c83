"""boxbox.race checks its arguments as `boxbox race` checks its options, with the same code
(validate.py) and the same words, before TORCS starts. The races themselves are stubbed here
(`launch.run_race` raises Raced): what reaches it passed every check, and nothing ever races."""

from __future__ import annotations

import math
import os
import re

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import boxbox
from boxbox.cli import main_group
from boxbox.torcs import launch

SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=30), st.binary(max_size=8),
    st.sampled_from(["nan", "inf", "", "0", "3", "-1", "1e12", "last", "first", "boxbox", "bt:2", "bt:2,berniw:3",
                     "/proc/x", "mu_scale=0.9", "fresh", "pro", "bang-bang"]),
)
ANYTHING = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                         st.dictionaries(st.text(max_size=8), inner, max_size=2)),
                        max_leaves=6)
OPTIONS = ["laps", "robots", "opponents", "car", "skill_level", "grid_position", "learning", "pit_laps", "fuel_laps",
           "pit_mode", "settings", "telemetry", "step_budget_ms", "setup_budget_s", "report", "track"]


class Raced(Exception):
    """launch.run_race was called: every check passed."""


@pytest.fixture(scope="module")
def no_races(overlay, tmp_path_factory):
    """Races stubbed, and a scratch working folder (relative paths land there)."""
    folder = tmp_path_factory.mktemp("api-validation")
    cwd = os.getcwd()
    with pytest.MonkeyPatch.context() as patch:
        def run_race(cfg, overlay, *args, **kwargs):
            raise Raced(cfg)

        patch.setattr(launch, "run_race", run_race)
        os.chdir(folder)
        try:
            yield folder
        finally:
            os.chdir(cwd)


def api_error(**kwargs) -> str | None:
    """boxbox.race's UsageError line for kwargs (a one-lap race on g-track-1 otherwise), or None
    when it would race."""
    try:
        boxbox.race(track=kwargs.pop("track", "g-track-1"), laps=kwargs.pop("laps", 1), **kwargs)
    except Raced:
        return None
    except boxbox.UsageError as exc:
        return str(exc)
    raise AssertionError("neither raced nor refused")


@settings(max_examples=200, deadline=None, suppress_health_check=list(HealthCheck))
@given(option=st.sampled_from(OPTIONS), value=ANYTHING)
def test_any_value_of_any_argument_races_or_is_one_usage_error_before_torcs(no_races, option, value):
    run_dir = no_races / "run"
    try:
        boxbox.race(**{"track": "g-track-1", "laps": 1, "run_dir": run_dir, option: value})
    except Raced:
        return  # a valid value: it reached the race (stubbed)
    except boxbox.UsageError as exc:
        assert str(exc) and "\n" not in str(exc)
        assert isinstance(exc, ValueError)
    assert not run_dir.exists()


def test_the_values_of_issue_48_are_refused_in_one_line(no_races):
    cases = {
        "robots=[]": ({"robots": []}, "Invalid value for 'robots': [] has no robot; give at least one"),
        "pit_laps=[0]": ({"pit_laps": [0]}, "Invalid value for 'pit_laps': 0 is not in the range 1<=x<=10000."),
        "fuel_laps=nan": ({"fuel_laps": math.nan}, "Invalid value for 'fuel_laps': nan is not a finite number."),
        "step_budget_ms=0": ({"step_budget_ms": 0}, "Invalid value for 'step_budget_ms': 0.0 is not in the range"),
        "laps=True": ({"laps": True}, "Invalid value for 'laps': True is not a valid integer."),
        "grid_position='first'": ({"grid_position": "first"}, "Invalid value for 'grid_position': 'first' is not "
                                                              "a grid slot; give a number from 1 (pole) or 'last'."),
        "report=/proc/x": ({"report": "/proc/x"}, "Invalid value for 'report': cannot write in /proc/x"),
        "settings=['x']": ({"settings": ["mu_scale"]}, "Invalid value for 'settings': 'mu_scale' is not KEY=VALUE"),
        "settings=['mu_scale=9']": ({"settings": ["mu_scale=9"]}, "mu_scale must be a finite number from 0.3 to 1.5"),
        "setup_budget_s=0": ({"setup_budget_s": 0}, "Invalid value for 'setup_budget_s': 0.0 is not in the range"),
        "opponents='bt:2,bt:2'": ({"opponents": "bt:2,bt:2"}, "opponent bt:2 is given twice"),
        "robots='boxbx'": ({"robots": "boxbx"}, "unknown robot 'boxbx' (did you mean boxbox?)"),
        "robots=int": ({"robots": [int]}, "is not a boxbox.Robot subclass"),
    }
    for label, (kwargs, words) in cases.items():
        got = api_error(**kwargs)
        assert got is not None and words in got, (label, got)


def test_strings_are_taken_as_the_command_line_takes_them(no_races):
    with pytest.raises(Raced) as raced:
        boxbox.race(track="g-track-1", laps=2, robots="boxbox", opponents="bt:2,berniw:3", pit_laps="1",
                    settings=["mu_scale=0.9"], setup_budget_s=30, grid_position="last")
    cfg = raced.value.args[0]
    assert cfg.robots == ["boxbox"] and cfg.opponents == [("bt", 2), ("berniw", 3)]
    assert cfg.options.pit_laps == (1,) and cfg.options.robot_args == {"set": {"mu_scale": 0.9}}
    assert cfg.setup_budget_ms == 30_000 and cfg.grid_position == 3 and cfg.learning == "fresh"


# the same bad value through both doors: the CLI's option, boxbox.race's argument
SAME = [
    (["--laps", "0"], {"laps": 0}),
    (["--laps", "three"], {"laps": "three"}),
    (["--laps", "2147483647"], {"laps": 2147483647}),
    (["--fuel-laps", "nan"], {"fuel_laps": math.nan}),
    (["--fuel-laps", "inf"], {"fuel_laps": math.inf}),
    (["--fuel-laps", "x"], {"fuel_laps": "x"}),
    (["--step-budget-ms", "0"], {"step_budget_ms": 0}),
    (["--setup-budget-s", "1e12"], {"setup_budget_s": 1e12}),
    (["--pit-laps", "0"], {"pit_laps": [0]}),
    (["--pit-laps", "2,x"], {"pit_laps": "2,x"}),
    (["--pit-mode", "fast"], {"pit_mode": "fast"}),
    (["--learning", "always"], {"learning": "always"}),
    (["--skill-level", "expert"], {"skill_level": "expert"}),
    (["--grid-position", "first"], {"grid_position": "first"}),
    (["--grid-position", "41"], {"grid_position": 41}),
    (["--report", "/proc/boxbox-no-such"], {"report": "/proc/boxbox-no-such"}),
    (["--run-dir", "/proc/boxbox-no-such/run"], {"run_dir": "/proc/boxbox-no-such/run"}),
    (["--setup", "/no/such/setup.toml"], {"setup": "/no/such/setup.toml"}),
]


@pytest.mark.parametrize("args,kwargs", SAME, ids=[" ".join(a) for a, _ in SAME])
def test_the_command_line_and_boxbox_race_say_the_same(no_races, args, kwargs):
    result = CliRunner().invoke(main_group, ["race", "--track", "g-track-1", *args], standalone_mode=False)
    assert result.exception is not None
    cli_line = str(result.exception.format_message())  # click's: "Invalid value for '--laps': ..."
    api_line = api_error(**kwargs)
    option = args[0].lstrip("-").replace("-", "_")
    assert api_line is not None and api_line.startswith(f"Invalid value for '{option}': ")
    assert re.sub(r"^Invalid value for '[-\w]+': ", "", cli_line) == api_line.split(": ", 1)[1], (cli_line, api_line)
