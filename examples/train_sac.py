"""Learn to drive a lap of g-track-1 with Stable-Baselines3's SAC on the env's defaults (the rl extra:
./boxbox install-rl).

The env is `gymnasium.make("boxbox/TORCS-v0")` as it comes: observations scaled to [-1, 1] in a Dict
(hence SAC's MultiInputPolicy, an MLP of 64x64 here), steering and one pedal, a decision every 0.1 s,
a start drawn from the seed along the lap. Exploration is gSDE's (noise that is a function of the
observation, drawn afresh each episode). Training stops when a deterministic rollout of the policy
from the grid completes the lap (tried after each training episode that completed it, and every
--eval-every steps), or after --steps.

    .venv/bin/python examples/train_sac.py --out sac-g-track-1 --seed 0   # until it laps (at most 50,000 steps)
    .venv/bin/python examples/train_sac.py --out /tmp/sac --steps 300     # a smoke run (what CI runs)

It writes into --out: model.zip (SAC.load), curve.csv (a row per training episode and per
deterministic rollout: steps, wall_s, kind, episode_return, progress_m, lap_completed, termination),
curve.png, and summary.json (the last rollout: lap completed, progress, lap time).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import gymnasium
import torch
from stable_baselines3 import SAC

import boxbox.gym  # noqa: F401  (registers boxbox/TORCS-v0)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from learning import rollout, train  # noqa: E402,F401  (this folder's shared part; rollout for callers)

TRACK = "g-track-1"


def make_env(random_start: bool = False) -> gymnasium.Env:
    """The env with its defaults; from the grid unless `random_start` (the deterministic rollouts' form)."""
    return gymnasium.make("boxbox/TORCS-v0", track=TRACK, random_start=random_start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the model, the curve and the summary")
    parser.add_argument("--steps", type=int, default=50_000, help="at most this many env steps")
    parser.add_argument("--eval-every", type=int, default=5_000, help="a deterministic rollout every N steps")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # one core for the learner; TORCS takes the other
    env, eval_env = make_env(random_start=True), make_env()
    # gSDE: exploration noise that is a function of the observation, so a car explores a smooth line
    # through a corner rather than a new random steer every 0.1 s (which spun it; see docs/gym.md). Its
    # noise is drawn afresh at each training round: one round an episode, then as many updates as steps
    model = SAC("MultiInputPolicy", env, learning_starts=min(1_000, args.steps // 2), batch_size=128, use_sde=True,
                train_freq=(1, "episode"), gradient_steps=-1, policy_kwargs={"net_arch": [64, 64]},
                seed=args.seed, verbose=0)
    about = {"algorithm": "SAC", "track": TRACK, "seed": args.seed}
    train(model, eval_env, args.out, args.steps, args.eval_every, about, f"SAC on {TRACK}, seed {args.seed}")
    env.close()
    eval_env.close()


if __name__ == "__main__":
    main()
