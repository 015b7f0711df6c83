"""The env's defaults on real TORCS: the seed decides where an episode starts (different seeds, different
episodes; the same seed and actions, the same episode), the observations are scaled with their units in
`info`, the checker passes, and the parallel env seeds and truncates the same way.  Short episodes."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import boxbox.gym
from boxbox.gym.start import LAUNCH_MAX_STEPS
from boxbox.model.constants import DRIVE_STEP_S

ID = boxbox.gym.ENV_ID
STEPS = 30  # 3 s of racing
ACTIONS = np.random.default_rng(5).uniform([-0.2, -0.2], [0.2, 1.0], size=(STEPS, 2)).astype(np.float32)


def episode(env, seed: int) -> tuple[dict, np.ndarray]:
    """The reset's info, and the episode's observations and rewards as one vector."""
    obs, info = env.reset(seed=seed)
    seen = [gymnasium.spaces.flatten(env.observation_space, obs)]
    for action in ACTIONS:
        obs, reward, terminated, truncated, _ = env.step(action)
        seen += [gymnasium.spaces.flatten(env.observation_space, obs), np.float32([reward])]
        if terminated or truncated:
            break
    return info, np.concatenate(seen)


def test_the_seed_draws_the_start_and_the_same_seed_gives_the_same_episode(overlay):
    env = gymnasium.make(ID, track="g-track-1", opponents=["bt:2"])
    check_env(env.unwrapped, skip_render_check=True)
    first, a = episode(env, 0)
    second, b = episode(env, 1)
    again, c = episode(env, 0)
    env.close()
    length = first["track_length_m"]
    assert a.tobytes() == c.tobytes() and first["state"] == again["state"]  # the same seed: bit for bit
    assert a[:69].tobytes() != b[:69].tobytes()  # another seed: another first observation
    places = [info["state"].dist_from_start_m for info in (first, second)]
    assert abs(places[0] - places[1]) > 10.0 and all(0.0 <= p < length for p in places)
    for info in (first, second):  # past the countdown and the start's launch
        start = info["start"]
        assert 0.0 <= info["state"].sim_time_s <= (start.launch_steps + 2) * DRIVE_STEP_S
        assert start.launch_steps <= LAUNCH_MAX_STEPS and 0.0 <= start.fraction < 1.0


def test_observations_are_scaled_with_their_units_in_info(overlay):
    env = gymnasium.make(ID, track="g-track-1")
    obs, info = env.reset(seed=3)
    assert env.observation_space["speed_mps"].low[0] == -1.0 and env.observation_space.contains(obs)
    raw, state = info["raw_observation"], info["state"]
    assert raw["dist_from_start_m"][0] == pytest.approx(state.dist_from_start_m, abs=1e-3)
    assert obs["dist_from_start_m"][0] == pytest.approx(2 * state.dist_from_start_m / info["track_length_m"] - 1,
                                                        abs=1e-5)
    obs, _, _, _, info = env.step(np.float32([0.0, 1.0]))
    assert obs["speed_mps"][0] == pytest.approx(info["raw_observation"]["speed_mps"][0] / 100.0, abs=1e-6)
    env.close()
    grid = gymnasium.make(ID, track="g-track-1", random_start=False, raw_observations=True)
    starts = {grid.reset(seed=seed)[1]["state"].dist_from_start_m for seed in (0, 1)}
    assert len(starts) == 1 and starts.pop() > 2000.0  # the grid, 25 m behind the line, whatever the seed
    grid.close()


def test_a_track_that_places_its_own_grid_starts_there(overlay):
    env = gymnasium.make(ID, track="alpine-1")  # its file's "Starting Grid" overrides the race file's
    places = {round(env.reset(seed=seed)[1]["state"].dist_from_start_m) for seed in (0, 1)}
    env.close()
    length = env.unwrapped.track.length_m
    assert all(p > length - 30.0 for p in places)  # behind the start line (the launch moves the car a little)


def test_the_parallel_env_seeds_its_starts_and_truncates_at_max_episode_steps(overlay):
    env = boxbox.gym.parallel_env(cars=2, track="g-track-1", max_episode_steps=5)

    def run(seed: int) -> tuple[list[float], np.ndarray, dict]:
        obs, infos = env.reset(seed=seed)
        places = [infos[a]["state"].dist_from_start_m for a in env.possible_agents]
        trace = [np.concatenate([gymnasium.spaces.flatten(env.observation_space(a), obs[a]) for a in env.agents])]
        while env.agents:
            obs, rewards, terminations, truncations, infos = env.step({a: ACTIONS[0] for a in env.agents})
            trace.append(np.float32(list(rewards.values())))
        return places, np.concatenate(trace), {a: (terminations[a], truncations[a]) for a in terminations}

    a, b, c = run(0), run(1), run(0)
    env.close()
    assert a[0] == c[0] and a[1].tobytes() == c[1].tobytes()  # the same seed: the same episode
    assert abs(a[0][0] - b[0][0]) > 10.0  # another seed: the grid elsewhere on the lap
    assert a[0][0] > a[0][1]  # car_1 behind car_0 on the grid
    assert a[2] == {"car_0": (False, True), "car_1": (False, True)}  # 5 steps: truncated, not terminated
