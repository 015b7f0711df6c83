"""Learn to drive a lap of g-track-1 with Stable-Baselines3's SAC (the rl extra: ./boxbox install-rl).

The policy is SAC's MLP (64x64) on 23 numbers: the angle to the track axis, the offset from it, the
speed along and across the car and the 19 range finders, scaled to about -1..1. It acts every 5
drive steps (0.1 s) with two outputs: the steering, and one pedal (below -0.5 the brake, above it
the throttle). The reward is the env's: metres of progress, less a metre a drive step off the
track. Exploration is gSDE's (noise that is a function of the observation, drawn afresh each
episode). Training stops when a deterministic rollout of the policy completes the lap (tried after
each training episode that completed it, and every --eval-every steps), or after --steps.

    .venv/bin/python examples/train_sac.py --out sac-g-track-1            # until it laps (minutes)
    .venv/bin/python examples/train_sac.py --out /tmp/sac --steps 300     # a smoke run (what CI runs)

It writes into --out: model.zip (SAC.load), curve.csv (a row per training episode and per
deterministic rollout: steps, wall_s, kind, episode_return, progress_m, lap_completed, termination),
curve.png, and summary.json (the last rollout: lap completed, progress, lap time).
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import gymnasium
import numpy as np
import torch
from stable_baselines3 import SAC
from stable_baselines3.common.callbacks import BaseCallback

import boxbox.gym  # noqa: F401  (registers boxbox/TORCS-v0)
from boxbox.gym.reward import RewardWeights

ACTION_REPEAT = 5  # drive steps (0.02 s each) an action holds
EPISODE_S = 120.0  # simulated seconds before an episode is cut (a lap of g-track-1 takes about 40)


class Driver(gymnasium.Wrapper):
    """The env seen by the learner: 23 scaled numbers in, [steer, pedal] out."""

    def __init__(self, env: gymnasium.Env):
        super().__init__(env)
        self.observation_space = gymnasium.spaces.Box(-5.0, 5.0, (23,), np.float32)
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32)

    @staticmethod
    def features(obs: dict) -> np.ndarray:
        return np.concatenate([obs["angle_rad"], obs["track_pos"], obs["speed_mps"] / 50.0,
                               obs["track_edges_m"] / 100.0]).astype(np.float32)

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        return self.features(obs), info

    def step(self, action):
        steer, pedal = (float(a) for a in np.clip(action, -1.0, 1.0))
        # pedal -1 .. -0.5 brakes (fully at -1), -0.5 .. 0.5 opens the throttle, 0.5 .. 1 holds it open: a
        # random policy drives off the grid instead of standing still until the env calls it stuck
        throttle, brake = min(max(pedal + 0.5, 0.0), 1.0), max(-2.0 * (pedal + 0.5), 0.0)
        obs, reward, terminated, truncated, info = self.env.step(np.array([steer, throttle, brake], np.float32))
        return self.features(obs), reward, terminated, truncated, info


def make_env() -> gymnasium.Env:
    # the env in units, from the grid, with two pedals and the reward weights the figures in docs/gym.md were
    # measured with: this wrapper scales and maps the pedal itself
    env = gymnasium.make("boxbox/TORCS-v0", track="g-track-1", laps=1, action_repeat=ACTION_REPEAT, off_track_s=0.5,
                         max_episode_steps=int(EPISODE_S / (0.02 * ACTION_REPEAT)), raw_observations=True,
                         random_start=False, actions=("steer", "throttle", "brake"),
                         reward_weights=RewardWeights(off_track_m=1.0, off_track_progress=1.0))
    return Driver(env)


def rollout(model: SAC, env: gymnasium.Env) -> dict:
    """One deterministic episode: did it complete the lap, how far it went, the lap time."""
    obs, _ = env.reset(seed=0)
    episode_return, progress_m, done = 0.0, 0.0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(model.predict(obs, deterministic=True)[0])
        episode_return, progress_m = episode_return + float(reward), progress_m + info["progress_m"]
        done = terminated or truncated
    lap = info["termination"] == "race-end"
    return {"lap_completed": lap, "episode_return": round(episode_return, 1), "progress_m": round(progress_m, 1),
            "termination": info["termination"] or "time-limit",
            "lap_time_s": round(info["state"].last_lap_time_s, 3) if lap else None}


class Curve(BaseCallback):
    """A CSV row per training episode and per deterministic rollout; stops training once a rollout laps."""

    COLUMNS = ["steps", "wall_s", "kind", "episode_return", "progress_m", "lap_completed", "termination"]

    def __init__(self, path: Path, eval_env: gymnasium.Env, eval_every: int):
        super().__init__()
        self.file = path.open("w", newline="")
        self.rows = csv.DictWriter(self.file, self.COLUMNS, extrasaction="ignore")
        self.rows.writeheader()
        self.eval_env, self.eval_every = eval_env, eval_every
        self.started, self.episode_return, self.progress_m = time.perf_counter(), 0.0, 0.0
        self.final: dict | None = None

    def write(self, kind: str, row: dict) -> None:
        row = {**row, "steps": self.num_timesteps, "wall_s": round(time.perf_counter() - self.started, 2),
               "kind": kind, "lap_completed": int(row["lap_completed"])}
        self.rows.writerow(row)
        self.file.flush()
        print(f"{row['steps']} steps, {row['wall_s']:.0f} s, {kind}: {row['progress_m']:.0f} m "
              f"({row['termination']})", flush=True)

    def _on_step(self) -> bool:
        info = self.locals["infos"][0]
        self.episode_return += float(self.locals["rewards"][0])
        self.progress_m += info["progress_m"]
        lapped = False
        if self.locals["dones"][0]:
            lapped = info["termination"] == "race-end"
            self.write("train", {"episode_return": round(self.episode_return, 1), "lap_completed": lapped,
                                 "progress_m": round(self.progress_m, 1),
                                 "termination": info["termination"] or "time-limit"})
            self.episode_return = self.progress_m = 0.0
        if lapped or self.num_timesteps % self.eval_every == 0:
            result = rollout(self.model, self.eval_env)
            self.write("eval", result)
            if result["lap_completed"]:
                self.final = result
                return False
        return True

    def _on_training_end(self) -> None:
        self.file.close()


def plot(csv_path: Path, png_path: Path, lap_m: float, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with csv_path.open() as f:
        rows = list(csv.DictReader(f))
    fig, ax = plt.subplots(figsize=(7, 3.6), dpi=110)
    for kind, style, label in (("train", ".", "training episode"), ("eval", "x", "deterministic rollout")):
        steps = [int(r["steps"]) for r in rows if r["kind"] == kind]
        ax.plot(steps, [float(r["progress_m"]) for r in rows if r["kind"] == kind], style, label=label)
    ax.axhline(lap_m, color="grey", ls="--", lw=1, label=f"a lap ({lap_m:.0f} m)")
    ax.set(xlabel=f"env steps (an action every {0.02 * ACTION_REPEAT:.2f} s of race)",
           ylabel="progress in the episode (m)", title=title)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the model, the curve and the summary")
    parser.add_argument("--steps", type=int, default=200_000, help="at most this many env steps")
    parser.add_argument("--eval-every", type=int, default=5_000, help="a deterministic rollout every N steps")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # one core for the learner; TORCS takes the other
    env, eval_env = make_env(), make_env()
    # gSDE: exploration noise that is a function of the observation, so a car explores a smooth line
    # through a corner rather than a new random steer every 0.1 s (which spun it; see docs/gym.md). Its
    # noise is drawn afresh at each training round: one round an episode, then as many updates as steps
    model = SAC("MlpPolicy", env, learning_starts=min(1_000, args.steps // 2), batch_size=128, use_sde=True,
                train_freq=(1, "episode"), gradient_steps=-1, policy_kwargs={"net_arch": [64, 64]},
                seed=args.seed, verbose=0)
    curve = Curve(args.out / "curve.csv", eval_env, args.eval_every)
    started = time.perf_counter()
    model.learn(total_timesteps=args.steps, callback=curve)
    wall_s = time.perf_counter() - started
    model.save(args.out / "model.zip")
    final = curve.final or rollout(model, eval_env)
    summary = {"steps": model.num_timesteps, "wall_s": round(wall_s, 1), **final}
    lap_m = float(eval_env.unwrapped.track.length_m)
    plot(args.out / "curve.csv", args.out / "curve.png", lap_m,
         f"SAC on g-track-1: {model.num_timesteps:,} steps, {wall_s / 60:.1f} min")
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    env.close()
    eval_env.close()
    print(f"lap completed: {final['lap_completed']} after {model.num_timesteps} steps ({wall_s:.0f} s); "
          f"deterministic rollout {final['progress_m']:.0f} m, lap time {final['lap_time_s']} s")


if __name__ == "__main__":
    main()
