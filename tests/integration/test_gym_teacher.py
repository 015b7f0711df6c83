"""The robot as the env's teacher on real TORCS: its action for the learner's state, fed back as the
learner's action, drives the car along g-track-1 (a lap at a decision every 0.04 s)."""

from __future__ import annotations

import gymnasium
import pytest

import boxbox.gym

pytestmark = pytest.mark.torcs


def fed_back(env, seed: int, steps: int) -> tuple[float, dict, int]:
    """Progress (m), the last info and the steps driven, with the teacher's action as the action."""
    _, info = env.reset(seed=seed)
    progress, n = 0.0, 0
    while n < steps:
        _, _, terminated, truncated, info = env.step(info["teacher_action"])
        progress, n = progress + info["progress_m"], n + 1
        if terminated or truncated:
            break
    return progress, info, n


def test_the_teacher_action_fed_back_drives_along_the_track():
    env = gymnasium.make(boxbox.gym.ENV_ID, track="g-track-1", teacher="boxbox")  # the defaults: 0.1 s, a drawn start
    try:
        progress, info, steps = fed_back(env, seed=0, steps=150)
        assert steps == 150 and info["termination"] is None and progress > 500.0, (steps, info["termination"], progress)
        assert env.action_space.contains(info["teacher_action"])
    finally:
        env.close()
    env = gymnasium.make(boxbox.gym.ENV_ID, track="g-track-1", teacher="boxbox", action_repeat=2, random_start=False)
    try:
        progress, info, _ = fed_back(env, seed=0, steps=2000)
        # the shipped robot's own race: 41.1 s; held for 0.04 s and without its car setup, 42.6 s
        assert info["termination"] == "race-end" and progress > 2000.0, (info["termination"], progress)
        assert 0 < info["state"].last_lap_time_s < 45.0
    finally:
        env.close()
