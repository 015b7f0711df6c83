"""`bench-gym --cluster`: the vector measurement with its envs spread over a Ray cluster's nodes.

Each env is a Ray actor needing one CPU (as RLlib's env runners are), placed with Ray's SPREAD
strategy, on a core of its node that no race or other env holds (`claimed_core`: by process id
two of a node's envs met on one core).  All are made and reset first; then each steps its own env
`steps` times with random actions at once, as an env runner samples, and the figure is the sum of
their env steps a second, resets included: what AsyncVectorEnv's row measures on one machine.
The front connects to the cluster and checks its nodes (bench/cluster.py, through the command);
this module only needs `ray` initialised.
"""

from __future__ import annotations

import contextlib

import numpy as np

from boxbox.errors import UsageError
from boxbox.gym.bench_gym import _actions, make_env, stepped
from boxbox.torcs.processes import claimed_core


class EnvOnNode:
    """One env on a node: made and reset when the actor starts, stepped by `run`."""

    def __init__(self, track: str, episode_steps: int, steps: int, seed: int) -> None:
        self.held = contextlib.ExitStack()  # the core, until `run` ends
        cpu = self.held.enter_context(claimed_core())
        self.env = make_env(track, episode_steps, cpu=cpu)
        self.actions = _actions(self.env.action_space, min(steps, 10_000), np.random.default_rng(seed))
        self.env.reset(seed=seed)

    def node(self) -> str:
        import ray

        return ray.get_runtime_context().get_node_id()

    def run(self, steps: int) -> float:
        """Env steps a second over `steps` steps, resets included; then the env closed."""
        try:
            wall_s, _ = stepped(self.env, self.actions, steps)
        finally:
            self.env.close()
            self.held.close()
        return steps / wall_s


def vector_on_cluster(track: str, n_envs: int, steps: int, episode_steps: int, seed: int = 0) -> tuple[float, int]:
    """(env steps a second of all `n_envs` envs together, the nodes they ran on)."""
    import ray

    check_cpus(n_envs)
    actor = ray.remote(num_cpus=1, max_restarts=0)(EnvOnNode)
    envs = [actor.options(scheduling_strategy="SPREAD").remote(track, episode_steps, steps, seed + i)
            for i in range(n_envs)]
    try:
        nodes = set(ray.get([env.node.remote() for env in envs]))  # every env made and reset
        rates = ray.get([env.run.remote(steps) for env in envs])
    finally:
        for env in envs:
            ray.kill(env)
    return float(sum(rates)), len(nodes)



def check_cpus(n_envs: int) -> None:
    """A UsageError unless the cluster has a CPU for each env (the rest would wait for one, and the
    envs would not step at once)."""
    import ray

    cpus = int(ray.cluster_resources().get("CPU", 0))
    if n_envs > cpus:
        raise UsageError(f"--envs {n_envs} on the cluster needs {n_envs} CPUs, and it has {cpus}: "
                         f"give --envs {cpus} or fewer")
