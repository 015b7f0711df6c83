"""`boxbox bench-gym`: the env's speed, resets and resource use, with gym_torcs's figures beside.

Measured (`run_bench`):
- env steps a second, one env on one core (TORCS runs on the core of the thread that steps it), random
  actions on g-track-1, episodes of `episode_steps` steps; the figure without the resets and
  with them;
- a random policy (Gaussian actions) with the env's own limits (the car leaves the track within a
  few hundred steps, so resets weigh): env steps a second, resets included, and the reset median
  and 95th percentile, without spare races (`spares=0`, each reset starts TORCS) and with one,
  alternating in rounds in the same run (the machine's load moves);
- the same with an AsyncVectorEnv of `vector_envs` envs (env steps a second, all envs together);
- over `episodes` short episodes (a reset and 20 random steps each): the median and 95th
  percentile reset time, and this process's memory, open files and child processes after the
  10th episode and after the last.
Random actions are drawn with numpy in batches beforehand: `action_space.sample()` alone costs
about 20 us, as much as a step, and is the learner's cost, not the env's.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium
import numpy as np
import psutil

from boxbox.gym import ENV_ID
from boxbox.gym.env import DEFAULT_ACTION_REPEAT
from boxbox.model.constants import DRIVE_STEP_S

# gym_torcs and its forks, as their users report them (see docs/gym.md for the threads)
GYM_TORCS_STEPS_PER_S = "5-23"
GYM_TORCS_SOURCES = "gym_torcs #31, #54; pyTORCS-docker #8"
Log = Callable[[str], None]


@dataclass
class Row:
    measure: str
    value: str
    target: str = ""
    gym_torcs: str = ""


def _actions(space, n: int, rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(space.low, space.high, size=(n, *space.shape)).astype(np.float32)


def make_env(track: str, episode_steps: int, **kwargs):
    """The env the bench measures: episodes end by truncation only (random actions would get the
    car 'stuck' within seconds and make every episode a reset)."""
    return gymnasium.make(ENV_ID, track=track, stuck_s=None, off_track_s=None, max_episode_steps=episode_steps,
                          flat=True, **kwargs)


def single_env(track: str, steps: int, episode_steps: int, seed: int = 0) -> tuple[float, float]:
    """(steps a second without the resets, steps a second with them)."""
    return timed_steps(make_env(track, episode_steps), steps, seed)


def timed_steps(env: gymnasium.Env, steps: int, seed: int = 0) -> tuple[float, float]:
    """`steps` random actions through env, reset at each episode's end, then the env closed:
    (steps a second without the resets, steps a second with them)."""
    actions = _actions(env.action_space, min(steps, 10_000), np.random.default_rng(seed))
    env.reset(seed=seed)
    wall, resets_s = stepped(env, actions, steps)
    env.close()
    return steps / (wall - resets_s), steps / wall


def stepped(env: gymnasium.Env, actions: np.ndarray, steps: int) -> tuple[float, float]:
    """`steps` of `actions` (in turn) through a reset env, reset at each episode's end: (wall s, of
    which resetting s)."""
    resets_s = 0.0
    started = time.perf_counter()
    for i in range(steps):
        _, _, terminated, truncated, _ = env.step(actions[i % len(actions)])
        if terminated or truncated:
            t = time.perf_counter()
            env.reset()
            resets_s += time.perf_counter() - t
    return time.perf_counter() - started, resets_s


@dataclass
class PolicyRun:
    steps: int = 0
    wall_s: float = 0.0
    resets_s: list[float] = field(default_factory=list)
    spares_used: int = 0

    def row(self, label: str, target: str = "") -> list[Row]:
        rate = self.steps / self.wall_s if self.wall_s else 0.0
        times = np.array(self.resets_s or [0.0]) * 1000
        return [Row(f"random policy, resets included, {label}: env steps/s ({len(self.resets_s)} episodes)",
                    f"{rate:,.0f}", ">= 10,000" if target else ""),
                Row(f"random policy, {label}: reset median (95th percentile)",
                    f"{np.median(times):.2f} ms ({np.percentile(times, 95):.2f} ms)", target,
                    "" if not self.spares_used else f"{self.spares_used} resets took a spare")]


def policy_actions(space, n: int, rng: np.random.Generator) -> np.ndarray:
    """Gaussian actions (sd 0.5 about the middle of each column), clipped to the space."""
    mid, half = (space.high + space.low) / 2, (space.high - space.low) / 2
    return np.clip(rng.normal(mid, 0.5 * half, size=(n, *space.shape)), space.low, space.high).astype(np.float32)


def random_policy(track: str, steps: int, spares: int, run: PolicyRun, seed: int = 0) -> None:
    """`steps` env steps of a random policy through gymnasium.make with the env's own limits."""
    env = gymnasium.make(ENV_ID, track=track, flat=True, spares=spares)
    actions = policy_actions(env.action_space, min(steps, 10_000), np.random.default_rng(seed))
    env.reset(seed=seed)
    started = time.perf_counter()
    for i in range(steps):
        _, _, terminated, truncated, _ = env.step(actions[i % len(actions)])
        if terminated or truncated:
            t = time.perf_counter()
            _, info = env.reset()
            run.resets_s.append(time.perf_counter() - t)
            run.spares_used += bool(info["spare"])
    run.wall_s += time.perf_counter() - started
    run.steps += steps
    env.close()


def spares_compared(track: str, steps: int, rounds: int = 2) -> tuple[PolicyRun, PolicyRun]:
    """(without spares, with one): `rounds` rounds of steps/rounds steps each, alternating."""
    old, new = PolicyRun(), PolicyRun()
    for r in range(rounds):
        random_policy(track, steps // rounds, 0, old, seed=r)
        random_policy(track, steps // rounds, 1, new, seed=r)
    return old, new


def vector_env(track: str, n_envs: int, steps: int, episode_steps: int, seed: int = 0) -> float:
    """Env steps a second of an AsyncVectorEnv (each sub-env steps `steps` times)."""
    venv = gymnasium.vector.AsyncVectorEnv([lambda: make_env(track, episode_steps)] * n_envs)
    rng = np.random.default_rng(seed)
    actions = _actions(venv.action_space, min(steps, 2_000), rng)
    venv.reset(seed=seed)
    started = time.perf_counter()
    for i in range(steps):
        venv.step(actions[i % len(actions)])
    wall = time.perf_counter() - started
    venv.close()
    return n_envs * steps / wall


@dataclass
class Soak:
    reset_median_s: float
    reset_p95_s: float
    rss_mb: tuple[float, float]  # after the 10th episode, after the last
    fds: tuple[int, int]
    processes: tuple[int, int]  # this process's children (TORCS and its spare)


def reset_soak(track: str, episodes: int, steps: int = 20, seed: int = 0) -> Soak:
    me = psutil.Process()
    env = gymnasium.make(ENV_ID, track=track, flat=True)
    actions = _actions(env.action_space, steps, np.random.default_rng(seed))
    times, marks = [], []
    for episode in range(1, episodes + 1):
        t = time.perf_counter()
        env.reset()
        times.append(time.perf_counter() - t)
        for a in actions:
            env.step(a)
        if episode in (10, episodes):
            torcs_env: Any = env.unwrapped
            torcs_env.session.settle()  # the spare ready, the last race collected
            marks.append((me.memory_info().rss / 2**20, len(os.listdir("/proc/self/fd")),
                          len(me.children(recursive=True))))
    env.close()
    first, last = marks[0], marks[-1]
    return Soak(float(np.median(times)), float(np.percentile(times, 95)), (first[0], last[0]),
                (first[1], last[1]), (first[2], last[2]))


def run_bench(track: str = "g-track-1", steps: int = 100_000, episode_steps: int = 1000, vector_envs: int = 8,
              vector_steps: int = 5_000, episodes: int = 1000, policy_steps: int = 40_000,
              log: Log = lambda text: None, on_cluster: bool = False) -> list[Row]:
    """Every measurement as table rows (measure, boxbox's figure, the target, gym_torcs's figure);
    `on_cluster`: the vector measurement's envs on the Ray cluster this process is connected to."""
    cores = len(os.sched_getaffinity(0))
    log(f"one env: {steps} steps of random actions")
    bare, with_resets = single_env(track, steps, episode_steps)
    log(f"a random policy with the env's limits: {policy_steps} steps without spare races and with one")
    old, new = spares_compared(track, policy_steps) if policy_steps else (PolicyRun(), PolicyRun())
    vector_row = f"env steps/s, AsyncVectorEnv of {vector_envs} on {cores} cores (all envs)"
    if on_cluster and vector_envs:
        from boxbox.gym.vector_cluster import vector_on_cluster

        log(f"{vector_envs} envs on the Ray cluster: {vector_steps} steps each")
        vec, nodes = vector_on_cluster(track, vector_envs, vector_steps, episode_steps)
        vector_row = f"env steps/s, {vector_envs} envs as Ray actors on {nodes} nodes of the cluster (all envs)"
    else:
        log(f"AsyncVectorEnv of {vector_envs}: {vector_steps} steps each")
        vec = vector_env(track, vector_envs, vector_steps, episode_steps) if vector_envs else 0.0
    log(f"{episodes} episodes of a reset and 20 steps")
    soak = reset_soak(track, episodes)
    return [
        Row("env steps/s, 1 env on 1 core, random actions", f"{bare:,.0f}", ">= 10,000 (aim 20,000)",
            f"{GYM_TORCS_STEPS_PER_S} ({GYM_TORCS_SOURCES})"),
        Row(f"the same with a reset every {episode_steps} steps", f"{with_resets:,.0f}"),
        Row(f"the first in race time: simulated s a wall s (action_repeat {DEFAULT_ACTION_REPEAT}: drive steps of "
            f"{DRIVE_STEP_S} s an env step)", f"{bare * DEFAULT_ACTION_REPEAT * DRIVE_STEP_S:,.0f}"),
        *(old.row("no spare (spares=0: TORCS started at each reset)") if policy_steps else []),
        *(new.row("a spare race (spares=1, the default)", "<= 3 ms") if policy_steps else []),
        Row(vector_row, f"{vec:,.0f}"),
        Row(f"reset, median of {episodes} (95th percentile)",
            f"{soak.reset_median_s * 1000:.1f} ms ({soak.reset_p95_s * 1000:.1f} ms)", "< 300 ms",
            "relaunches TORCS every few episodes (gym_torcs #37)"),
        Row(f"memory (RSS) after 10 / {episodes} episodes", f"{soak.rss_mb[0]:.1f} / {soak.rss_mb[1]:.1f} MB",
            "flat"),
        Row(f"open file descriptors after 10 / {episodes} episodes", f"{soak.fds[0]} / {soak.fds[1]}", "flat"),
        Row(f"child processes after 10 / {episodes} episodes", f"{soak.processes[0]} / {soak.processes[1]}", "flat"),
    ]


def markdown(rows: list[Row]) -> str:
    lines = ["| measure | boxbox/TORCS-v0 | target | gym_torcs (published) |", "|---|---|---|---|"]
    lines += [f"| {r.measure} | {r.value} | {r.target} | {r.gym_torcs} |" for r in rows]
    return "\n".join(lines)
