"""Learn to drive a lap of g-track-1 with Stable-Baselines3's PPO, its default hyperparameters, on
the env's defaults (the rl extra: ./boxbox install-rl).

The env is `gymnasium.make("boxbox/TORCS-v0")` as it comes: observations scaled to [-1, 1] in a Dict
(hence PPO's MultiInputPolicy), steering and one pedal, a decision every 0.1 s, a start drawn from
the seed along the lap. Four envs (SB3's make_vec_env, one process) gather the experience; every
--eval-every steps a deterministic rollout of the policy drives from the grid (random_start=False),
and training stops when one completes the lap, or after --steps.

    .venv/bin/python examples/train_ppo.py --out ppo-g-track-1 --seed 0     # until it laps
    .venv/bin/python examples/train_ppo.py --out /tmp/ppo --steps 256 --n-steps 32   # a smoke run (CI's)

It writes into --out: model.zip (PPO.load), curve.csv, curve.png and summary.json (steps, wall time,
the last rollout: lap completed, progress, lap time).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import gymnasium
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env

import boxbox.gym  # noqa: F401  (registers boxbox/TORCS-v0)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from learning import train  # noqa: E402  (this folder's shared part)

ENVS = 4


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the model, the curve and the summary")
    parser.add_argument("--steps", type=int, default=500_000, help="at most this many env steps (all envs)")
    parser.add_argument("--eval-every", type=int, default=10_000, help="a deterministic rollout every N steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--track", default="g-track-1")
    parser.add_argument("--n-steps", type=int, default=2048,
                        help="steps per env between updates (PPO's default; less only for a smoke run)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # one core for the learner; the races take the other
    env = make_vec_env("boxbox/TORCS-v0", n_envs=ENVS, seed=args.seed, env_kwargs={"track": args.track})
    eval_env = gymnasium.make("boxbox/TORCS-v0", track=args.track, random_start=False)
    batch_size = min(64, args.n_steps * ENVS)  # PPO's default batch, or the whole rollout when it is smaller
    model = PPO("MultiInputPolicy", env, n_steps=args.n_steps, batch_size=batch_size, seed=args.seed, verbose=0)
    about = {"algorithm": "PPO", "track": args.track, "seed": args.seed, "envs": ENVS}
    title = f"PPO (defaults) on {args.track}, seed {args.seed}"
    train(model, eval_env, args.out, args.steps, args.eval_every, about, title)
    env.close()
    eval_env.close()


if __name__ == "__main__":
    main()
