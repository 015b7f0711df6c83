"""Varied episodes on real TORCS: tracks, cars, fields, grid slots, levels and start fuel drawn
per reset from the seed, chosen by reset(options=...), reported in info; SCR's sensor noise."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

import boxbox.gym
from boxbox.errors import UsageError
from boxbox.gym.episodes import OneOf, Uniform

ID = boxbox.gym.ENV_ID
KEYS = ("track", "car", "opponents", "grid_position", "skill_level", "initial_fuel_l")


def drawn(env, seed: int, n: int) -> list[tuple]:
    _, info = env.reset(seed=seed)
    out = [tuple(info[k] for k in KEYS)]
    for _ in range(n - 1):
        _, info = env.reset()
        out.append(tuple(info[k] for k in KEYS))
    return out


def test_episodes_drawn_from_the_seed_take_effect_and_keep_the_spaces(overlay):
    env = gymnasium.make(ID, track=["g-track-1", "e-track-2"], car=["car1-trb1", "car1-ow1"],
                         opponents=OneOf((), ["bt:2"]), grid_position=[1, "last"], skill_level=["rookie", "pro"],
                         initial_fuel_l=Uniform(10, 40))
    space = env.observation_space
    first = drawn(env, 5, 8)
    assert drawn(env, 5, 8) == first  # the same seed: the same episodes
    assert {e[0] for e in first} == {"g-track-1", "e-track-2"} and len(set(first)) > 4
    for _ in range(4):
        obs, info = env.reset()
        assert env.observation_space == space and space.contains(obs)  # fixed across tracks and cars
        cfg = env.unwrapped.cfg
        assert (info["track"], info["car"], env.unwrapped.car.name) == (cfg.track, cfg.car, cfg.car)
        assert info["grid_position"] == (cfg.grid_position or 1) <= 1 + len(info["opponents"])
        assert 10 <= info["initial_fuel_l"] <= 40  # the tank holds more: the drawn fuel took effect
        assert round(info["track_length_m"]) == {"g-track-1": 2058, "e-track-2": 5381}[info["track"]]
    env.close()


def test_reset_options_choose_and_unknown_names_are_refused(overlay):
    env = gymnasium.make(ID, track="g-track-1")
    _, info = env.reset(seed=0, options={"opponents": ["bt:2", "berniw:3"], "grid_position": "last",
                                         "skill_level": "pro", "initial_fuel_l": 12.5})
    assert (info["opponents"], info["grid_position"], info["skill_level"]) == (("bt:2", "berniw:3"), 3, "pro")
    assert info["initial_fuel_l"] == pytest.approx(12.5, abs=0.01)
    with pytest.raises(UsageError, match="unknown track 'g-track-9'"):
        env.reset(options={"track": "g-track-9"})
    with pytest.raises(UsageError, match=r"reset\(\) does not take 'laps' \(reset options: track, car"):
        env.reset(options={"laps": 2})
    _, info = env.reset()  # back to the env's own options
    assert (info["opponents"], info["grid_position"]) == ((), 1)
    env.close()


def test_sensor_noise_is_drawn_from_the_seed(overlay):
    def episode(env, seed):
        obs, _ = env.reset(seed=seed)
        seen = [obs]
        for _ in range(30):
            obs, *_ = env.step(np.array([0.0, 0.3], np.float32))
            seen.append(obs)
        return np.concatenate(seen)

    # in units: the noise multiplies the range finders' metres (scaled, their ratio would not be the factor)
    noisy = gymnasium.make(ID, track="g-track-1", opponents=["bt:2"], flat=True, sensor_noise=True,
                           raw_observations=True)
    clean = gymnasium.make(ID, track="g-track-1", opponents=["bt:2"], flat=True, spares=0, raw_observations=True)
    a, b, c, d = episode(noisy, 1), episode(noisy, 1), episode(noisy, 2), episode(clean, 1)
    assert a.tobytes() == b.tobytes() and a.tobytes() != c.tobytes()
    edges = clean.unwrapped.layout.slices["track_edges_m"]
    ratio = a.reshape(31, -1)[:, edges] / d.reshape(31, -1)[:, edges]
    assert 0.05 < ratio.std() < 0.15  # SCR: each range finder times N(1, 0.1)
    noisy.close()
    clean.close()
