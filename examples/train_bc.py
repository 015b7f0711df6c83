"""Behaviour cloning from a `boxbox dataset`, then DAgger with the robot as teacher (the rl extra for
PyTorch: ./boxbox install-rl).

The policy is an MLP (two hidden layers of --hidden, tanh out) on the env's whole observation,
flattened (gymnasium.spaces.flatten of the dataset's observation space), trained with plain PyTorch
to output the robot's own action for each observation (the dataset's infos["teacher_action"]; with
--noise the car was driven with a noisy action, so the data hold the robot's recoveries): mean
squared error (the steering column's weighed by --steer-weight), Adam.

With --dagger ROUNDS, each round then drives the current policy in the dataset's own env (its
env_spec: the same options, the action repeat among them, and the robot as the env's teacher), from
seeded starts along the lap, round the --tracks in turn: each state the policy reaches is labelled
with the robot's action for it (info["teacher_action"]), the pairs join the data and the policy
trains on them all again (--round-epochs). With --beta B, round r drives the robot's own action
instead of the policy's on a fraction B**r of its steps (drawn per step). Every labelled step counts,
the dataset's and DAgger's, and DAgger stops at --budget of them. DAgger's policies need not get
better round by round: with --select the one kept is the round's (before any DAgger pass: the dataset's alone)
whose rollouts from the grid of --tracks lapped most, then drove furthest.

With --look-ahead the policy also sees the track's curvature up to 400 m ahead of the car (ten
windows, learning.LookAhead): the envs it drives are wrapped in LookAhead, and the dataset's steps
get the same numbers from their distance along the lap and their episode's track.

Then one deterministic rollout from the grid (standing start, one lap) on each of --eval-tracks
reports how far the policy drove, how the episode ended and its lap time.

    boxbox dataset boxbox/robot-v0 --steps 30000 --noise 0.1       # the data (about a minute)
    .venv/bin/python examples/train_bc.py --dataset boxbox/robot-v0 --out bc-g-track-1
    .venv/bin/python examples/train_bc.py --dataset boxbox/robot-v0 --out bc-dagger --dagger 4
    .venv/bin/python examples/train_bc.py --drive bc-dagger/policy.pt --eval-tracks g-track-2

It writes into --out: policy.pt (torch.load: the state dict, the sizes, the env's options, the
tracks it trained on; --drive drives it again) and summary.json (the labelled steps, each round's
loss and episodes, each track's rollout, the wall time).
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from pathlib import Path

import gymnasium
import minari
import numpy as np
import torch
from torch import nn

import boxbox.gym  # noqa: F401  (registers boxbox/TORCS-v0)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from learning import DRIVE_STEP_S, LookAhead, look_ahead, rollout  # noqa: E402  (this folder's shared part)

BATCH = 512
EVAL_S = 300.0  # simulated seconds before an evaluation rollout is cut (the robot laps each public track in < 100 s)
FOCUS_FLOOR = 0.05  # --focus: a lapped track's share of a round's episodes, as if its rollout fell 5 % short
ROUND_EPISODE_S = 60.0  # a DAgger episode's simulated seconds at most: a round sees many starts, not one long lap


def policy_net(obs_size: int, act_size: int, hidden: int = 256) -> nn.Module:
    return nn.Sequential(nn.Linear(obs_size, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                         nn.Linear(hidden, act_size), nn.Tanh())


class Policy:
    """The net as a policy on the env's Dict observation (learning.rollout calls `predict`)."""

    def __init__(self, net: nn.Module, space: gymnasium.spaces.Dict) -> None:
        self.net, self.space = net, space
        self.looks_ahead = LookAhead.KEY in space.spaces  # it drives envs wrapped in LookAhead

    def flat(self, obs) -> np.ndarray:
        return gymnasium.spaces.flatten(self.space, obs).astype(np.float32)

    def __call__(self, obs) -> np.ndarray:
        with torch.no_grad():
            return self.net(torch.from_numpy(self.flat(obs)[None]))[0].numpy()

    def predict(self, obs, deterministic: bool = True) -> tuple[np.ndarray, None]:
        return self(obs), None


def make_env(kwargs: dict, ahead: bool, **options) -> gymnasium.Env:
    """The dataset's env (its options `kwargs`, some replaced by `options`), with --look-ahead wrapped
    in LookAhead (learning.py)."""
    max_steps = options.pop("max_episode_steps", None)
    env = gymnasium.make("boxbox/TORCS-v0", **{**kwargs, "car": kwargs["car"][0], "opponents": (), **options},
                         max_episode_steps=max_steps)
    return LookAhead(env) if ahead else env


def curvatures_of(kwargs: dict, tracks: list[str]) -> LookAhead:
    """A closed LookAhead env that has been reset once on each track: its `curvatures`, `lengths_m`
    and observation space."""
    env = make_env(kwargs, True, track=tracks, teacher=None, grid_position=None, random_start=False)
    try:
        for track in tracks:
            env.reset(seed=0, options={"track": track})
    finally:
        env.close()
    assert isinstance(env, LookAhead)
    return env


def episode_observations(episode, track: str, ahead: LookAhead | None) -> dict[str, np.ndarray]:
    """An episode's observations by field, with --look-ahead's from each step's distance along the
    lap (the scaled observation's, from -1 at the line to 1 a lap on) on the episode's track."""
    observations = dict(episode.observations)
    if ahead is not None:
        scaled = np.asarray(observations["dist_from_start_m"])[:, 0].astype(np.float64)
        dist_m = (scaled + 1.0) * 0.5 * ahead.lengths_m[track]
        observations[LookAhead.KEY] = look_ahead(ahead.curvatures[track], dist_m)
    return observations


def pairs(data: minari.MinariDataset, space: gymnasium.spaces.Dict,
          ahead: LookAhead | None) -> tuple[np.ndarray, np.ndarray]:
    """(flat observations, the robot's actions for them), every step of every episode: each field's
    columns side by side in `space`'s order, as gymnasium.spaces.flatten lays a Dict of Boxes."""
    fields = list(space.spaces)
    tracks = [about["options"]["track"] for about in data.storage.get_episode_metadata(data.episode_indices)]
    obs, act = [], []
    for episode, track in zip(data.iterate_episodes(), tracks, strict=True):
        steps = len(episode.infos["teacher_action"])
        observations = episode_observations(episode, track, ahead)
        obs.append(np.concatenate([observations[k].reshape(steps, -1) for k in fields], axis=1))
        act.append(episode.infos["teacher_action"])
    first = episode_observations(next(data.iterate_episodes()), tracks[0], ahead)
    assert np.allclose(obs[0][0], gymnasium.spaces.flatten(space, {k: v[0] for k, v in first.items()}))
    return np.concatenate(obs).astype(np.float32), np.concatenate(act).astype(np.float32)


def train(net: nn.Module, x: np.ndarray, y: np.ndarray, epochs: int,
          weights: torch.Tensor) -> tuple[float, list[float]]:
    """`epochs` passes of Adam over the pairs (batches of BATCH, each column's squared error
    weighed by `weights`): the last epoch's mean loss, and its mean squared error per column."""
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    xs, ys = torch.from_numpy(x), torch.from_numpy(y)
    total, columns = 0.0, torch.zeros(y.shape[1])
    for epoch in range(epochs):
        order = torch.randperm(len(xs))
        total, columns = 0.0, torch.zeros(y.shape[1])
        for start in range(0, len(xs), BATCH):
            batch = order[start:start + BATCH]
            errors = (net(xs[batch]) - ys[batch]) ** 2
            loss = (errors * weights).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(batch)
            columns += errors.detach().sum(0)
        print(f"epoch {epoch + 1}/{epochs}: loss {total / len(xs):.5f}", flush=True)
    return total / len(xs), [round(float(c) / len(xs), 6) for c in columns]


def labelled_episode(env: gymnasium.Env, policy: Policy, seed: int, track: str, teacher_share: float,
                     rng: np.random.Generator, max_steps: int) -> tuple[list, list, dict]:
    """One episode the policy drives (the robot's action instead on a `teacher_share` of its steps,
    drawn per step): every observation it reaches, flat, with the robot's action for it."""
    obs, info = env.reset(seed=seed, options={"track": track})
    xs, ys = [policy.flat(obs)], [info["teacher_action"]]
    progress_m, termination = 0.0, "cut"
    while len(xs) < max_steps:
        action = info["teacher_action"] if rng.random() < teacher_share else policy(obs)
        obs, _, terminated, truncated, info = env.step(action)
        xs.append(policy.flat(obs))
        ys.append(info["teacher_action"])
        progress_m += info["progress_m"]
        if terminated or truncated:
            termination = info["termination"] or "truncated"
            break
    return xs, ys, {"track": track, "seed": seed, "steps": len(xs), "progress_m": round(progress_m, 1),
                    "termination": termination}


def dagger_round(env: gymnasium.Env, policy: Policy, args: argparse.Namespace, r: int, steps: int,
                 rng: np.random.Generator, shares: dict[str, float]) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """Round `r`'s labelled pairs, `steps` of them, from seeded starts over the tracks, each episode's
    the one furthest below its share of the round's episodes (equal shares: the tracks in turn)."""
    xs: list = []
    ys: list = []
    episodes: list[dict] = []
    step_s = DRIVE_STEP_S * env.unwrapped.action_repeat  # type: ignore[attr-defined]
    while len(xs) < steps:
        i = len(episodes)
        driven = {t: sum(e["track"] == t for e in episodes) for t in args.tracks}
        track = max(args.tracks, key=lambda t: shares[t] / (1 + driven[t]))  # the first of the ties
        max_steps = min(steps - len(xs), int(ROUND_EPISODE_S / step_s))
        ex, ey, about = labelled_episode(env, policy, args.seed * 100_000 + r * 1_000 + i, track,
                                         args.beta ** r, rng, max_steps)
        xs += ex
        ys += ey
        episodes.append(about)
        print(f"  round {r} episode {i}: {track} seed {about['seed']}: {about['progress_m']:.0f} m in "
              f"{about['steps']} steps ({about['termination']})", flush=True)
    return np.array(xs, dtype=np.float32), np.array(ys, dtype=np.float32), episodes


def dagger(policy: Policy, x: np.ndarray, y: np.ndarray, kwargs: dict,
           args: argparse.Namespace) -> tuple[np.ndarray, np.ndarray, list[dict], int | None]:
    """--dagger rounds of labelling the policy's own states and training on all the pairs, until
    --budget labelled steps in all: the pairs, each round's record and the round selected.  With
    --select the policy left is the round's (before any DAgger pass: the dataset's alone) whose rollouts from the
    grid of --tracks lapped most, then drove furthest."""
    env = make_env(kwargs, policy.looks_ahead, track=args.tracks, teacher=kwargs.get("teacher") or "boxbox",
                   grid_position=None, random_start=True)
    rng = np.random.default_rng(args.seed)
    rounds: list[dict] = []
    shares = {track: 1.0 for track in args.tracks}
    best = None
    if args.select or args.focus:
        rows = evaluate(policy, kwargs, args.tracks)
        shares = focus_shares(rows) if args.focus else shares
        best = (selection_score(rows), 0, copy.deepcopy(policy.net.state_dict())) if args.select else None
    try:
        for r in range(1, args.dagger + 1):
            left = args.budget - len(x)
            steps = min(left // (args.dagger - r + 1), args.round_steps or left)
            if steps <= 0:
                break
            started = time.perf_counter()
            rx, ry, episodes = dagger_round(env, policy, args, r, steps, rng, shares)
            x, y = np.concatenate([x, rx]), np.concatenate([y, ry])
            loss, columns = train(policy.net, x, y, args.round_epochs, loss_weights(kwargs, args.steer_weight))
            rounds.append({"round": r, "teacher_share": args.beta ** r, "pairs": len(rx), "total_pairs": len(x),
                           "loss": round(loss, 6), "column_mse": columns,
                           "wall_s": round(time.perf_counter() - started, 1),
                           "mean_progress_m": round(float(np.mean([e["progress_m"] for e in episodes])), 1),
                           "episodes": episodes})
            print(f"round {r}: {len(rx)} pairs ({len(x)} in all), loss {loss:.5f} {columns}, episodes' mean "
                  f"progress {rounds[-1]['mean_progress_m']:.0f} m, {rounds[-1]['wall_s']:.0f} s", flush=True)
            if args.select or args.focus:
                rows = evaluate(policy, kwargs, args.tracks)
                rounds[-1]["selection_score"] = score = selection_score(rows)
                shares = focus_shares(rows) if args.focus else shares
            if best is not None:
                best = max(best, (score, r, copy.deepcopy(policy.net.state_dict())), key=lambda b: (b[0], b[1]))
    finally:
        env.close()
    if best is not None:
        policy.net.load_state_dict(best[2])
        print(f"selected: round {best[1]} ({best[0][0]} laps, {best[0][1]:.0f} m on {','.join(args.tracks)})")
    return x, y, rounds, best[1] if best is not None else None


def selection_score(rows: list[dict]) -> tuple[int, float]:
    """(laps completed, metres driven) in the rollouts from the grid of the training tracks."""
    return sum(row["lap_completed"] for row in rows), round(sum(row["progress_m"] for row in rows), 1)


def focus_shares(rows: list[dict]) -> dict[str, float]:
    """--focus: each track's share of the next round's episodes, the part of a lap its rollout from
    the grid fell short by (at least FOCUS_FLOOR, so that a lapped track keeps a few episodes)."""
    return {row["track"]: max(FOCUS_FLOOR, 0.0 if row["lap_completed"] else 1.0 - row["progress_m"] / row["lap_m"])
            for row in rows}


def loss_weights(kwargs: dict, steer_weight: float) -> torch.Tensor:
    """Each action column's weight in the loss: `steer_weight` for steering, 1 for the others."""
    columns = tuple(kwargs.get("actions", ("steer", "pedal")))
    return torch.tensor([steer_weight if c == "steer" else 1.0 for c in columns])


def evaluate(policy: Policy, kwargs: dict, tracks: list[str]) -> list[dict]:
    """A deterministic lap from the grid (standing start) on each track: progress, end, lap time."""
    rows = []
    for track in tracks:
        env = make_env(kwargs, policy.looks_ahead, track=track, teacher=None, grid_position=None, random_start=False,
                       laps=1, max_episode_steps=int(EVAL_S / (DRIVE_STEP_S * kwargs.get("action_repeat", 5))))
        try:
            result = rollout(policy, env)
        finally:
            env.close()
        rows.append({"track": track, **{k: result[k] for k in ("lap_completed", "lap_time_s", "progress_m",
                                                               "termination", "episode_steps")},
                     "lap_m": round(float(env.unwrapped.track.length_m), 1)})  # type: ignore[attr-defined]
        print(f"rollout on {track}: {result['progress_m']:.0f} m, {result['termination']}, "
              f"lap {result['lap_time_s']} s", flush=True)
    return rows


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="boxbox/robot-v0", help="a Minari dataset id (boxbox dataset wrote it)")
    parser.add_argument("--out", type=Path, help="folder for policy.pt and summary.json")
    parser.add_argument("--drive", type=Path, metavar="POLICY_PT",
                        help="only drive a saved policy.pt's laps on --eval-tracks (default: its training tracks)")
    parser.add_argument("--dataset-steps", type=int, default=0, help="use only the dataset's first N steps")
    parser.add_argument("--epochs", type=int, default=10, help="passes over the dataset before DAgger")
    parser.add_argument("--hidden", type=int, default=256, help="units in each of the two hidden layers")
    parser.add_argument("--steer-weight", type=float, default=1.0, help="the steering error's weight in the loss")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dagger", type=int, default=0, metavar="ROUNDS", help="DAgger rounds after the dataset")
    parser.add_argument("--budget", type=int, default=200_000, help="labelled steps in all, dataset and DAgger")
    parser.add_argument("--round-steps", type=int, default=0,
                        help="labelled steps per round (default: the budget left, shared by the rounds left)")
    parser.add_argument("--round-epochs", type=int, default=5, help="passes over all the pairs after each round")
    parser.add_argument("--beta", type=float, default=0.0, help="round r drives the robot's action on B**r of steps")
    parser.add_argument("--tracks", default=None, help="DAgger's tracks, comma-separated (default: the dataset's)")
    parser.add_argument("--select", action="store_true",
                        help="keep the round whose rollouts on --tracks lap most (then drive furthest)")
    parser.add_argument("--focus", action="store_true",
                        help="share each round's episodes among --tracks by how far short of a lap each one's "
                             "rollout from the grid fell")
    parser.add_argument("--eval-tracks", default=None, help="the rollouts' tracks (default: --tracks)")
    parser.add_argument("--look-ahead", action="store_true",
                        help="observe the track's curvature up to 400 m ahead too (learning.LookAhead)")
    args = parser.parse_args()
    for name in ("dataset_steps", "epochs", "hidden", "dagger", "budget", "round_steps", "round_epochs"):
        if getattr(args, name) < 0 or (name == "hidden" and args.hidden < 1):
            parser.error(f"--{name.replace('_', '-')} is {getattr(args, name)}; give a whole number of at least "
                         f"{1 if name == 'hidden' else 0}")
    if args.out is None and args.drive is None:
        parser.error("give --out (a folder for policy.pt and summary.json), or --drive a saved policy.pt")
    if not (0.0 <= args.beta <= 1.0) or not np.isfinite(args.steer_weight) or args.steer_weight <= 0:
        parser.error("--beta takes 0 to 1 and --steer-weight a number above 0")
    return args


def drive_saved(path: Path, tracks: list[str] | None) -> None:
    """A saved policy's deterministic lap from the grid of each track (default: those it trained on)."""
    saved = torch.load(path)
    net = policy_net(saved["obs_size"], saved["act_size"], saved["hidden"])
    net.load_state_dict(saved["state_dict"])
    env = make_env(saved["env"], saved.get("look_ahead", False), track=saved["trained_on"][0], teacher=None)
    space = env.observation_space  # the same for every track and car (docs/gym.md, Observations)
    env.close()
    assert isinstance(space, gymnasium.spaces.Dict)
    for row in evaluate(Policy(net, space), saved["env"], tracks or saved["trained_on"]):
        print(json.dumps({**row, "trained_on": row["track"] in saved["trained_on"]}), flush=True)


def main() -> None:
    args = parse_args()
    started = time.perf_counter()
    torch.manual_seed(args.seed)
    torch.set_num_threads(1)  # a small MLP: threads cost more than they give (and TORCS needs a core)
    if args.drive:
        drive_saved(args.drive, args.eval_tracks.split(",") if args.eval_tracks else None)
        return
    data = minari.load_dataset(args.dataset)
    kwargs = dict(data.spec.env_spec.kwargs)
    args.tracks = args.tracks.split(",") if args.tracks else list(kwargs["track"])
    eval_tracks = args.eval_tracks.split(",") if args.eval_tracks else args.tracks
    ahead = curvatures_of(kwargs, sorted(set(kwargs["track"]))) if args.look_ahead else None
    space = ahead.observation_space if ahead is not None else data.observation_space
    assert isinstance(space, gymnasium.spaces.Dict)
    x, y = pairs(data, space, ahead)
    if args.dataset_steps:
        x, y = x[:args.dataset_steps], y[:args.dataset_steps]  # its first episodes: they go round the tracks
    if len(x) > args.budget:
        print(f"train_bc.py: {args.dataset} holds {len(x)} labelled steps, more than --budget {args.budget}; "
              "record fewer (boxbox dataset --steps) or raise --budget", file=sys.stderr)
        sys.exit(2)
    print(f"{args.dataset}: {len(x)} observations of {x.shape[1]} numbers, actions of {y.shape[1]}", flush=True)
    policy = Policy(policy_net(x.shape[1], y.shape[1], args.hidden), space)
    loss, columns = train(policy.net, x, y, args.epochs, loss_weights(kwargs, args.steer_weight))
    dataset_pairs = len(x)
    x, y, rounds, selected = dagger(policy, x, y, kwargs, args) if args.dagger else (x, y, [], None)
    args.out.mkdir(parents=True, exist_ok=True)
    trained_on = sorted(set(kwargs["track"]) | (set(args.tracks) if rounds else set()))
    torch.save({"state_dict": policy.net.state_dict(), "obs_size": x.shape[1], "act_size": y.shape[1],
                "hidden": args.hidden, "env": kwargs, "trained_on": trained_on, "look_ahead": args.look_ahead},
               args.out / "policy.pt")
    trained_s = time.perf_counter() - started
    rows = [{**row, "trained_on": row["track"] in trained_on} for row in evaluate(policy, kwargs, eval_tracks)]
    summary = {"dataset": args.dataset, "dataset_pairs": dataset_pairs, "dagger_pairs": len(x) - dataset_pairs,
               "labelled_steps": len(x), "epochs": args.epochs, "hidden": args.hidden,
               "steer_weight": args.steer_weight, "beta": args.beta, "seed": args.seed, "look_ahead": args.look_ahead,
               "selected_round": selected, "loss": round(rounds[-1]["loss"] if rounds else loss, 6),
               "column_mse": rounds[-1]["column_mse"] if rounds else columns, "train_wall_s": round(trained_s, 1),
               "wall_s": round(time.perf_counter() - started, 1), "tracks_trained_on": trained_on,
               "laps_completed": sum(row["lap_completed"] for row in rows), "rollouts": rows, "rounds": rounds}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps({k: v for k, v in summary.items() if k != "rounds"}))


if __name__ == "__main__":
    main()
