"""`bench --cluster`, `bench-field --cluster` and RLlib's PPO on a real Ray cluster of two nodes on this machine.

The nodes are started with --node-ip-address 127.0.0.1, yet Ray names each by the machine's
reachable address and listens on every interface: so the cluster takes only clients holding its
random token (Ray's token authentication, RAY_AUTH_MODE=token).  It lives in a temporary folder,
and every process of it is found by a mark in its environment (Ray's daemons and workers and the
races they start inherit it): the tests stop exactly those, never `ray stop`, which would end a
user's own cluster too.
Skipped only when Ray is not installed (`./boxbox install-cluster`; `./boxbox test` installs it), the RLlib
test when RLlib's extra is not (`./boxbox install-rllib`; `./boxbox test` installs it too).
"""

from __future__ import annotations

import importlib.util
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from pathlib import Path

import pytest

from helpers import ROOT, processes_mentioning, read_json, run_boxbox

pytest.importorskip("ray", reason="the cluster extra (Ray) is not installed: ./boxbox install-cluster")
pytestmark = pytest.mark.torcs

RAY = Path(sys.executable).parent / "ray"
TRACKS = "g-track-1,michigan,e-speedway"  # short: three 1-lap solo races, about 10 s each
START_TIMEOUT_S = 120.0
WORKER_PORTS = 40  # a node's worker processes' ports after its first: a few workers a test


def _free_ports(n: int) -> list[int]:
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def _node_ports() -> list[int]:
    """Six free ports and the first of 41 for the node's workers, none inside that range (Ray refuses
    a node whose ports overlap: "is trying to use a port number ... used by other components")."""
    while True:
        ports = _free_ports(7)
        if not any(ports[-1] <= port <= ports[-1] + WORKER_PORTS for port in ports[:-1]):
            return ports


class LocalCluster:
    """A Ray head and its nodes on 127.0.0.1, each node's processes known by its own token."""

    def __init__(self) -> None:
        # short: Ray's socket paths live under it, and a socket path has at most 107 bytes
        self.temp_dir = tempfile.mkdtemp(prefix="bxr", dir="/tmp")
        self.port = _free_ports(1)[0]
        self.address = f"127.0.0.1:{self.port}"
        self.tokens: list[str] = []  # the nodes running
        self.every_token: list[str] = []
        # what a client needs to use the cluster (and a node to join it)
        self.auth = {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(32)}

    def start_nodes(self, count: int = 1, head: bool = False, env: dict | None = None) -> list[str]:
        """`count` nodes started, their marks; one after the other (two nodes of one machine started
        at once each time out waiting for its own node info)."""
        tokens = []
        for _ in range(count):
            token, proc = self._start(head, env)
            out, _ = proc.communicate(timeout=START_TIMEOUT_S)
            assert proc.returncode == 0, out
            tokens.append(token)
        return tokens

    def _start(self, head: bool, env: dict | None) -> tuple[str, subprocess.Popen]:
        token = f"boxbox-test-ray-{uuid.uuid4().hex[:12]}"
        agent, grpc, runtime, metrics, manager, objects, worker = _node_ports()
        args = [str(RAY), "start", "--node-ip-address", "127.0.0.1", "--num-cpus", "1", "--disable-usage-stats",
                "--object-store-memory", str(80 * 1024 * 1024), "--dashboard-agent-listen-port", str(agent),
                "--dashboard-agent-grpc-port", str(grpc), "--runtime-env-agent-port", str(runtime),
                "--metrics-export-port", str(metrics), "--node-manager-port", str(manager),
                "--object-manager-port", str(objects), "--min-worker-port", str(worker),
                "--max-worker-port", str(worker + WORKER_PORTS)]
        if head:
            args += ["--head", "--port", str(self.port), "--temp-dir", self.temp_dir, "--include-dashboard=false"]
        else:
            args += ["--address", self.address]
        # a lost node is found in about 3 s (Ray's default: 30 s), so the fault test stays short
        node_env = dict(os.environ, BOXBOX_TEST_RAY=token, RAY_health_check_period_ms="1000",
                        RAY_health_check_failure_threshold="3", RAY_health_check_initial_delay_ms="1000",
                        **self.auth, **(env or {}))
        node_env.pop("RAY_ADDRESS", None)
        self.tokens.append(token)
        self.every_token.append(token)
        return token, subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                       env=node_env)

    def pids(self, token: str, name: str = "") -> list[int]:
        return [int(line.split(":")[0]) for line in processes_mentioning(f"BOXBOX_TEST_RAY={token}")
                if name in line.split(":", 1)[1]]

    def stop_node(self, token: str, sig: int = signal.SIGTERM) -> None:
        self.stop_nodes([token], sig)

    def stop_nodes(self, tokens: list[str], sig: int = signal.SIGTERM) -> None:
        """The nodes' processes asked to stop at once (a raylet then leaves the cluster), then killed."""
        def alive() -> list[int]:
            return [pid for token in tokens for pid in self.pids(token)]

        for s in (sig, signal.SIGKILL):
            for pid in alive():
                try:
                    os.kill(pid, s)
                except ProcessLookupError:
                    pass
            # a raylet asked to stop leaves the cluster within a second; Ray's agents and idle workers
            # may not end by themselves for seconds, and are killed then
            deadline = time.monotonic() + (2 if s == sig else 5)
            while alive() and time.monotonic() < deadline:
                time.sleep(0.2)
        for token in tokens:
            self.tokens.remove(token)

    def stop(self) -> None:
        self.stop_nodes(list(self.tokens))
        shutil.rmtree(self.temp_dir, ignore_errors=True)


class RacesAtOnce:
    """The most TORCS processes seen at once on any node of the cluster while the block runs."""

    def __init__(self, cluster: LocalCluster) -> None:
        self.cluster, self.per_node = cluster, 0
        self.done = threading.Event()
        self.watcher = threading.Thread(target=self._watch, daemon=True)

    def _watch(self) -> None:
        while not self.done.is_set():
            for token in list(self.cluster.tokens):
                self.per_node = max(self.per_node, len(self.cluster.pids(token, "torcs-bin")))
            time.sleep(0.05)

    def __enter__(self) -> RacesAtOnce:
        self.watcher.start()
        return self

    def __exit__(self, *exc) -> None:
        self.done.set()
        self.watcher.join()


@pytest.fixture(scope="module")
def cluster(overlay):
    """The head and a second node, one CPU each (the fault test adds the third it loses: each bench on
    the cluster starts Ray workers that import boxbox on every node, about 2 s of CPU each)."""
    c = LocalCluster()
    try:
        c.start_nodes(head=True)
        c.start_nodes(1)
        yield c
    finally:
        c.stop()
    for token in c.every_token:
        assert not processes_mentioning(token)


def _rows(path: Path) -> list[tuple]:
    return [(r["track"], r["robot"], r["laps"], r["time"], r["best_lap"], r["damage"], r["error"])
            for r in read_json(path)["rows"]]


def test_a_bench_on_the_nodes_gives_the_figures_of_jobs_2_robot_file_and_settings_and_all(cluster, tmp_path):
    """The robot's file and the module beside it travel as the job's working_dir, --set with each race:
    the nodes race what --jobs 2 races here, to the millisecond."""
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "naming.py").write_text('NAME = "traveller"\n')
    (folder / "robot.py").write_text("from naming import NAME\n\nfrom boxbox.robot.tutorial import TutorialRobot\n\n\n"
                                     "class Traveller(TutorialRobot):\n    name = NAME\n")
    common = ["bench", "--robots", f"{folder}/robot.py:Traveller", "--tracks", TRACKS, "--laps", "1", "--no-limit",
              "--set", "mu_scale=0.9", "--step-budget-ms", "5000"]
    local = run_boxbox(*common, "--no-cache", "--jobs", "2", "--json", str(tmp_path / "local.json"), timeout=300)
    assert local.returncode == 0, local.stderr
    with RacesAtOnce(cluster) as most:
        spread = run_boxbox(*common, "--no-cache", "--cluster", cluster.address, "--json",
                            str(tmp_path / "cluster.json"), timeout=300, env=cluster.auth)
    assert spread.returncode == 0, spread.stderr
    # a node of one CPU races one race at a time (a task that waited on the lap queue lent its CPU out,
    # and its node started a second race beside it: seen in a 76-race bench-field, 4 races at once on
    # two 1-CPU nodes; these 1-lap races send their one lap as they end, so here it is a check, not a repro)
    assert most.per_node == 1, most.per_node
    assert _rows(tmp_path / "cluster.json") == _rows(tmp_path / "local.json")
    assert all(r[2] == 1 and r[3] > 0 and r[6] is None for r in _rows(tmp_path / "cluster.json"))
    doc = read_json(tmp_path / "cluster.json")
    assert doc["settings"] == {"mu_scale": 0.9} and all(r["name"].startswith("traveller") for r in doc["rows"])
    assert "3 raced, 0 cached" in spread.stderr
    # the front stored the cache entries: the same bench again (here, without connecting) races nothing
    again = run_boxbox(*common, timeout=300)
    assert again.returncode == 0 and "0 raced, 3 cached" in again.stderr, again.stderr


def test_a_bench_field_on_the_cluster_has_the_shape_of_one_here(cluster, tmp_path):
    proc = run_boxbox("bench-field", "--tracks", "g-track-1", "--laps", "1", "--no-cache", "--step-budget-ms", "5000",
                      "--cluster", cluster.address, "--json", str(tmp_path / "f.json"), timeout=300, env=cluster.auth)
    assert proc.returncode == 0, proc.stderr
    doc = read_json(tmp_path / "f.json")
    assert set(doc) >= {"tracks", "robot", "anchor", "field", "laps", "rows", "summary"}
    assert [(r["track"], r["role"]) for r in doc["rows"]] == [("g-track-1", "robot"), ("g-track-1", "anchor")]
    assert all(r["error"] is None and 1 <= r["rank"] <= 10 and r["laps"] == 1 for r in doc["rows"]), doc["rows"]
    assert "2 raced, 0 cached" in proc.stderr


def test_a_sweep_on_the_cluster(cluster, tmp_path):
    proc = run_boxbox("sweep", "--tracks", "g-track-1", "--cars", "car1-trb1", "--laps", "1", "--no-cache",
                      "--step-budget-ms", "5000", "--cluster", cluster.address, "--json", str(tmp_path / "s.json"),
                      timeout=300, env=cluster.auth)
    assert proc.returncode == 0, proc.stderr
    rows = read_json(tmp_path / "s.json")["rows"]
    assert [(r["part"], r["finished"]) for r in rows] == [("every track", True), ("every car", True)], rows
    assert "1 raced, 0 cached" in proc.stderr


def test_a_robots_fault_is_its_rows_error_as_here_and_not_raced_again(cluster, tmp_path):
    common = ["bench", "--robots", "tests/robots/faulty.py:RaisesInOnTrack", "--tracks", "g-track-1", "--laps", "1",
              "--no-limit", "--no-cache"]
    here = run_boxbox(*common, "--jobs", "1", "--json", str(tmp_path / "here.json"), timeout=300)
    there = run_boxbox(*common, "--cluster", cluster.address, "--json", str(tmp_path / "there.json"), timeout=300,
                       env=cluster.auth)
    assert here.returncode == there.returncode == 0, there.stderr
    (local,), (remote,) = read_json(tmp_path / "here.json")["rows"], read_json(tmp_path / "there.json")["rows"]
    assert remote["error"].split(";")[0] == local["error"].split(";")[0], remote["error"]
    assert local["error"].startswith("robot 'tests/robots/faulty.py:RaisesInOnTrack' (middle 1) failed: RuntimeError")
    assert there.stderr.count("race failed") == 1


def test_rllib_ppo_trains_with_env_runners_on_two_nodes(cluster, tmp_path):
    """examples/train_rllib.py joins the cluster: two env runners (one CPU each, one CPU a node) race
    on two nodes, an iteration of 200 env steps trains, and the checkpoint is written."""
    lacking = [m for m in ("torch", "tree", "pandas") if importlib.util.find_spec(m) is None]
    if lacking:
        pytest.skip(f"the rllib extra is not installed ({', '.join(lacking)} missing): ./boxbox install-rllib")
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / "train_rllib.py"), "--address", cluster.address,
                           "--env-runners", "2", "--iterations", "1", "--train-batch", "200", "--epochs", "1",
                           "--out", str(tmp_path)], capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, **cluster.auth))
    assert proc.returncode == 0, proc.stderr[-3000:]
    (row,) = read_json(tmp_path / "summary.json")["iterations"]
    assert row["env_steps_sampled"] >= 200 and row["env_steps_per_s"] > 0, row
    assert len(row["nodes"]) == 2, row  # the cluster's two nodes of one CPU each
    assert (tmp_path / "checkpoint" / "rllib_checkpoint.json").is_file()  # Algorithm.from_checkpoint's folder
    assert "iteration 1: " in proc.stdout and "env runners on 2 node(s)" in proc.stdout, proc.stdout


def test_a_node_lost_mid_bench_leaves_every_race_once(cluster, tmp_path):
    (lost,) = cluster.start_nodes()
    try:
        bench = subprocess.Popen([sys.executable, "-m", "boxbox.cli", "bench", "--robots", "boxbox", "--tracks", TRACKS,
                                  "--laps", "1", "--no-limit", "--no-cache", "--step-budget-ms", "5000",
                                  "--cluster", cluster.address, "--json", str(tmp_path / "b.json")],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                 env=dict(os.environ, COLUMNS="200", **cluster.auth))
        deadline = time.monotonic() + 120
        while not cluster.pids(lost, "torcs") and time.monotonic() < deadline and bench.poll() is None:
            time.sleep(0.1)
        if not cluster.pids(lost, "torcs"):
            bench.kill()
            pytest.fail(f"no race ran on the third node: {bench.communicate()[1]}")
        for pid in cluster.pids(lost, "raylet"):
            os.kill(pid, signal.SIGKILL)
        _, stderr = bench.communicate(timeout=300)
    finally:
        cluster.stop_node(lost, signal.SIGKILL)
    assert bench.returncode == 0, stderr
    rows = read_json(tmp_path / "b.json")["rows"]
    assert sorted(r["track"] for r in rows) == sorted(TRACKS.split(","))
    assert all(r["error"] is None and r["laps"] == 1 for r in rows), rows
    assert "3 raced" in stderr


def test_ctrl_c_stops_this_benchs_races_and_leaves_the_cluster_running(cluster, tmp_path):
    bench = subprocess.Popen([sys.executable, "-m", "boxbox.cli", "bench", "--robots", "boxbox", "--tracks",
                              "g-track-1,michigan", "--laps", "200", "--no-limit", "--no-cache", "--cluster",
                              cluster.address], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=dict(os.environ, COLUMNS="200", **cluster.auth))
    # a race running on a node, or 15 s (connecting and checking the nodes takes 2-4 s): 200 laps race on for
    # a minute or more, where 3 laps of both ended in 8.6 s and 20 laps in 7.7 s on an idle machine
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline and bench.poll() is None and \
            not [pid for token in cluster.tokens for pid in cluster.pids(token, "torcs")]:
        time.sleep(0.1)
    bench.send_signal(signal.SIGINT)
    _, stderr = bench.communicate(timeout=120)
    assert bench.returncode == 130 and "the bench was stopped" in stderr, stderr
    assert not [pid for token in cluster.tokens for pid in cluster.pids(token, "torcs")]
    assert all(cluster.pids(token, "raylet") for token in cluster.tokens)  # the cluster runs on


def test_a_node_without_torcs_and_other_sources_says_so_in_one_line(cluster, tmp_path):
    """The node's Ray workers import a copy of boxbox with one line more, and find no TORCS binary."""
    copy = tmp_path / "src" / "boxbox"
    shutil.copytree(ROOT / "src" / "boxbox", copy, ignore=shutil.ignore_patterns("__pycache__"))
    with open(copy / "errors.py", "a") as f:
        f.write("# changed\n")
    (bare,) = cluster.start_nodes(env={"BOXBOX_TORCS_LIB": str(tmp_path / "no-torcs"),
                                       "PYTHONPATH": str(tmp_path / "src")})
    try:
        proc = run_boxbox("bench", "--robots", "boxbox", "--tracks", "g-track-1", "--laps", "1", "--no-limit",
                          "--no-cache", "--cluster", cluster.address, timeout=300, env=cluster.auth)
    finally:
        cluster.stop_node(bare)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert "(Ray node " in lines[0] and "TORCS binary not found" in lines[0] and "./boxbox setup" in lines[0], lines
    assert "its boxbox sources differ from this front's" in lines[0], lines


def test_bench_gym_steps_its_vector_envs_on_the_nodes(cluster, tmp_path):
    proc = run_boxbox("bench-gym", "--steps", "1000", "--episode-steps", "100", "--envs", "2", "--vector-steps", "300",
                      "--episodes", "10", "--policy-steps", "0", "--multi-steps", "0", "--cluster", cluster.address,
                      "--json", str(tmp_path / "g.json"), timeout=300, env=cluster.auth)
    assert proc.returncode == 0, proc.stderr
    rows = read_json(tmp_path / "g.json")
    (row,) = [r for r in rows if "Ray actors" in r["measure"]]
    assert not [r for r in rows if "random policy" in r["measure"]]  # --policy-steps 0: not measured, no row
    assert row["measure"].startswith("env steps/s, 2 envs as Ray actors on 2 nodes"), row
    assert float(row["value"].replace(",", "")) > 0
    too_many = run_boxbox("bench-gym", "--envs", "3", "--cluster", cluster.address, timeout=120, env=cluster.auth)
    assert too_many.returncode == 2 and "--envs 3 on the cluster needs 3 CPUs, and it has 2" in too_many.stderr
    assert len(too_many.stderr.strip().splitlines()) == 1, too_many.stderr
