"""Train RLlib's PPO (its new API stack, PyTorch) on boxbox/TORCS-v0, with the env runners spread
over a Ray cluster's nodes (the rllib extra: ./boxbox install-rllib).

The env is the one `gymnasium.make("boxbox/TORCS-v0")` gives, with its defaults (the Dict observation
flattened by RLlib's FlattenObservations connector); with --parallel it is
`boxbox.gym.parallel_env(cars=--cars)`, PettingZoo's parallel API through RLlib's wrapper, every car
driven by one shared policy. Each env runner is a Ray actor needing one CPU, on whichever node has
one free; it imports boxbox there and races its own TORCS.

    .venv/bin/python examples/train_rllib.py --out /tmp/rllib --env-runners 1 --iterations 2
    .venv/bin/python examples/train_rllib.py --address 10.0.0.1:6379 --env-runners 8 --out ppo-cluster

It prints per iteration the env steps sampled, env steps a second, the mean episode return and the
nodes the env runners ran on, and writes into --out: checkpoint/ (Algorithm.from_checkpoint) and
summary.json (the iterations' figures).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import ray
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.connectors.env_to_module import FlattenObservations
from ray.tune.registry import register_env

ENV = "boxbox-torcs"
PARALLEL_ENV = "boxbox-torcs-parallel"
POLICY = "car"  # the one policy every car of the parallel env shares


def make_env(config: dict):
    """The single env, made in the env runner's process (importing boxbox.gym there registers it)."""
    import gymnasium

    import boxbox.gym  # noqa: F401

    return gymnasium.make("boxbox/TORCS-v0", **config)


def make_parallel_env(config: dict):
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    import boxbox.gym

    return ParallelPettingZooEnv(boxbox.gym.parallel_env(**config))


def ppo_config(args: argparse.Namespace) -> PPOConfig:
    multi = args.parallel
    env_config = {"cars": args.cars} if multi else {}
    config = (
        PPOConfig()
        .environment(PARALLEL_ENV if multi else ENV, env_config=env_config)
        .framework("torch")
        .env_runners(num_env_runners=args.env_runners, num_envs_per_env_runner=1, num_cpus_per_env_runner=1,
                     rollout_fragment_length="auto",
                     env_to_module_connector=lambda env, *_: FlattenObservations(multi_agent=multi))
        .training(train_batch_size_per_learner=args.train_batch, minibatch_size=min(128, args.train_batch),
                  num_epochs=args.epochs)
        .debugging(seed=args.seed)
    )
    if multi:
        config = config.multi_agent(policies={POLICY}, policy_mapping_fn=lambda agent_id, episode, **kw: POLICY)
    return config


def runner_nodes(algo) -> list[str]:
    """The addresses of the nodes the remote env runners run on, one per runner."""
    return algo.env_runner_group.foreach_env_runner(
        lambda runner: ray.util.get_node_ip_address() + "/" + ray.get_runtime_context().get_node_id()[:8],
        local_env_runner=False)


def iteration_row(result: dict, wall_s: float, nodes: list[str]) -> dict:
    runners = result.get("env_runners", {})
    sampled = int(runners.get("num_env_steps_sampled", 0))
    episode_return = runners.get("episode_return_mean", math.nan)
    # the time the runners sampled in parallel (the rest of the iteration is the PPO update, on the driver)
    sampling_s = float(result.get("timers", {}).get("env_runner_sampling_timer", 0.0))
    per_node = sampled / sampling_s / max(1, len(set(nodes))) if sampling_s > 0 else None
    return {"env_steps_sampled": sampled, "env_steps_lifetime": int(result.get("num_env_steps_sampled_lifetime", 0)),
            "env_steps_per_s": sampled / wall_s if wall_s > 0 else 0.0, "wall_s": wall_s, "sampling_s": sampling_s,
            "sampling_env_steps_per_s_per_node": per_node,
            "episode_return_mean": None if math.isnan(episode_return) else float(episode_return),
            "episodes": int(runners.get("num_episodes", 0)), "nodes": sorted(set(nodes))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the checkpoint and summary.json")
    parser.add_argument("--address", default="local",
                        help="a Ray cluster to join (host:port, or auto); default: a Ray started here for the run")
    parser.add_argument("--env-runners", type=int, default=2, help="env runner actors, one CPU each")
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--train-batch", type=int, default=4000, help="env steps per iteration (PPO's default)")
    parser.add_argument("--epochs", type=int, default=10, help="passes over each batch (PPO's default: 30)")
    parser.add_argument("--parallel", action="store_true", help="the PettingZoo parallel env, one shared policy")
    parser.add_argument("--cars", type=int, default=2, help="learning cars in the race with --parallel")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.env_runners < 1 or args.iterations < 1 or args.train_batch < 1:
        parser.error("--env-runners, --iterations and --train-batch must be at least 1")
    args.out = args.out.resolve()
    args.out.mkdir(parents=True, exist_ok=True)
    ray.init(address=None if args.address == "local" else args.address, log_to_driver=False)
    register_env(ENV, make_env)
    register_env(PARALLEL_ENV, make_parallel_env)
    algo = ppo_config(args).build_algo()
    rows = []
    try:
        nodes = runner_nodes(algo)
        for i in range(1, args.iterations + 1):
            started = time.perf_counter()
            result = algo.train()
            row = iteration_row(result, time.perf_counter() - started, nodes)
            rows.append(row)
            ret = "n/a" if row["episode_return_mean"] is None else f"{row['episode_return_mean']:.1f}"
            per_node = row["sampling_env_steps_per_s_per_node"]
            sampling = "" if per_node is None else f" ({per_node:.0f} a node while sampling)"
            print(f"iteration {i}: {row['env_steps_sampled']} env steps sampled, {row['env_steps_per_s']:.0f} env "
                  f"steps/s{sampling}, mean episode return {ret} ({row['episodes']} episodes), env runners on "
                  f"{len(row['nodes'])} node(s): {', '.join(row['nodes'])}", flush=True)
        checkpoint = algo.save_to_path(str(args.out / "checkpoint"))
    finally:
        algo.stop()
        ray.shutdown()
    summary = {"env": PARALLEL_ENV if args.parallel else ENV, "cars": args.cars if args.parallel else 1,
               "env_runners": args.env_runners, "train_batch": args.train_batch, "seed": args.seed,
               "checkpoint": checkpoint, "iterations": rows}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"checkpoint: {checkpoint}; summary: {args.out / 'summary.json'}")


if __name__ == "__main__":
    main()
