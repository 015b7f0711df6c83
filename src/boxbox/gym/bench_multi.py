"""bench-gym's figures of pixels and of several learning cars (`boxbox bench-gym --multi-steps N`).

Measured on the envs as users make them: `gymnasium.make("boxbox/TORCS-v0", pixels=True)` (96x96
views; then with every pixel option on: the numbers beside the view, the dashboard, 100 m ahead) and
`boxbox.gym.parallel_env(cars=n)` for 2 and 4 cars, random actions drawn beforehand, episodes ending
by truncation only (as bench.py's), resets left out of the figures.  One parallel step moves every
car: its figure is env steps a second; per agent, that times the cars.
"""

from __future__ import annotations

import time
from typing import Any

import gymnasium
import numpy as np

from boxbox.gym import ENV_ID
from boxbox.gym.bench_gym import Log, Row, _actions, timed_steps
from boxbox.gym.parallel import parallel_env

# the pixel options all on (gym/pixelobs.py): what they cost beside the view alone
PIXEL_OPTIONS: dict[str, Any] = {"pixels_only": False, "dashboard": True, "view_ahead_m": 100.0}


def pixel_steps_per_s(track: str, steps: int, episode_steps: int, seed: int = 0, **options: Any) -> float:
    env = gymnasium.make(ENV_ID, track=track, stuck_s=None, off_track_s=None, max_episode_steps=episode_steps,
                         pixels=True, **options)
    return timed_steps(env, steps, seed)[0]


def parallel_steps_per_s(track: str, cars: int, steps: int, episode_steps: int, seed: int = 0) -> float:
    """Env steps a second (each moves all `cars` cars) of the parallel env."""
    env = parallel_env(cars=cars, track=track, flat=True, stuck_s=None, off_track_s=None)
    space = env.action_space(env.possible_agents[0])
    width = int(np.prod(space.shape or (1,)))
    actions = _actions(space, min(steps, 10_000) * cars, np.random.default_rng(seed)).reshape(-1, cars, width)
    env.reset(seed=seed)
    resets_s = 0.0
    started = time.perf_counter()
    for i in range(steps):
        row = actions[i % len(actions)]
        env.step({agent: row[k] for k, agent in enumerate(env.agents)})
        if not env.agents or (i + 1) % episode_steps == 0:
            t = time.perf_counter()
            env.reset()
            resets_s += time.perf_counter() - t
    wall = time.perf_counter() - started
    env.close()
    return steps / (wall - resets_s)


def run_multi_bench(track: str = "g-track-1", steps: int = 20_000, episode_steps: int = 1000,
                    log: Log = lambda text: None) -> list[Row]:
    log(f"pixel observations 96x96: {steps} steps")
    pixels = pixel_steps_per_s(track, steps, episode_steps)
    rows = [Row("env steps/s with 96x96 pixel observations (resets left out)", f"{pixels:,.0f}", ">= 5,000")]
    log(f"pixel observations 96x96 with the numbers, the dashboard, 100 m ahead: {steps} steps")
    every = pixel_steps_per_s(track, steps, episode_steps, **PIXEL_OPTIONS)
    rows.append(Row("env steps/s with 96x96 pixels and the numbers in one Dict, the dashboard, 100 m ahead (resets "
                    "left out; the view alone's share)", f"{every:,.0f} ({every / pixels:.2f})", ""))
    for cars in (2, 4):
        log(f"{cars} learning cars in one race: {steps} steps")
        rate = parallel_steps_per_s(track, cars, steps, episode_steps)
        rows.append(Row(f"env steps/s with {cars} learning cars in one race (each step moves all; per car)",
                        f"{rate:,.0f} ({rate * cars:,.0f})", ">= 4,000" if cars == 4 else ""))
    return rows
