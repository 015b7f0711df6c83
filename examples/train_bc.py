"""Behaviour cloning from a `boxbox dataset` (the rl extra for PyTorch: ./boxbox install-rl).

The policy is an MLP (two hidden layers of 256, tanh out) on the env's whole observation, flattened
(gymnasium.spaces.flatten of the dataset's observation space), trained with plain PyTorch to
output the robot's own action for each observation (the dataset's infos["teacher_action"]; with
--noise the car was driven with a noisy action, so the data hold the robot's recoveries): mean
squared error, Adam. Then one deterministic rollout on the dataset's own env (its env_spec: the same
options, the action repeat among them), from the grid of --track, reports how far the policy drove
and its lap time.

    boxbox dataset boxbox/robot-v0 --steps 30000 --noise 0.1       # the data (about a minute)
    .venv/bin/python examples/train_bc.py --dataset boxbox/robot-v0 --out bc-g-track-1

It writes into --out: policy.pt (torch.load: the state dict, the sizes and the env's options) and
summary.json (the training loss, the rollout: progress, termination, lap time, steps, wall time).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium
import minari
import numpy as np
import torch
from torch import nn

import boxbox.gym  # noqa: F401  (registers boxbox/TORCS-v0)

BATCH = 512
ROLLOUT_S = 120.0  # simulated seconds before the rollout is cut (a lap of g-track-1 takes about 43)


def policy_net(obs_size: int, act_size: int, hidden: int = 256) -> nn.Module:
    return nn.Sequential(nn.Linear(obs_size, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                         nn.Linear(hidden, act_size), nn.Tanh())


def pairs(data: minari.MinariDataset) -> tuple[np.ndarray, np.ndarray]:
    """(flat observations, the robot's actions for them), every step of every episode: each field's
    columns side by side in the space's order, as gymnasium.spaces.flatten lays a Dict of Boxes."""
    fields = list(data.observation_space.spaces)
    obs, act = [], []
    for episode in data.iterate_episodes():
        steps = len(episode.infos["teacher_action"])
        obs.append(np.concatenate([episode.observations[k].reshape(steps, -1) for k in fields], axis=1))
        act.append(episode.infos["teacher_action"])
    return np.concatenate(obs).astype(np.float32), np.concatenate(act).astype(np.float32)


def train(x: np.ndarray, y: np.ndarray, epochs: int, seed: int) -> tuple[nn.Module, float]:
    torch.manual_seed(seed)
    torch.set_num_threads(1)  # a small MLP: threads cost more than they give (and TORCS needs a core)
    net = policy_net(x.shape[1], y.shape[1])
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    xs, ys = torch.from_numpy(x), torch.from_numpy(y)
    loss = torch.tensor(0.0)
    for epoch in range(epochs):
        order = torch.randperm(len(xs))
        total = 0.0
        for start in range(0, len(xs), BATCH):
            batch = order[start:start + BATCH]
            loss = nn.functional.mse_loss(net(xs[batch]), ys[batch])
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss) * len(batch)
        print(f"epoch {epoch + 1}/{epochs}: loss {total / len(xs):.5f}", flush=True)
    return net, total / len(xs)


def rollout(net: nn.Module, kwargs: dict, track: str) -> dict:
    """One deterministic episode from the grid: how far the policy drove, how it ended, its lap."""
    env = gymnasium.make("boxbox/TORCS-v0", **{**kwargs, "track": track, "car": kwargs["car"][0], "teacher": None,
                                              "grid_position": None, "opponents": ()})
    space = env.observation_space
    try:
        obs, info = env.reset(seed=0)
        progress, steps = 0.0, 0
        while True:
            with torch.no_grad():
                action = net(torch.from_numpy(gymnasium.spaces.flatten(space, obs)[None].astype(np.float32)))[0]
            obs, _, terminated, truncated, info = env.step(action.numpy())
            progress, steps = progress + info["progress_m"], steps + 1
            if terminated or truncated or info["state"].sim_time_s > ROLLOUT_S:
                break
        state = info["state"]
        lapped = info["termination"] == "race-end" and state.laps >= 2
        return {"track": track, "progress_m": round(progress, 1), "termination": info["termination"],
                "lap_completed": lapped, "lap_time_s": round(state.last_lap_time_s, 3) if lapped else None,
                "steps": steps}
    finally:
        env.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="boxbox/robot-v0", help="a Minari dataset id (boxbox dataset wrote it)")
    parser.add_argument("--out", type=Path, required=True, help="folder for policy.pt and summary.json")
    parser.add_argument("--epochs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--track", default="g-track-1", help="the rollout's track")
    args = parser.parse_args()
    started = time.perf_counter()
    data = minari.load_dataset(args.dataset)
    x, y = pairs(data)
    first = next(data.iterate_episodes()).observations  # laid out as the rollout's flatten lays it
    assert np.allclose(x[0], gymnasium.spaces.flatten(data.observation_space, {k: v[0] for k, v in first.items()}))
    print(f"{args.dataset}: {len(x)} observations of {x.shape[1]} numbers, actions of {y.shape[1]}", flush=True)
    net, loss = train(x, y, args.epochs, args.seed)
    kwargs = dict(data.spec.env_spec.kwargs)
    args.out.mkdir(parents=True, exist_ok=True)
    torch.save({"state_dict": net.state_dict(), "obs_size": x.shape[1], "act_size": y.shape[1], "env": kwargs},
               args.out / "policy.pt")
    trained_s = time.perf_counter() - started
    result = rollout(net, kwargs, args.track)
    summary = {"dataset": args.dataset, "pairs": len(x), "epochs": args.epochs, "loss": round(loss, 6),
               "train_wall_s": round(trained_s, 1), "rollout": result}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
