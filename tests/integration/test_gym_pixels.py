"""Pixels on real TORCS: the race drawn top-down for render() and RecordVideo, and the car's view as
the observation (gym/render.py)."""

from __future__ import annotations

import gymnasium
import numpy as np
from gymnasium.utils.env_checker import check_env

import boxbox.gym
from boxbox.gym.dashboard import FRAME_ROWS, SPEED_BAR, view_rows
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


def speed_bar(image: np.ndarray, rows: int) -> int:
    """Columns of the dashboard's speed bar (white, from the left) in the strip of the last `rows` rows."""
    return int((image[-rows // 2, :, :] == np.array(SPEED_BAR, np.uint8)).all(axis=1).sum())


def test_pixels_with_the_numbers_and_the_dashboard_pass_the_checker(overlay):
    # the view and the numbers in one Dict (gym/pixelobs.py), the dashboard strip, a look 100 m ahead
    env = gymnasium.make(ID, track="g-track-1", pixels=True, pixels_only=False, dashboard=True, view_ahead_m=100,
                         render_mode="rgb_array", random_start=False)
    check_env(env.unwrapped)  # with the render check
    obs, info = env.reset(seed=0)
    numbers = env.unwrapped.layout.dict_space(True)
    assert set(obs) == {"pixels", *numbers.spaces} and env.observation_space.contains(obs)
    assert obs["pixels"].shape == (96, 96, 3) and obs["pixels"].dtype == np.uint8
    assert speed_bar(obs["pixels"], view_rows(96)) == 0  # on the grid, at rest
    for _ in range(20):  # 2 s at full throttle
        obs, reward, terminated, truncated, info = env.step(np.array([0.0, 1.0], np.float32))
    speed = info["state"].speed_x_mps
    assert not terminated and speed > 10.0
    assert abs(obs["speed_mps"][0] - speed / 100.0) < 1e-6  # the numbers as without pixels: scaled
    bar = speed_bar(obs["pixels"], view_rows(96))
    assert abs(bar - speed / 100.0 * 34) <= 1  # the speed bar as long as the speed
    assert speed_bar(env.render(), FRAME_ROWS) > 0  # render()'s frame has the strip below it
    env.close()
    flat = gymnasium.make(ID, track="g-track-1", pixels=True, pixels_only=False, flat=True, pixel_size=(64, 64))
    assert set(flat.observation_space.spaces) == {"pixels", "state"}
    check_env(flat.unwrapped, skip_render_check=True)
    flat.close()
