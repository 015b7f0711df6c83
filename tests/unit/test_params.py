"""The tutorial robot's parameters (boxbox.robot.params): defaults, setup files, --set."""

import dataclasses

import pytest

import boxbox.robot.params as params_mod
from boxbox.control import pit_brake
from boxbox.control.gears import DEFAULT_SHIFT, DEFAULT_SHIFT_MARGIN_MPS
from boxbox.control.traction import SlipParams
from boxbox.errors import UsageError
from boxbox.robot.base import RaceOptions
from boxbox.robot.opponents import OpponentParams
from boxbox.robot.params import TutorialParams, load_params, parse_set, setup_files
from boxbox.robot.pit import PitParams
from boxbox.robot.tutorial import TutorialRobot

CAR, TRACK = "car1-trb1", "e-track-2"


@pytest.fixture
def setups(tmp_path, monkeypatch):
    """An empty setups folder in place of the robot's own."""
    monkeypatch.setattr(params_mod, "SETUPS", tmp_path)
    return tmp_path


def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


# --- defaults --------------------------------------------------------------------------------

def test_defaults_are_the_tutorial_values():
    p = TutorialParams()
    assert (p.lookahead_m, p.lookahead_s) == (17.0, 0.33)
    assert p.shift == 0.9
    assert p.shift_margin_mps == 4.0
    assert (p.abs_slip_mps, p.abs_range_mps) == (2.0, 5.0)
    assert (p.tcl_slip_mps, p.tcl_range_mps) == (2.0, 10.0)
    assert (p.stuck_angle_deg, p.stuck_speed_mps, p.stuck_offset_m, p.stuck_time_s) == (30.0, 5.0, 3.0, 2.0)
    assert p.pit_lookahead_m == 6.0


def test_defaults_agree_with_the_controllers_constants():
    p = TutorialParams()
    assert p.shift == DEFAULT_SHIFT and p.shift_margin_mps == DEFAULT_SHIFT_MARGIN_MPS
    slip = SlipParams()
    assert (p.abs_slip_mps, p.abs_range_mps, p.tcl_slip_mps, p.tcl_range_mps) == \
        (slip.abs_slip_mps, slip.abs_range_mps, slip.tcl_slip_mps, slip.tcl_range_mps)
    assert p.pit_lookahead_m == pit_brake.PIT_LOOKAHEAD_M
    pit = PitParams()
    assert (p.pit_lookahead_m, p.pit_brake_mu_scale, p.pit_give_up_s, p.pit_stop_threshold_m, p.pit_stop_grip_share) \
        == (pit.lookahead_m, pit.brake_mu_scale, pit.give_up_s, pit.stop_threshold_m, pit.stop_grip_share)
    opp = OpponentParams()
    assert (p.front_range_m, p.back_range_m, p.length_margin_m, p.side_margin_m, p.overtake_step_m) == \
        (opp.front_range_m, opp.back_range_m, opp.length_margin_m, opp.side_margin_m, opp.overtake_step_m)


def test_defaults_without_setup_files(setups):
    p, sources = load_params(CAR, TRACK)
    assert p == TutorialParams()
    assert set(sources) == {f.name for f in dataclasses.fields(TutorialParams)}
    assert set(sources.values()) == {"default"}


def test_params_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        TutorialParams().shift = 0.5


# --- setup files, in order --------------------------------------------------------------------

def test_setup_files_order(setups):
    assert setup_files(CAR, TRACK) == [setups / "default.toml", setups / CAR / "default.toml",
                                       setups / CAR / f"{TRACK}.toml"]


def test_layers_override_in_order(setups):
    base = write(setups / "default.toml", "shift = 0.8\nlookahead_m = 10.0\nabs_slip_mps = 2.5\nlearning = false\n")
    car = write(setups / CAR / "default.toml", "shift = 0.85\nabs_slip_mps = 3.0\ntcl_range_mps = 8.0\n")
    track = write(setups / CAR / f"{TRACK}.toml", 'shift = 0.87\nsteering = "lookahead"\ntcl_range_mps = 7.0\n')
    p, sources = load_params(CAR, TRACK, {"shift": 0.88})
    assert p.shift == 0.88 and sources["shift"] == "--set"
    assert p.steering == "lookahead" and sources["steering"] == str(track)
    assert p.tcl_range_mps == 7.0 and sources["tcl_range_mps"] == str(track)
    assert p.abs_slip_mps == 3.0 and sources["abs_slip_mps"] == str(car)
    assert p.lookahead_m == 10.0 and sources["lookahead_m"] == str(base)
    assert p.learning is False and sources["learning"] == str(base)
    assert p.mu_scale == TutorialParams().mu_scale and sources["mu_scale"] == "default"

    # without --set the track file wins
    p, sources = load_params(CAR, TRACK)
    assert p.shift == 0.87 and sources["shift"] == str(track)
    # another track: the car's defaults, not this track's file
    p, sources = load_params(CAR, "g-track-1")
    assert p.shift == 0.85 and sources["shift"] == str(car)
    assert p.steering == "line" and p.tcl_range_mps == 8.0
    # another car: only the common defaults
    p, sources = load_params("car2-trb1", TRACK)
    assert p.shift == 0.8 and sources["shift"] == str(base)
    assert p.abs_slip_mps == 2.5


def test_integers_are_taken_for_floats(setups):
    write(setups / "default.toml", "lookahead_m = 20\n")
    p, _ = load_params(CAR, TRACK, {"stuck_time_s": 3})
    assert p.lookahead_m == 20.0 and type(p.lookahead_m) is float
    assert p.stuck_time_s == 3.0 and type(p.stuck_time_s) is float


def test_unknown_key_names_the_nearest_one(setups):
    path = write(setups / CAR / "default.toml", "lookahed_m = 20.0\n")
    with pytest.raises(UsageError) as err:
        load_params(CAR, TRACK)
    msg = str(err.value)
    assert "lookahed_m" in msg and "lookahead_m" in msg and str(path) in msg


def test_unknown_key_in_set_names_the_nearest_one(setups):
    with pytest.raises(UsageError, match="shift_margin_mps") as err:
        load_params(CAR, TRACK, {"shift_margn_mps": 3.0})
    assert "--set" in str(err.value)


def test_unknown_key_without_a_near_one(setups):
    with pytest.raises(UsageError, match="zzzzzz"):
        load_params(CAR, TRACK, {"zzzzzz": 1.0})


def test_table_in_a_setup_file_is_an_unknown_key(setups):
    write(setups / "default.toml", "[steering]\nkind = 1\n")
    with pytest.raises(UsageError):
        load_params(CAR, TRACK)


@pytest.mark.parametrize("key, value", [
    ("shift", "fast"),  # str for a float
    ("shift", True),  # a bool is not a number here
    ("learning", 1),  # an int is not a bool
    ("learning", "yes"),
    ("steering", 3),  # a number for a str
    ("friction_circle", 0.0),
])
def test_wrong_type_is_a_usage_error(setups, key, value):
    with pytest.raises(UsageError, match=key):
        load_params(CAR, TRACK, {key: value})


def test_wrong_type_in_a_file_names_the_file(setups):
    path = write(setups / CAR / f"{TRACK}.toml", 'abs_range_mps = "wide"\n')
    with pytest.raises(UsageError) as err:
        load_params(CAR, TRACK)
    assert str(path) in str(err.value) and "abs_range_mps" in str(err.value)


@pytest.mark.parametrize("key, value", [
    ("steering", "wobbly"), ("brake_method", "guess"), ("track_limits", "loose"),
])
def test_invalid_choice_is_a_usage_error(setups, key, value):
    with pytest.raises(UsageError) as err:
        load_params(CAR, TRACK, {key: value})
    msg = str(err.value)
    assert key in msg and value in msg
    for choice in params_mod.CHOICES[key]:
        assert choice in msg


@pytest.mark.parametrize("key, value", [
    ("steering", "lookahead"), ("brake_method", "approx"), ("track_limits", "strict"),
])
def test_valid_choices(setups, key, value):
    p, _ = load_params(CAR, TRACK, {key: value})
    assert getattr(p, key) == value


def test_invalid_toml_is_a_usage_error(setups):
    path = write(setups / "default.toml", "shift = = 0.8\n")
    with pytest.raises(UsageError, match="TOML") as err:
        load_params(CAR, TRACK)
    assert str(path) in str(err.value)


def test_a_bad_file_for_another_track_does_not_matter(setups):
    write(setups / CAR / "g-track-1.toml", "nonsense = 1\n")
    p, _ = load_params(CAR, TRACK)
    assert p == TutorialParams()


# --- --set ------------------------------------------------------------------------------------

def test_parse_set_reads_numbers_bools_and_strings():
    got = parse_set(["shift=0.8", "stuck_time_s=3", "learning=false", "friction_circle=true",
                     "steering=lookahead", 'brake_method="approx"', " abs_slip_mps = 2.5 ", "lookahead_s=-1e-1"])
    assert got == {"shift": 0.8, "stuck_time_s": 3, "learning": False, "friction_circle": True,
                   "steering": "lookahead", "brake_method": "approx", "abs_slip_mps": 2.5, "lookahead_s": -0.1}
    assert type(got["stuck_time_s"]) is int and type(got["learning"]) is bool
    assert type(got["shift"]) is float


def test_parse_set_empty_and_tuple():
    assert parse_set([]) == {}
    assert parse_set(("shift=0.7",)) == {"shift": 0.7}


def test_parse_set_later_wins():
    assert parse_set(["shift=0.7", "shift=0.75"]) == {"shift": 0.75}


def test_parse_set_value_with_equals_sign():
    assert parse_set(["steering=a=b"]) == {"steering": "a=b"}


def test_parse_set_without_equals_is_a_usage_error():
    with pytest.raises(UsageError, match="key=value"):
        parse_set(["shift"])


def test_parse_set_feeds_load_params(setups):
    p, sources = load_params(CAR, TRACK, parse_set(["shift=0.8", "learning=false", "steering=lookahead",
                                                     "stuck_time_s=3"]))
    assert (p.shift, p.learning, p.steering, p.stuck_time_s) == (0.8, False, "lookahead", 3.0)
    assert {sources[k] for k in ("shift", "learning", "steering", "stuck_time_s")} == {"--set"}
    assert sources["lookahead_m"] == "default"
    with pytest.raises(UsageError):
        load_params(CAR, TRACK, parse_set(["shift=fast"]))  # an unquoted word is a string: wrong type


def test_robot_check_setup_fails_early(setups):
    TutorialRobot.check_setup(RaceOptions(robot_args={"set": {"shift": 0.8}}), TRACK, CAR)
    with pytest.raises(UsageError):
        TutorialRobot.check_setup(RaceOptions(robot_args={"set": {"shfit": 0.8}}), TRACK, CAR)
    write(setups / CAR / f"{TRACK}.toml", 'steering = "sideways"\n')
    with pytest.raises(UsageError):
        TutorialRobot.check_setup(RaceOptions(), TRACK, CAR)


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -5.0, 1.6])
def test_numbers_outside_their_declared_bounds_are_refused(value):
    from boxbox.errors import UsageError
    from boxbox.robot.params import load_params

    with pytest.raises(UsageError, match=r"mu_scale must be a finite number from 0.3 to 1.5"):
        load_params("car1-trb1", "g-track-1", {"mu_scale": value})


def test_every_number_parameter_has_a_bound_its_default_keeps():
    import dataclasses

    from boxbox.robot.params import BOUNDS, TutorialParams, bound_of

    defaults = TutorialParams()
    assert set(BOUNDS) <= {f.name for f in dataclasses.fields(TutorialParams)}
    for f in dataclasses.fields(TutorialParams):
        value = getattr(defaults, f.name)
        if isinstance(value, float):
            b = bound_of(f.name)
            assert b.lo <= value <= b.hi, f.name
            assert not b.log or b.lo > 0, f.name
