"""Learn to drive a lap of g-track-1 with the cross-entropy method (numpy only).

The policy is linear: two outputs from nine observations (the angle to the track axis, the
offset from it, the speed, five range finders ahead and a constant; the env scales each to about
-1..1), squashed by tanh: the env's two actions, the steering and the pedal (throttle when
positive, brake when negative).  The cross-entropy method samples a population of weight vectors
from a Gaussian, drives one episode with each from the grid (TORCS is deterministic: one episode
says all), and refits the Gaussian to the best few.

    .venv/bin/python examples/train_cem.py            # until a policy completes a lap (~1-3 min)
    .venv/bin/python examples/train_cem.py --quick    # a few short iterations (what CI runs)

With --json FILE it writes {"lap_completed", "iterations", "best_progress_m", "random_progress_m",
"history"}: the random policy's progress is measured over the same episode length.
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium
import numpy as np

import boxbox.gym  # noqa: F401  (registers boxbox/TORCS-v0)

AHEAD = [4, 7, 9, 11, 14]  # the range finders at -30, -10, 0, 10 and 30 degrees (SCR's default angles)
N_FEATURES = 4 + len(AHEAD)
N_OUTPUTS = 2


# the scaled observations (-1..1) stretched so that the Gaussian's first draws (sd 1) steer and brake as
# much as they need: the angle back to radians, the offset to +-1 at the edges, the speed to 1 at 50 m/s,
# the range finders to 0..1
STRETCH = np.array([np.pi / 2, 2.0, 2.0])


def features(obs: dict) -> np.ndarray:
    ahead = (obs["track_edges_m"][AHEAD] + 1.0) / 2.0
    scaled = np.concatenate([obs["angle_rad"], obs["track_pos"], obs["speed_mps"][:1]])
    return np.concatenate([scaled * STRETCH, [1.0], ahead])


def act(weights: np.ndarray, obs: dict) -> np.ndarray:
    return np.tanh(weights.reshape(N_OUTPUTS, N_FEATURES) @ features(obs)).astype(np.float32)  # steer, pedal


def episode(env, policy, max_steps: int) -> tuple[float, bool]:
    """Metres of progress in one episode, and whether it ended by completing the race (one lap)."""
    obs, _ = env.reset(seed=0)
    progress = 0.0
    for _ in range(max_steps):
        obs, _, terminated, truncated, info = env.step(policy(obs))
        progress += info["progress_m"]
        if terminated or truncated:
            return progress, info["termination"] == "race-end"
    return progress, False


def random_progress(env, max_steps: int, episodes: int, seed: int) -> float:
    rng = np.random.default_rng(seed)
    space = env.action_space
    return float(np.mean([episode(env, lambda obs: rng.uniform(space.low, space.high).astype(np.float32),
                                  max_steps)[0] for _ in range(episodes)]))


def cem(env, iterations: int, population: int, elite: int, max_steps: int, seed: int, log=print) -> dict:
    """The cross-entropy method until a policy completes the lap (or `iterations` run out)."""
    rng = np.random.default_rng(seed)
    mean, std = np.zeros(N_OUTPUTS * N_FEATURES), np.ones(N_OUTPUTS * N_FEATURES)
    best_w, best_score, history = mean, -np.inf, []
    for it in range(1, iterations + 1):
        samples = mean + std * rng.standard_normal((population, mean.size))
        runs = [episode(env, lambda obs, w=w: act(w, obs), max_steps) for w in samples]
        scores = np.array([progress for progress, _ in runs])
        order = np.argsort(scores)[::-1][:elite]
        mean, std = samples[order].mean(axis=0), samples[order].std(axis=0) + 0.02  # a little noise stays
        if scores[order[0]] > best_score:
            best_w, best_score = samples[order[0]], float(scores[order[0]])
        history.append({"iteration": it, "best_m": round(float(scores[order[0]]), 1),
                        "elite_mean_m": round(float(scores[order].mean()), 1)})
        log(f"iteration {it}: best {scores[order[0]]:.0f} m, elite mean {history[-1]['elite_mean_m']:.0f} m")
        if any(lap for _, lap in runs):
            return {"lap_completed": True, "iterations": it, "best_progress_m": best_score, "weights": best_w.tolist(),
                    "history": history}
    return {"lap_completed": False, "iterations": iterations, "best_progress_m": best_score,
            "weights": best_w.tolist(), "history": history}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 iterations of 12 short episodes (CI)")
    parser.add_argument("--iterations", type=int, default=40)
    parser.add_argument("--population", type=int, default=24)
    parser.add_argument("--elite", type=int, default=6)
    parser.add_argument("--max-steps", type=int, default=1600, help="env steps per episode (0.1 s each)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", help="write the summary here")
    args = parser.parse_args()
    if args.quick:
        args.iterations, args.population, args.elite, args.max_steps = 3, 12, 3, 200
    env = gymnasium.make("boxbox/TORCS-v0", track="g-track-1", laps=1, random_start=False)  # a lap from the grid
    started = time.perf_counter()
    result = cem(env, args.iterations, args.population, args.elite, args.max_steps, args.seed)
    result["random_progress_m"] = random_progress(env, args.max_steps, 5, args.seed)
    result["wall_s"] = round(time.perf_counter() - started, 1)
    env.close()
    print(f"lap completed: {result['lap_completed']} after {result['iterations']} iterations "
          f"({result['wall_s']} s); best {result['best_progress_m']:.0f} m, "
          f"a random policy {result['random_progress_m']:.1f} m")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
