"""Races as Ray tasks: `bench --cluster ADDRESS` and `bench-field --cluster ADDRESS` (docs/cluster.md).

The bench on the front plans, checks and recalls the cache as with `--jobs`; each race left to run
is one Ray task needing one CPU, on whichever node has one free.  The results come back to the
front, which stores the cache entries and draws the same progress bar (the laps reach it through
a queue actor that needs no CPU).  Only this module (and gym/vector_cluster.py, for bench-gym's
vector measurement) import Ray, and only `--cluster` imports it: one machine needs no Ray at all.

Before any race, each node runs one task that does the set-up `./boxbox race` does (TORCS, the
bridge, under the set-up lock) and answers what it lacks, if anything: the bench stops with one
line per such node before TORCS starts anywhere.  A Python robot from a file travels with the
tasks: its folder is the job's working_dir (Ray's runtime environment), so a node needs only
boxbox set up.  A node lost mid-bench (its raylet gone) is a system failure Ray retries elsewhere
(`NODE_LOST_RETRIES`); a race that fails for the robot's reasons is a result, never retried.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from rich.console import Console

from boxbox.bench.solo import BenchBar, RaceJob, RaceOutcomes, race_job, stopped_error
from boxbox.cache import cache_dir
from boxbox.errors import BoxboxError, UsageError
from boxbox.torcs.processes import claimed_core

# a race whose node (or worker) is lost runs again on another node this many times at most; a
# race is a minute or two, so three losses in a row mean the cluster, not chance, is the trouble
NODE_LOST_RETRIES = 3
# after Ctrl-C, how long the front waits for the cancelled races to stop TORCS and answer (a race
# stops within a second of being asked: torcs/signals.py)
CANCEL_WAIT_S = 30.0
# never uploaded with a robot's folder: the environments and caches a project folder tends to hold
WORKING_DIR_EXCLUDES = [".git", ".venv", "venv", "__pycache__", "*.pyc", ".mypy_cache", ".ruff_cache",
                        ".pytest_cache", "node_modules"]
# how often the front looks for results and laps: each look is calls to the queue actor, and at 5 a second
# the front and the actor took 11 s of CPU in a 12-race bench of 130 s on 2 cores
POLL_S = 1.0
HEAD_CONNECT_TIMEOUT_S = 5.0  # a head on the network answers a connection within a second
CACHE_MARK = "CACHE/"  # a travelling job's run dir under the cache: each node's own (~/.cache/boxbox)
INSTALL_HINT = "--cluster needs Ray, which boxbox installs only on request: run `./boxbox install-cluster`"


def require_ray() -> None:
    """A UsageError (exit 2, before anything races) when the cluster extra is not installed."""
    try:
        import ray  # noqa: F401
    except ImportError:
        raise UsageError(INSTALL_HINT) from None


def check_address(address: str) -> str:
    """'auto' (the cluster this machine joined) or HOST:PORT of a head, as RAY_ADDRESS takes them."""
    address = address.strip()
    host, _, port = address.rpartition(":")
    if address == "auto" or (host and "/" not in host and " " not in host and port.isdigit() and 0 < int(port) < 65536):
        return address
    raise UsageError(f"--cluster {address!r}: give 'auto' (the cluster this machine joined with `ray start`) or "
                     "the head's HOST:PORT, e.g. 10.0.0.5:6379")


# --- on the front ------------------------------------------------------------------------------

def race_on_cluster(todo: list[RaceJob], address: str, n_cached: int, console: Console) -> RaceOutcomes:
    """Each job raced as one Ray task on the cluster at `address`; the outcomes by job key, as
    `--jobs` gives them (solo._race_all)."""
    import ray

    sent, runtime_env = travelling_jobs(todo)
    with connected(address, runtime_env):
        return _race_all(ray, todo, sent, n_cached, console)


@contextlib.contextmanager
def connected(address: str, runtime_env: dict[str, Any] | None = None) -> Iterator[None]:
    """This process connected to the cluster at `address`, every node checked as set up (one line
    for each that is not); disconnected after, the cluster left running."""
    import ray

    _connect(ray, address, runtime_env or {})
    try:
        _set_up_nodes(ray)
        yield
    finally:
        ray.shutdown()  # this front's connection only: the cluster goes on


def travelling_jobs(todo: list[RaceJob]) -> tuple[list[RaceJob], dict[str, Any]]:
    """The jobs as a node runs them and the runtime environment they need: a robot from a file is
    named by its path in its folder, which goes to the nodes as the job's working_dir; a run dir
    in the cache (bench-field's) by its place there, as each node has its own cache."""
    todo = [dataclasses.replace(job, run_dir=_in_cache(job.run_dir)) for job in todo]
    folders = {Path(where).resolve().parent for job in todo for where in map(_robot_file, job.python_specs) if where}
    if not folders:
        return todo, {}
    # the folder that holds every robot file (one of theirs: never an ancestor nobody named, like ~)
    folder = Path(os.path.commonpath(folders))
    if folder not in folders:
        raise UsageError("on a cluster the robots' files travel as one folder (with its subfolders); put them in "
                         "one, got " + ", ".join(sorted(map(str, folders))))

    def on_node(spec: str) -> str:
        where = _robot_file(spec)
        return f"{Path(where).resolve().relative_to(folder)}:{spec.rpartition(':')[2]}" if where else spec

    sent = [dataclasses.replace(job, python_specs=[on_node(s) for s in job.python_specs]) for job in todo]
    return sent, {"working_dir": str(folder), "excludes": WORKING_DIR_EXCLUDES}


def _in_cache(run_dir: str) -> str:
    """A run dir under this machine's cache as CACHE/relative path (a node puts it in its own)."""
    if run_dir and Path(run_dir).is_relative_to(cache_dir()):
        return CACHE_MARK + str(Path(run_dir).relative_to(cache_dir()))
    return run_dir


def _robot_file(spec: str) -> str:
    """The file of a robot given as path/file.py:Class, else '' (boxbox's own, module:Class)."""
    where, colon, _ = spec.rpartition(":")
    return where if colon and (where.endswith(".py") or "/" in where) else ""


def _connect(ray, address: str, runtime_env: dict[str, Any]) -> None:
    _check_reachable(address)
    # RAY_ADDRESS, when set, overrides the address ray.init is given: --cluster is the one asked for
    os.environ["RAY_ADDRESS"] = address
    try:
        ray.init(address=address, runtime_env=runtime_env or None, logging_level=logging.ERROR, log_to_driver=False,
                 configure_logging=True)
    except (ConnectionError, RuntimeError, ValueError) as exc:
        said = str(exc).strip().splitlines()[0].rstrip(".") if str(exc).strip() else type(exc).__name__
        # no cluster there, or the robot's folder refused (too large for Ray's upload)
        token = "" if os.environ.get("RAY_AUTH_TOKEN") else \
            " (a cluster with token authentication needs RAY_AUTH_MODE=token and its RAY_AUTH_TOKEN here too)"
        raise UsageError(f"--cluster {address}: {said}{token}; see docs/cluster.md") from None


def _check_reachable(address: str) -> None:
    """One line at once when nothing listens at the head's address: ray.init would try for minutes."""
    import socket

    head = address
    if address == "auto":
        try:  # the address `ray start` on this machine recorded (Ray's own look-up; None: no cluster joined)
            from ray._private.services import canonicalize_bootstrap_address

            head = canonicalize_bootstrap_address("auto") or ""
        except Exception:
            return  # left to ray.init, which says it in its own words
        if not head:
            raise UsageError("--cluster auto: this machine has joined no Ray cluster (`ray start`, docs/cluster.md); "
                             "give the head's HOST:PORT")
    host, _, port = head.rpartition(":")
    try:
        socket.create_connection((host, int(port)), timeout=HEAD_CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise UsageError(f"--cluster {address}: no Ray head answers at {head} ({exc.strerror or exc}); start one "
                         "(docs/cluster.md) or check the address and the network") from None


def _set_up_nodes(ray) -> None:
    """One set-up task pinned to each live node with a CPU; one line per node that lacks something."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    from boxbox.bench.cache import package_version

    # no CPU asked: a node busy with others' tasks answers all the same (set-up is quick once done)
    setup_task = ray.remote(num_cpus=0, max_retries=0)(set_up_node)
    nodes = [n for n in ray.nodes() if n.get("Alive") and n.get("Resources", {}).get("CPU", 0) >= 1]
    if not nodes:
        raise UsageError("the Ray cluster has no node with a CPU to race on (`ray start --num-cpus N`)")
    sources = package_version()
    refs = [setup_task.options(scheduling_strategy=NodeAffinitySchedulingStrategy(n["NodeID"], soft=False))
            .remote(sources) for n in nodes]
    problems = []
    for node, ref in zip(nodes, refs, strict=True):
        where = f"node {node.get('NodeManagerAddress', '?')} (Ray node {node['NodeID'][:8]})"
        try:
            lack = ray.get(ref)
        except Exception as exc:  # the node went away while setting up: its races go elsewhere
            lack = None if _is_system_failure(ray, exc) else f"{type(exc).__name__}: {exc}"
        if lack:
            problems.append(f"{where}: {lack}")
    if problems:
        raise UsageError("; ".join(problems) + " (run `./boxbox setup` on it, or leave it out of the cluster)")


def _is_system_failure(ray, exc: Exception) -> bool:
    from ray import exceptions

    return isinstance(exc, exceptions.WorkerCrashedError | exceptions.NodeDiedError | exceptions.ObjectLostError
                      | exceptions.TaskUnschedulableError)


def _race_all(ray, todo: list[RaceJob], sent: list[RaceJob], n_cached: int, console: Console) -> RaceOutcomes:
    from ray.util.queue import Queue
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    # the races' lap messages, for the progress bar: on this front's own node, which lasts as long as the bench
    here = NodeAffinitySchedulingStrategy(ray.get_runtime_context().get_node_id(), soft=False)
    laps = Queue(actor_options={"num_cpus": 0, "scheduling_strategy": here})
    # spread over the nodes rather than packed onto the first: a race is one CPU's work, and a node
    # lost then takes the fewest races with it
    race_task = ray.remote(num_cpus=1, max_retries=NODE_LOST_RETRIES, retry_exceptions=False,
                           scheduling_strategy="SPREAD")(race_on_node)
    by_key = {job.key: job for job in todo}
    refs = {race_task.remote(job, laps): job.key for job in sent}
    outcomes: RaceOutcomes = {}
    cpus = int(ray.cluster_resources().get("CPU", 0))
    nodes = sum(1 for n in ray.nodes() if n.get("Alive"))
    with BenchBar(console, f"bench: {len(todo)} races on {cpus} CPUs of {nodes} Ray nodes", len(todo),
                  n_cached) as bar:
        pending = list(refs)
        # Ctrl-C raises here even where the caller started this with SIGINT ignored (a shell's background
        # job: a clean clone's `.ci/run` in the background ran a signalled bench to its end)
        previous = signal.signal(signal.SIGINT, signal.default_int_handler)
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1, timeout=POLL_S)
                bar.show_laps(_Drained(laps), by_key, outcomes)
                for ref in done:
                    bar.record(by_key[refs[ref]], _answer(ray, ref), outcomes, store_it=True)
        except KeyboardInterrupt:
            _cancel(ray, pending)
            raise stopped_error(outcomes) from None
        finally:
            signal.signal(signal.SIGINT, previous)
            with contextlib.suppress(Exception):
                ray.kill(laps.actor)
    return outcomes


def _answer(ray, ref) -> dict:
    """The task's answer; a race that could not run at all (its node lost more often than retried)
    is an error row like any other."""
    try:
        return ray.get(ref)
    except Exception as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        return {"result": None, "error": f"could not run on the cluster: {type(exc).__name__}: {first}"}


def _cancel(ray, pending: list) -> None:
    """Ctrl-C: this bench's races only, each asked to stop as a Ctrl-C would (TORCS stopped, nothing left
    on the node); the ones not started never start.  The cluster and others' tasks run on."""
    for ref in pending:
        ray.cancel(ref, force=False)
    ray.wait(pending, num_returns=len(pending), timeout=CANCEL_WAIT_S)


class _Drained:
    """The lap messages in the queue actor now, taken in one call, read like a local queue."""

    def __init__(self, laps) -> None:
        try:
            self.items = list(laps.get_nowait_batch(laps.qsize()))
        except Exception:  # the bar's laps are lost with the queue; the races and their results are not
            self.items = []

    def get_nowait(self):
        import queue

        if not self.items:
            raise queue.Empty
        return self.items.pop(0)


# --- on a node ---------------------------------------------------------------------------------

_node: dict = {}  # this worker process's overlay, once set up


def set_up_node(front_sources: str = "") -> str | None:
    """The set-up `./boxbox race` does, on this node: None when ready, else what it lacks in one
    line; with the front's `package_version`, also whether this node runs the same boxbox (other
    sources may race otherwise, and their results would be cached as the front's)."""
    from boxbox.bench.cache import package_version
    from boxbox.torcs import setup

    lacks = []
    if front_sources and (here := package_version()) != front_sources:
        lacks.append(f"its boxbox sources differ from this front's ({here} here, {front_sources} there): "
                     "check out the same commit on it")
    try:
        _node["overlay"] = setup.ensure_ready()
    except BoxboxError as exc:
        lacks.append(str(exc).splitlines()[0])
    except OSError as exc:
        lacks.append(f"set-up failed: {exc}")
    return "; ".join(lacks) or None


def race_on_node(job: RaceJob, laps) -> dict:
    """A Ray task: one race on this node, never raising for the race's own reasons."""
    if "overlay" not in _node:
        lack = set_up_node()
        if lack:
            return {"result": None, "error": f"{_this_node()} cannot race: {lack}"}
    # a robot's file arrived in the working_dir, which is this process's folder
    run_dir = str(cache_dir() / job.run_dir.removeprefix(CACHE_MARK)) if job.run_dir.startswith(CACHE_MARK) \
        else job.run_dir
    job = dataclasses.replace(job, python_specs=[_absolute(s) for s in job.python_specs], run_dir=run_dir)

    def send(message: tuple) -> None:
        # sent, not waited for: Queue.put_nowait waits on the actor (ray.get), and a task waiting in
        # ray.get lends its CPU back, so the node started a second race beside this one (4 races at
        # once on two 1-CPU nodes, each lap)
        with contextlib.suppress(Exception):  # a lap the bar misses is no reason to lose the race
            laps.actor.put_nowait.remote(message)

    # a core of this node's own, not the one this worker's process id picks: two workers of one node
    # met on one core by pid while the other stood idle
    with claimed_core() as core:
        result, error = race_job(job, _node["overlay"], core, send)
    if error:  # a robot named as the user gave it (job.entries: Python robots first), not by this node's copy
        for on_node, given in zip(job.python_specs, job.entries, strict=False):
            error = error.replace(f"'{on_node}'", f"'{given}'")
        if result is not None:
            result.error = error
    return {"result": result.to_json() if result else None, "error": error}


def _this_node() -> str:
    import ray

    return f"node {ray.util.get_node_ip_address()} (Ray node {ray.get_runtime_context().get_node_id()[:8]})"


def _absolute(spec: str) -> str:
    where = _robot_file(spec)
    return f"{os.path.abspath(where)}:{spec.rpartition(':')[2]}" if where else spec
