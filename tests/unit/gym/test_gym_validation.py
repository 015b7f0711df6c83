"""The env's options and actions, and the SCR server's messages, checked before anything runs:
bad input is one UsageError (also a ValueError), never another exception (property-based)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from boxbox.errors import UsageError
from boxbox.gym import env as env_module
from boxbox.gym.env import TorcsEnv
from boxbox.gym.episodes import check_reset_options
from boxbox.gym.scr import Action, parse_init
from boxbox.gym.spaces import ActionReader

SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=20), st.binary(max_size=8),
    st.sampled_from(["nan", "inf", "", "steer", "gears", "bt:2", "semi-pro", "last", "-5", "0"]),
)
ANYTHING = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4), st.tuples(inner, inner),
                                                         st.dictionaries(st.text(max_size=5), inner, max_size=2)),
                        max_leaves=8)
OPTIONS = ["track", "car", "opponents", "laps", "action_repeat", "actions", "assists", "flat",
           "track_sensor_angles_deg", "reward_fn", "reward_weights", "max_damage", "off_track_s", "stuck_s",
           "skill_level", "grid_position", "initial_fuel_l", "pit_fuel_l", "pit_repair", "cpu", "render_mode", "pixels",
           "pixel_size", "spares", "sensor_noise", "step_timeout_s", "pixels_only", "dashboard", "view_ahead_m"]


class SetUp(Exception):
    """The env got as far as setting TORCS up: every option passed its check."""


@pytest.fixture
def no_setup(monkeypatch):
    def ensure_ready(report=None):
        raise SetUp

    monkeypatch.setattr(env_module.setup, "ensure_ready", ensure_ready)


def made(**kwargs) -> str | None:
    """The UsageError line of TorcsEnv(**kwargs), or None when the options passed (up to the set-up)."""
    try:
        TorcsEnv(**kwargs)
    except SetUp:
        return None
    except UsageError as exc:
        assert str(exc) and "\n" not in str(exc)
        return str(exc)
    raise AssertionError("neither set up nor refused")


@settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck))
@given(option=st.sampled_from(OPTIONS), value=ANYTHING)
def test_any_value_of_any_option_passes_or_is_one_usage_error_before_torcs(no_setup, option, value):
    made(**{option: value})


def test_the_options_of_issue_48_are_refused_in_one_line(no_setup):
    cases = [
        ({"stuck_s": -1}, "Invalid value for 'stuck_s': -1.0 is not in the range x>0."),
        ({"off_track_s": math.nan}, "Invalid value for 'off_track_s': nan is not a finite number."),
        ({"max_damage": 0}, "Invalid value for 'max_damage': 0.0 is not in the range x>0."),
        ({"initial_fuel_l": -5}, "Invalid value for 'initial_fuel_l': -5.0 is not in the range 0<=x<=1000.0."),
        ({"track_sensor_angles_deg": ()}, "Invalid value for 'track_sensor_angles_deg': 0 angles: give 1 to 360"),
        ({"track_sensor_angles_deg": (0, math.nan)}, "'track_sensor_angles_deg': nan is not a finite number."),
        ({"laps": True}, "Invalid value for 'laps': True is not a valid integer."),
        ({"actions": ("steer", "gas")}, "Invalid value for 'actions': 'gas' is not one of 'steer', 'throttle'"),
        ({"action_repeat": 0}, "Invalid value for 'action_repeat': 0 is not in the range 1<=x<=1000."),
        ({"grid_position": "first"}, "'first' is not a grid slot"),
        ({"cpu": 4096}, "Invalid value for 'cpu': 4096 is not a core this process may use"),
        ({"reward_fn": 3}, "Invalid value for 'reward_fn': 3 is not callable"),
    ]
    for kwargs, words in cases:
        got = made(**kwargs)
        assert got is not None and words in got, (kwargs, got)
    # a string is a comma list, as on the command line (not its letters)
    assert env_module.checked_actions("steer, throttle", "gears") == (("steer", "throttle"), ("gears",))
    assert made(stuck_s=None, off_track_s=None, max_damage=5000, initial_fuel_l=0, opponents="bt:2,berniw:3",
                track_sensor_angles_deg=(-45, 0, 45), grid_position="last") is None


def test_options_that_were_accepted_and_ignored_are_refused_with_what_to_do(no_setup):
    cases = [
        ({"pixel_size": (7, 7)}, "sizes the pixel observation, which is off; set pixels=True"),
        ({"pixel_size": 96}, "sizes the pixel observation, which is off; set pixels=True"),
        ({"pixels_only": False}, "'pixels_only': False adds the numbers to the pixel observation, which is off"),
        ({"dashboard": True}, "'dashboard': True draws into the pixel observation and render()'s frames, both off"),
        ({"view_ahead_m": 80}, "'view_ahead_m': 80 sets how far ahead the pixel observation sees, which is off"),
        ({"pixels": True, "view_ahead_m": math.nan}, "Invalid value for 'view_ahead_m': nan is not a finite number."),
        ({"assists": ("gears", "gears")}, "'assists': ('gears', 'gears'): choose each of the assists at most once"),
        ({"assists": "abs,abs", "actions": ("steer", "throttle", "brake", "gear")}, "at most once"),
        ({"opponents": [[], ["bt:1"]]}, "wrap them in OneOf (boxbox.gym.episodes): opponents=OneOf([], ['bt:1'])"),
        ({"step_timeout_s": 0}, "Invalid value for 'step_timeout_s': 0.0 is not in the range 0<x<=3600.0."),
        ({"step_timeout_s": math.inf}, "Invalid value for 'step_timeout_s'"),
    ]
    for kwargs, words in cases:
        got = made(**kwargs)
        assert got is not None and words in got, (kwargs, got)
    assert made(pixels=True, pixel_size=(64, 64), step_timeout_s=0.5, opponents=[("bt", 1), "bt:2"]) is None
    assert made(pixels=True, pixels_only=False, dashboard=True, view_ahead_m=120, flat=True) is None
    assert made(dashboard=True, render_mode="rgb_array") is None  # render()'s frames get it


def test_the_parallel_env_refuses_the_single_envs_options_in_one_line(no_setup):
    from boxbox.gym import parallel_env

    cases = [
        ({"sensor_noise": True}, "'sensor_noise': the parallel env does not take it yet; leave it out"),
        ({"spares": 0}, "'spares': the parallel env does not take it yet"),
        ({"grid_position": 2}, "'grid_position': the parallel env does not take it yet"),
        ({"track": ["g-track-1", "e-track-2"]}, "'track': ['g-track-1', 'e-track-2']: the parallel env races the same "
                                                "race at each reset; give one value"),
        ({"opponents": [[], ["bt:1"]]}, "the parallel env races the same race at each reset"),
        ({"pixel_size": 96}, "set pixels=True"),
        ({"dashboard": True, "render_mode": "rgb_array"}, "'dashboard': True draws into each car's pixel observation"),
        ({"view_ahead_m": 80}, "'view_ahead_m': 80 sets how far ahead the pixel observation sees, which is off"),
        ({"max_episode_steps": 0}, "Invalid value for 'max_episode_steps'"),
        ({"random_start": "no"}, "Invalid value for 'random_start': 'no' is not True or False"),
        ({"raw_observations": None}, "Invalid value for 'raw_observations'"),
        ({"actions": ("steer", "pedal", "throttle")}, "give 'pedal' or 'throttle' and 'brake', not both"),
    ]
    for kwargs, words in cases:
        with pytest.raises(UsageError) as refused:
            parallel_env(**kwargs)
        assert words in str(refused.value) and "\n" not in str(refused.value), (kwargs, str(refused.value))
    with pytest.raises(TypeError, match="unexpected keyword argument 'bogus'"):
        parallel_env(bogus=1)
    with pytest.raises(SetUp):  # a field of pairs and names is one field
        parallel_env(opponents=[("bt", 1), "bt:2"], step_timeout_s=2)


def test_the_docs_option_table_is_the_envs_signature():
    """Each option docs/gym.md's table lists is one TorcsEnv takes, and each one it takes is listed."""
    import inspect
    import itertools
    import re
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[3] / "docs" / "gym.md").read_text()
    lines = doc.split("## Options", 1)[1].splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("|"))
    rows = list(itertools.takewhile(lambda line: line.startswith("|"), lines[first:]))[2:]  # below the header
    listed = {name for row in rows for name in re.findall(r"`(\w+)`", row.split("|")[1])}
    takes = set(inspect.signature(TorcsEnv.__init__).parameters) - {"self"}
    assert listed == takes, (sorted(listed - takes), sorted(takes - listed))


def test_reset_refuses_options_it_does_not_take():
    check_reset_options(None)
    check_reset_options({})
    takes = "track, car, opponents, grid_position, skill_level, initial_fuel_l"
    for options, words in (({"laps": 3}, f"reset() does not take 'laps' (reset options: {takes})"),
                           ("track", "'track' is not a dict of reset options")):
        with pytest.raises(UsageError, match=words.replace("(", r"\(").replace(")", r"\)")):
            check_reset_options(options)


READER = ActionReader(("steer", "throttle", "brake", "gear", "clutch", "pit"))


@settings(max_examples=300, deadline=None)
@given(st.one_of(ANYTHING, st.lists(st.floats(), min_size=0, max_size=9),
                 st.lists(st.floats(), min_size=6, max_size=6).map(np.array),
                 st.lists(st.floats(width=32), min_size=6, max_size=6).map(lambda v: np.array(v, dtype=np.float32))))
def test_an_action_is_read_into_range_or_refused(action):
    try:
        steer, throttle, brake, clutch, gear, pit = READER.read(action)
    except UsageError as exc:
        assert "give 6 numbers, shape (6,)" in str(exc) and "\n" not in str(exc)
        return
    assert np.shape(action) == (6,)
    assert -1 <= steer <= 1 and 0 <= throttle <= 1 and 0 <= brake <= 1 and 0 <= clutch <= 1
    assert -1 <= gear <= 6 and isinstance(pit, bool)


def test_actions_of_the_wrong_shape_are_refused():
    reader = ActionReader(("steer", "throttle", "brake"))
    for action in (np.zeros(8), [0.0, 1.0], [[0.0, 1.0, 0.0]], 0.5, "abc", None, [0.0, "x", 1.0]):
        with pytest.raises(UsageError, match=r"give 3 numbers, shape \(3,\) \(steer, throttle, brake\)"):
            reader.read(action)


# --- the SCR server's parsers: any datagram --------------------------------------------------------
NEAR_MISSES = st.builds(lambda head, tokens: head + b" ".join(tokens) + b")",
                        st.sampled_from([b"SCR(init ", b"(accel ", b"(steer ", b"(meta ", b"(focus ", b"ID(init"]),
                        st.lists(st.text("-+.eE0123456789x", max_size=6).map(str.encode), max_size=20))


@settings(max_examples=400, deadline=None)
@given(st.one_of(st.binary(max_size=300), NEAR_MISSES,
                 st.lists(NEAR_MISSES, max_size=6).map(b"".join)))
def test_scr_parsers_take_any_bytes_and_never_raise(message):
    angles = parse_init(message)
    assert angles is None or (angles and all(isinstance(a, float) and math.isfinite(a) for a in angles))
    action = Action()
    before = dict(action.values)
    taken = action.update(message)
    assert isinstance(taken, bool)
    assert all(isinstance(v, float) and math.isfinite(v) for v in action.values.values())
    if not taken:
        assert action.values == before  # a malformed message changes nothing
    assert np.isfinite(action.vector()).all()


def test_the_messages_that_killed_the_server_are_ignored():
    assert parse_init(b"SCR(init - - - - - - - - - - - - - - - - - - -)") is None
    assert parse_init(b"SCR(init 1e999 0)") is None  # not finite
    action = Action()
    assert action.update(b"(accel -)") is False and action.values["accel"] == 0.0
    assert action.update(b"(accel 0.5)(brake .)") is False and action.values["accel"] == 0.0  # all or nothing
    assert action.update(b"(accel 0.5)(brake 1e-1)") is True and action.vector()[1:3].tolist() == [0.5, 0.1]
    assert action.update(b"(unknown 3)") is False


def test_the_env_and_boxbox_race_say_the_same(no_setup, monkeypatch):
    import boxbox
    from boxbox.torcs import setup as torcs_setup

    monkeypatch.setattr(torcs_setup, "ensure_ready", lambda report=None: pytest.fail("set up"))
    for kwargs in ({"laps": 0}, {"laps": True}, {"skill_level": "expert"}, {"grid_position": "first"},
                   {"opponents": 5}, {"track": ""}, {"car": None}):
        with pytest.raises(UsageError) as from_api:
            boxbox.race(**kwargs)
        assert made(**kwargs) == str(from_api.value), kwargs
