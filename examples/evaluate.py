"""Drive a saved policy (train_ppo.py's or train_sac.py's model.zip) for one deterministic lap from
the grid of each track given, tracks it never trained on included (the rl extra).

    .venv/bin/python examples/evaluate.py sac-g-track-1/model.zip --tracks g-track-1,e-track-2,aalborg
    .venv/bin/python examples/evaluate.py examples/checkpoints/sac-g-track-1-seed0.zip --tracks e-track-4

Prints a JSON line per track: lap completed, progress (m), the lap time (s), why the episode ended.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import gymnasium
from stable_baselines3 import PPO, SAC

import boxbox.gym  # noqa: F401  (registers boxbox/TORCS-v0)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from learning import rollout  # noqa: E402  (this folder's shared part)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("model", type=Path, help="a model.zip saved by train_ppo.py or train_sac.py")
    parser.add_argument("--tracks", default="g-track-1", help="comma-separated track names")
    args = parser.parse_args()
    # the summary the example wrote beside it (summary.json), or one named after the model (checkpoints/)
    summaries = [s for s in (args.model.with_suffix(".json"), args.model.with_name("summary.json")) if s.exists()]
    algorithm = json.loads(summaries[0].read_text()).get("algorithm", "SAC") if summaries else "SAC"
    model = {"PPO": PPO, "SAC": SAC}[algorithm].load(args.model)
    for track in args.tracks.split(","):
        env = gymnasium.make("boxbox/TORCS-v0", track=track, random_start=False)
        print(json.dumps({"track": track, "algorithm": algorithm, **rollout(model, env)}), flush=True)
        env.close()


if __name__ == "__main__":
    main()
