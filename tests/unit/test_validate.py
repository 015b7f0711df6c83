"""validate.py: one check per kind of option value. Each either returns the value converted or
raises UsageError (also a ValueError) with one line: never another exception, whatever it is given
(property-based: hypothesis throws wrong types, NaN, infinities, empty and huge values at each)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from boxbox import validate
from boxbox.errors import UsageError
from boxbox.model.skill import SkillLevel

FAST = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])

SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(), st.integers(min_value=-(10**400), max_value=10**400),
    st.floats(), st.floats(allow_nan=True, allow_infinity=True, width=32), st.text(max_size=40),
    st.sampled_from(["nan", "inf", "-inf", "1e999", "", " ", "3", " 7 ", "3.5", "1_000", "0x10", "last", "first",
                     "10001", "-1", "٣", "\x00", "a,b", ",", "bt:2", "boxbox"]),
    st.binary(max_size=10), st.complex_numbers(allow_nan=True),
)
ANYTHING = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=5), st.tuples(inner, inner),
                                                         st.dictionaries(st.text(max_size=5), inner, max_size=3)),
                        max_leaves=10)


def outcome(check, value):
    """check(value), or the UsageError's one line."""
    try:
        return check(value)
    except UsageError as exc:
        message = str(exc)
        assert message and "\n" not in message
        assert isinstance(exc, ValueError)  # as Python and Gymnasium raise for a bad argument
        return exc


def _is_whole_text(value) -> bool:
    try:
        int(value)
    except ValueError:
        return False
    return True


@FAST
@given(ANYTHING)
def test_laps_are_whole_numbers_from_1_to_10000_and_nothing_else(value):
    got = outcome(validate.laps, value)
    valid = (isinstance(value, int) and not isinstance(value, bool)) or (isinstance(value, str)
                                                                         and _is_whole_text(value))
    if valid and 1 <= int(value) <= validate.MAX_LAPS:
        assert got == int(value) and type(got) is int
    else:
        assert isinstance(got, UsageError)


@FAST
@given(ANYTHING, st.sampled_from([(0.01, 10_000), (1, 60_000), (None, None), (0, None)]))
def test_finite_numbers_refuse_nan_infinity_bools_and_other_types(value, bounds):
    lo, hi = bounds
    got = outcome(lambda v: validate.finite_number(v, lo, hi), value)
    if isinstance(got, float):
        assert math.isfinite(got) and (lo is None or got >= lo) and (hi is None or got <= hi)
        assert not isinstance(value, bool) and isinstance(value, int | float | str)
    else:
        assert isinstance(got, UsageError)


@FAST
@given(ANYTHING)
def test_list_checks_return_lists_of_their_kind_or_refuse(value):
    laps = outcome(validate.lap_list, value)
    assert isinstance(laps, UsageError) or all(type(lap) is int and 1 <= lap <= 10_000 for lap in laps)
    opponents = outcome(validate.opponent_list, value)
    assert isinstance(opponents, UsageError) or all(isinstance(o, str) and o for o in opponents)
    robots = outcome(validate.robot_list, value)
    assert isinstance(robots, UsageError) or (robots and all(isinstance(r, str | type) for r in robots))
    lengths = outcome(validate.lap_lengths, value)
    assert isinstance(lengths, UsageError) or (lengths and all(1 <= n <= 10_000 for n in lengths))
    angles = outcome(validate.angle_list, value)
    assert isinstance(angles, UsageError) or (angles and all(math.isfinite(a) and -180 <= a <= 180 for a in angles))
    names = outcome(lambda v: validate.names(v, "actions"), value)
    assert isinstance(names, UsageError) or all(isinstance(n, str) and n for n in names)


@FAST
@given(ANYTHING)
def test_choices_grid_slots_settings_flags_and_names(value):
    for check in (validate.pit_mode, validate.learning_mode, validate.skill_level):
        got = outcome(check, value)
        assert isinstance(got, UsageError) or got == value
    slot = outcome(validate.grid_position, value)
    assert isinstance(slot, UsageError) or slot in (None, "last") or (type(slot) is int and 1 <= slot <= 40)
    values = outcome(validate.settings, value)
    assert isinstance(values, UsageError) or all(isinstance(k, str) and k for k in values)
    assert outcome(validate.flag, value) is value if isinstance(value, bool) else isinstance(
        outcome(validate.flag, value), UsageError)
    track = outcome(lambda v: validate.text(v, "track name", "g-track-1"), value)
    assert isinstance(track, UsageError) or (isinstance(track, str) and track.strip() == track and track)


@settings(max_examples=150, deadline=None)
@given(st.one_of(st.text(max_size=300), st.binary(max_size=20), st.integers(), st.none(), st.just("x" * 5000)))
def test_paths_are_checked_without_any_other_error(tmp_path_factory, value):
    folder = tmp_path_factory.getbasetemp()
    cwd = os.getcwd()
    os.chdir(folder)  # relative names land in a scratch folder
    try:
        for check in (validate.output_file, validate.output_dir, validate.input_file):
            got = outcome(check, value)
            assert isinstance(got, UsageError) or (isinstance(got, Path) and got.is_absolute())
    finally:
        os.chdir(cwd)


def test_the_words_are_clicks_and_the_name_comes_first():
    cases = [
        (lambda: validate.laps(0), "0 is not in the range 1<=x<=10000."),
        (lambda: validate.laps("three", name="laps"), "Invalid value for 'laps': 'three' is not a valid integer."),
        (lambda: validate.laps(True), "True is not a valid integer."),
        (lambda: validate.laps(3.0), "3.0 is not a valid integer."),
        (lambda: validate.fuel_laps(math.nan), "nan is not a finite number."),
        (lambda: validate.fuel_laps("nan"), "nan is not a finite number."),
        (lambda: validate.fuel_laps(math.inf), "inf is not in the range 0.01<=x<=10000."),
        (lambda: validate.finite_number(math.inf), "inf is not a finite number."),
        (lambda: validate.finite_number(10**400), "is not a finite number."),
        (lambda: validate.step_budget_ms(0), "0.0 is not in the range 1<=x<=60000."),
        (lambda: validate.positive_limit(0, name="max_damage"), "Invalid value for 'max_damage': 0.0 is not in the "
                                                                "range x>0."),
        (lambda: validate.pit_mode("fast"), "'fast' is not one of 'constant-decel', 'bang-bang'."),
        (lambda: validate.grid_position("first"), "'first' is not a grid slot; give a number from 1 (pole)"),
        (lambda: validate.grid_position(41), "41 is not a grid slot; TORCS grids have 1 to 40."),
        (lambda: validate.robot_list([]), "[] has no robot; give at least one, e.g. ['boxbox']."),
        (lambda: validate.robot_list([3]), "3 is not a robot; give a name ('boxbox')"),
        (lambda: validate.lap_list([0]), "0 is not in the range 1<=x<=10000."),
        (lambda: validate.settings(["mu_scale"]), "'mu_scale' is not KEY=VALUE, e.g. 'mu_scale=0.9'."),
        (lambda: validate.angle_list([]), "0 angles: give 1 to 360"),
        (lambda: validate.output_dir("/proc/boxbox-x"), "cannot write in /proc/boxbox-x (in /proc): "),
    ]
    for call, words in cases:
        with pytest.raises(UsageError) as caught:
            call()
        assert words in str(caught.value), (words, str(caught.value))


def test_a_string_is_one_robot_and_a_comma_list_of_opponents():
    assert validate.robot_list("boxbox") == ["boxbox"]  # not ['b', 'o', 'x', ...]
    assert validate.robot_list(" my_robot.py:MyRobot ") == ["my_robot.py:MyRobot"]
    assert validate.robot_list(SkillLevel) == [SkillLevel]  # a class (the loader checks it is a Robot)
    assert validate.opponent_list("bt:2") == ["bt:2"]
    assert validate.opponent_list("bt:2, berniw:3,") == ["bt:2", "berniw:3"]
    assert validate.opponent_list(["bt:2", ("berniw", 3)]) == ["bt:2", "berniw:3"]
    assert validate.lap_list("7, 3,3") == [7, 3] and validate.lap_list((3, 7)) == [3, 7]
    assert validate.lap_lengths("6-9") == [6, 7, 8, 9]
    assert validate.settings(["mu_scale=0.9", "learning=false", "steering=lookahead"]) == {
        "mu_scale": 0.9, "learning": False, "steering": "lookahead"}
    assert validate.settings({"mu_scale": 0.9}) == {"mu_scale": 0.9}
    assert validate.grid_position("last") == "last" and validate.grid_position("3") == 3


def test_the_skill_levels_are_the_models():
    assert validate.SKILL_LEVELS == tuple(level.torcs_name for level in SkillLevel)
