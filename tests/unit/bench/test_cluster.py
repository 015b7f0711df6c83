"""`--cluster` without a cluster: Ray is loaded only when asked for, its absence is one line, and the
jobs a node runs name a robot's file by its place in the folder that travels with them.  (The
races on a real two-node cluster: tests/integration/test_cluster.py.)"""

from __future__ import annotations

import socket
import subprocess
import sys
import time

import pytest

from boxbox.bench.cluster import _check_reachable, check_address, travelling_jobs
from boxbox.bench.solo import BenchSpec, plan
from boxbox.errors import UsageError


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def test_the_benches_load_no_ray_unless_asked():
    done = _run("import sys, boxbox, boxbox.bench.solo, boxbox.bench.field, boxbox.cli.benches\n"
                "print('ray' in sys.modules)")
    assert done.stdout.split() == ["False"], done.stderr


@pytest.mark.parametrize("command", ["bench", "bench-field", "sweep"])
def test_without_ray_cluster_is_one_line_saying_how_to_install_it(command):
    # a None in sys.modules makes `import ray` fail as it does where the package is not installed
    done = _run("import sys; sys.modules['ray'] = None; from boxbox.cli import main; "
                f"sys.argv = ['boxbox', '{command}', '--tracks', 'g-track-1', '--cluster', 'auto']; main()")
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert "./boxbox install-cluster" in line, line


@pytest.mark.parametrize("address", ["auto", "10.0.0.5:6379", "head.example:6380", " auto "])
def test_cluster_addresses_as_ray_takes_them(address):
    assert check_address(address) == address.strip()


@pytest.mark.parametrize("address", ["", "head", "head:", "head:port", "head:0", "head:70000", "ray://head:10001"])
def test_other_addresses_are_refused_in_one_line(address):
    with pytest.raises(UsageError, match="HOST:PORT"):
        check_address(address)


def _jobs(*robots: str):
    spec = BenchSpec(tracks=["g-track-1"], cars=["car1-trb1"], robots=list(robots), laps=1, limit=False)
    return list({job.key: job for *_, job in plan(spec)[0]}.values())


def _robot_file(folder, name: str):
    path = folder / f"{name}.py"
    path.write_text(f"from boxbox.robot.tutorial import TutorialRobot\n\n\nclass R(TutorialRobot):\n"
                    f"    name = '{name}'\n")
    return path


def test_a_robots_folder_travels_and_the_nodes_find_its_file_in_it(tmp_path):
    (tmp_path / "sub").mkdir()
    a, b = _robot_file(tmp_path, "a"), _robot_file(tmp_path / "sub", "b")
    todo = _jobs(f"{a}:R", f"{b}:R", "boxbox")
    sent, env = travelling_jobs(todo)
    assert env["working_dir"] == str(tmp_path) and ".venv" in env["excludes"]
    assert [job.python_specs for job in sent] == [["a.py:R"], ["sub/b.py:R"], ["boxbox"]]
    assert [job.key for job in sent] == [job.key for job in todo]  # the front's cache keys and rows stay
    assert todo[0].python_specs == [f"{a}:R"]


def test_robots_own_to_boxbox_need_no_runtime_environment():
    sent, env = travelling_jobs(_jobs("boxbox", "middle"))
    assert env == {} and [job.python_specs for job in sent] == [["boxbox"], ["middle"]]


def test_robots_from_two_folders_are_refused_before_any_race(tmp_path):
    (tmp_path / "x").mkdir()
    (tmp_path / "y").mkdir()
    a, b = _robot_file(tmp_path / "x", "a"), _robot_file(tmp_path / "y", "b")
    with pytest.raises(UsageError, match="one folder"):
        travelling_jobs(_jobs(f"{a}:R", f"{b}:R"))


def test_a_head_that_does_not_answer_is_one_line_at_once():
    """ray.init tries an address nobody listens at for minutes, printing as it goes."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # bound, not listening: refused
        started = time.monotonic()
        with pytest.raises(UsageError, match=f"no Ray head answers at 127.0.0.1:{port}"):
            _check_reachable(f"127.0.0.1:{port}")
    assert time.monotonic() - started < 5


def test_a_run_dir_in_the_cache_travels_as_its_place_there(tmp_path, monkeypatch):
    """bench-field names each race's run dir under the front's cache; a node has its own cache."""
    monkeypatch.setenv("BOXBOX_CACHE", str(tmp_path / "cache"))
    todo = _jobs("boxbox", "middle")
    todo[0].run_dir = str(tmp_path / "cache" / "bench-field" / "g-track-1-robot-abc")
    todo[1].run_dir = str(tmp_path / "elsewhere")
    sent, _ = travelling_jobs(todo)
    assert [job.run_dir for job in sent] == ["CACHE/bench-field/g-track-1-robot-abc", str(tmp_path / "elsewhere")]
