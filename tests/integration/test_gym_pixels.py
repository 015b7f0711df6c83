"""Pixels on real TORCS: the race drawn top-down for render() and RecordVideo, and the car's view as
the observation (gym/render.py)."""

from __future__ import annotations

import gymnasium
import numpy as np
from gymnasium.utils.env_checker import check_env

import boxbox.gym
from boxbox.gym.render import OTHER_CAR, OWN_CAR
from helpers import GRID_IN_UNITS

ID = boxbox.gym.ENV_ID


def colour_pixels(image: np.ndarray, colour) -> np.ndarray:
    """(rows, cols) of the pixels of that colour."""
    return np.argwhere((image == np.array(colour, dtype=np.uint8)).all(axis=2))


def test_pixel_observations_are_the_cars_view_and_pass_the_checker(overlay):
    env = gymnasium.make(ID, track="g-track-1", opponents=["bt:2"], pixels=True, pixel_size=(64, 80), **GRID_IN_UNITS)
    assert env.observation_space == gymnasium.spaces.Box(0, 255, (64, 80, 3), np.uint8)
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=0)
    assert obs.shape == (64, 80, 3) and obs.dtype == np.uint8 and env.observation_space.contains(obs)
    own = colour_pixels(obs, OWN_CAR)
    assert len(own) > 0 and abs(own[:, 0].mean() - 0.7 * 64) < 2 and abs(own[:, 1].mean() - 40) < 2  # the car
    assert len(colour_pixels(obs, OTHER_CAR)) > 0  # bt's car beside us on the grid
    first = obs
    for _ in range(100):
        obs, reward, terminated, truncated, info = env.step(np.array([0.0, 0.8, 0.0], np.float32))
    assert not terminated and info["state"].speed_x_mps > 5.0
    assert not np.array_equal(obs, first)  # the track moved past
    env.close()


def test_render_draws_the_race_for_record_video(overlay, tmp_path):
    env = gymnasium.make(ID, track="g-track-1", opponents=["bt:2"], render_mode="rgb_array",
                         **{**GRID_IN_UNITS, "action_repeat": 5})
    assert env.metadata["render_modes"] == ["rgb_array"] and env.metadata["render_fps"] == 10.0
    check_env(env.unwrapped)  # with the render check
    env.reset(seed=0)
    frames = [env.render()]
    for _ in range(20):
        env.step(np.array([0.0, 1.0, 0.0], np.float32))
        frames.append(env.render())
    assert all(f.dtype == np.uint8 and f.shape == frames[0].shape and f.shape[2] == 3 for f in frames)
    assert frames[0].shape[0] % 16 == 0 and frames[0].shape[1] % 16 == 0  # what video codecs want
    start, end = colour_pixels(frames[0], OWN_CAR).mean(axis=0), colour_pixels(frames[-1], OWN_CAR).mean(axis=0)
    assert np.hypot(*(end - start)) > 3  # 2 s at full throttle: the car moved across the picture
    assert len(colour_pixels(frames[-1], OTHER_CAR)) > 0
    env.close()


def test_the_drawing_follows_the_episodes_track(overlay):
    # varied episodes (gym/episodes.py) with pixels: each reset's track is drawn, not the first one's
    env = gymnasium.make(ID, track=["g-track-1", "e-track-2"], render_mode="rgb_array", pixels=True)
    frames, views = {}, {}
    for track in ("g-track-1", "e-track-2", "g-track-1"):
        obs, info = env.reset(seed=0, options={"track": track})
        assert info["track"] == track and env.unwrapped.drawing.track is env.unwrapped.track
        frame = env.render()
        if track in frames:  # the same track again: the same picture
            assert np.array_equal(frame, frames[track]) and np.array_equal(obs, views[track])
        frames[track], views[track] = frame, obs
    first, second = frames["g-track-1"], frames["e-track-2"]
    assert first.shape != second.shape or not np.array_equal(first, second)
    env.close()
