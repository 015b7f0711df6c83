"""Episode drawing (gym/episodes.py): lists and distributions checked before anything runs, the
same seed gives the same episodes, reset options choose values, SCR's noise."""

from __future__ import annotations

import numpy as np
import pytest

from boxbox.errors import UsageError
from boxbox.gym import episodes as ep
from boxbox.gym.episodes import CHECKS, EpisodeStream, OneOf, Uniform, add_scr_noise, parse_draw


def draws(**options):
    """The options' draws, as Episodes parses them (without TORCS's checks)."""
    fixed = {"track": "g-track-1", "car": "car1-trb1", "opponents": (), "grid_position": None,
             "skill_level": "semi-pro", "initial_fuel_l": None} | options
    return {key: parse_draw(fixed[key], CHECKS[key], key, list_is_one=key == "opponents",
                            numbers=(0, ep.MAX_FUEL_L) if key == "initial_fuel_l" else None)
            for key in ep.EPISODE_KEYS}


class Unchecked(ep.Episodes):
    """Episodes without the installed TORCS (the integration tests check names against it)."""

    def __init__(self, random_start: bool = False, **options) -> None:
        self.laps = 1
        self.random_start = random_start
        self.draws = draws(**options)
        self._configs = {}


VARIED = dict(track=["g-track-1", "e-track-2", "aalborg"], car={"car1-trb1": 3, "car1-ow1": 1},
              opponents=OneOf((), ["bt:2"], ["bt:2", "berniw:3"]), grid_position=[1, 2],
              skill_level=["rookie", "pro"], initial_fuel_l=Uniform(5, 60))


def episodes_of(seed: int, n: int = 50) -> list:
    stream = EpisodeStream(Unchecked(**VARIED), np.random.default_rng(seed))
    return [stream.next() for _ in range(n)]


def test_same_seed_same_episodes_and_every_value_drawn():
    first, again, other = episodes_of(3), episodes_of(3), episodes_of(4)
    assert first == again and first != other
    assert {e.track for e in first} == {"g-track-1", "e-track-2", "aalborg"}
    assert {e.opponents for e in first} == {(), ("bt:2",), ("bt:2", "berniw:3")}
    assert all(5 <= e.initial_fuel_l <= 60 for e in first)
    cars = [e.car for e in episodes_of(0, 400)]
    assert 0.65 < cars.count("car1-trb1") / len(cars) < 0.85  # weights 3:1


def test_drawing_ahead_changes_nothing():
    ahead = EpisodeStream(Unchecked(**VARIED), np.random.default_rng(3))
    seen = []
    for _ in range(10):
        upcoming = ahead.peek(2)
        seen.append(ahead.next())
        assert ahead.peek(1)[0] == upcoming[1]
    assert seen == episodes_of(3, 10)


def test_fixed_options_draw_nothing():
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    episode = Unchecked().draw(rng)
    assert rng.bit_generator.state == state
    assert (episode.track, episode.opponents, episode.initial_fuel_l) == ("g-track-1", (), None)


@pytest.mark.parametrize(("options", "words"), [
    ({"track": []}, "Invalid value for 'track': nothing to draw from"),
    ({"track": ["g-track-1", 3]}, "Invalid value for 'track': 3 is not a track name"),
    ({"car": {"car1-trb1": -1}}, "Invalid value for 'car': -1.0 is not in the range x>=0"),
    ({"car": {"car1-trb1": 0}}, "the weights add up to 0"),
    ({"car": OneOf("car1-trb1", "car1-ow1", weights=[1])}, "give one weight per value (2)"),
    ({"initial_fuel_l": Uniform(50, 10)}, "the range ends before it starts"),
    ({"initial_fuel_l": Uniform(0, 2000)}, "2000.0 is not in the range 0<=x<=1000.0"),
    ({"initial_fuel_l": [10, float("nan")]}, "nan is not a finite number"),
    ({"grid_position": Uniform(1, 3)}, "Uniform(low, high) is for numbers"),
    ({"grid_position": [1, 99]}, "99 is not a grid slot"),
    ({"skill_level": ["pro", "expert"]}, "'expert' is not one of"),
    ({"opponents": OneOf(["bt:2"], [3])}, "3 is not an opponent"),
])
def test_bad_values_are_one_usage_error(options, words):
    with pytest.raises(UsageError) as caught:
        draws(**options)
    assert words in str(caught.value) and "\n" not in str(caught.value)


def test_reset_options_are_checked_values():
    episodes = Unchecked()
    assert episodes.explicit(None) == {}
    assert episodes.explicit({"track": " e-track-2 ", "grid_position": "last", "opponents": "bt:2,berniw:3"}) == \
        {"track": "e-track-2", "grid_position": "last", "opponents": ("bt:2", "berniw:3")}
    with pytest.raises(UsageError, match="reset\\(\\) does not take 'laps'"):
        episodes.explicit({"laps": 2})
    with pytest.raises(UsageError, match="Invalid value for 'initial_fuel_l': -1.0 is not in the range"):
        episodes.explicit({"initial_fuel_l": -1})


def test_scr_noise_is_relative_and_spares_off_track_readings():
    rng = np.random.default_rng(0)
    edges, sectors = np.full(19, 100.0), np.full(36, 200.0)
    noisy = [add_scr_noise(rng, edges, sectors) for _ in range(2000)]
    e = np.concatenate([n[0] for n in noisy]) / 100.0
    s = np.concatenate([n[1] for n in noisy]) / 200.0
    assert abs(e.mean() - 1) < 0.01 and abs(e.std() - 0.1) < 0.01  # SCR: x N(1, 0.1)
    assert abs(s.mean() - 1) < 0.002 and abs(s.std() - 0.02) < 0.002  # SCR: x N(1, 0.02)
    off = np.full(19, -1.0)
    assert (add_scr_noise(rng, off, sectors)[0] == -1.0).all()
    a = add_scr_noise(np.random.default_rng(5), edges, sectors)
    b = add_scr_noise(np.random.default_rng(5), edges, sectors)
    assert all((x == y).all() for x, y in zip(a, b, strict=True))
