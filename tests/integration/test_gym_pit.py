"""Pit stops as an action: the env drives into the box and out, the agent drives again."""

from __future__ import annotations

import gymnasium
import numpy as np

import boxbox.gym
from helpers import GRID_IN_UNITS


def test_a_requested_pit_stop_is_driven_by_the_env(overlay):
    env = gymnasium.make(boxbox.gym.ENV_ID, track="g-track-1", laps=2, initial_fuel_l=20.0, max_episode_steps=20_000,
                         **{**GRID_IN_UNITS, "actions": ("steer", "throttle", "brake", "pit")})
    obs, info = env.reset(seed=0)
    assert info["state"].fuel_l == 20.0
    phases, fuel_before, after_stop = [], None, []
    for i in range(20_000):
        steer = 2.0 * obs["angle_rad"][0] - 0.6 * obs["track_pos"][0]
        throttle = 0.2 * (22.0 - obs["speed_mps"][0])
        ask = 1.0 if i == 50 else 0.0  # one request, early in the first lap
        obs, reward, terminated, truncated, info = env.step(
            np.array([np.clip(steer, -1, 1), np.clip(throttle, 0, 1), 0.0, ask], dtype=np.float32))
        s = info["state"]
        if info["pit"] and (not phases or phases[-1] != info["pit"]):
            phases.append(info["pit"])
            if info["pit"] == "stop":
                fuel_before = s.fuel_l
        if s.pit_stops and info["pit"] is None:
            after_stop.append(s.speed_x_mps)  # the agent drives again
        if terminated or truncated:
            break
    env.close()
    assert info["termination"] == "race-end", info
    assert s.pit_stops == 1 and s.penalty_time_s == 0.0  # one stop, within the pit speed limit
    assert {"lane", "stop", "exit"} <= set(phases)
    assert fuel_before < 20.0 and s.fuel_l > 40.0  # filled up at the stop (the tank holds more than 60 l)
    assert len(after_stop) > 500 and max(after_stop) > 20.0
