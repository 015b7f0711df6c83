"""Faults of `boxbox tune` with real races, real worker processes and a real PostgreSQL: a worker
killed with SIGKILL at several moments of its life, on each storage, and workers started at the
same moment on a fresh database.  Each time the study completes, no trial stays RUNNING, and the
summary, the report and the setup file are written (docs/tuning.md, "Storage and faults")."""

from __future__ import annotations

import contextlib
import datetime
import os
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Callable
from pathlib import Path

import psutil
import pytest

pytestmark = pytest.mark.torcs

TRACK = "g-track-1"  # about 0.4 s of wall time a lap here
TRIALS = 4
RUN_TIMEOUT_S = 90  # a run that hangs (a dead worker's trial RUNNING for good) fails here


@pytest.fixture(scope="module")
def postgres():
    from boxbox.tune.postgres import TempServer

    with TempServer() as server:
        yield server


def tune_cmd(*args: str) -> list[str]:
    return [sys.executable, "-m", "boxbox.cli", "tune", "--tracks", TRACK, "--params", "mu_scale", "--laps", "1",
            "--quiet", "--no-compare", *args]


def load(url: str | None, study: str):
    from boxbox.tune.objective import TuneConfig
    from boxbox.tune.study import open_study

    return open_study(TuneConfig(study=study, storage=url))[0]


def forget(study: str) -> None:
    """The journal and its lock files in the cache."""
    from boxbox.tune.storage import journal_path

    for p in journal_path(study).parent.glob(f"{study}.*"):
        p.unlink()


# --- the moments of a worker's life a kill lands in, seen from outside through its processes -----
def in_a_race(worker: psutil.Process, study: str) -> None:
    """While its trial races (TORCS and the robot host are its children)."""
    _until(lambda: bool(worker.children()))


def first_racing(workers: list[psutil.Process]) -> int:
    """The number (1..) of the first worker seen racing: on an idle machine worker 2 had ended (its
    trials done) before a race of its own was seen (a clean clone's run, 2026-12-02)."""
    def racing() -> int:
        for number, worker in enumerate(workers, start=1):
            with contextlib.suppress(psutil.NoSuchProcess):
                if worker.children():
                    return number
        return 0
    seen: list[int] = []
    _until(lambda: bool(seen.append(racing()) or seen[-1]))
    return seen[-1]


def between_races(worker: psutil.Process, study: str) -> None:
    """Right after its first race ended: it writes the trial's result and claims the next one."""
    _until(lambda: bool(worker.children()))
    _until(lambda: not worker.children())


def in_its_claim(worker: psutil.Process, study: str) -> None:
    """Inside its first claim, holding the claim lock, its trial made but not yet beating: the
    front runs with BOXBOX_TUNE_PAUSE_IN_CLAIM_S, so the worker waits there (it holds NAME.lock
    then: /proc/locks); killed there, the lock still held."""
    from boxbox.tune.storage import journal_path

    claim = journal_path(study).with_suffix(".lock")
    _until(lambda: _holds(worker.pid, claim))
    worker.send_signal(signal.SIGKILL)
    _until(lambda: not _exists_unreaped(worker.pid) or worker.status() == psutil.STATUS_ZOMBIE)


PAUSED_IN_CLAIM_S = "2"  # the workers' pause inside each claim when the kill lands in one


def _holds(pid: int, path: Path) -> bool:
    """Whether process pid holds an flock on path (a line of /proc/locks: ... FLOCK ... PID MAJ:MIN:INODE)."""
    inode = f":{path.stat().st_ino} " if path.exists() else "?"
    return any(" -> " not in line and f" {pid} " in line and inode in line
               for line in Path("/proc/locks").read_text().splitlines())


def _until(seen: Callable[[], bool], timeout_s: float = 60) -> None:
    deadline = time.monotonic() + timeout_s
    while not seen():
        assert time.monotonic() < deadline, "the moment never came"
        time.sleep(0.005)


def workers_of(front: subprocess.Popen, n: int) -> list[psutil.Process]:
    """The front's n worker processes, in the order it started them (1..n)."""
    parent = psutil.Process(front.pid)
    deadline = time.monotonic() + 60
    while True:
        found = [p for p in parent.children() if "boxbox.tune.worker" in _cmdline(p)]
        if len(found) == n:
            return sorted(found, key=lambda p: p.pid)
        assert front.poll() is None and time.monotonic() < deadline, "the workers never started"
        time.sleep(0.01)


@pytest.mark.parametrize("storage, victim, moment", [
    ("journal", 2, in_a_race),
    ("journal", 2, in_its_claim),
    ("journal", 1, between_races),
    ("postgres", 2, in_a_race),
    ("postgres", 1, between_races),
], ids=lambda v: getattr(v, "__name__", str(v)))
def test_a_worker_killed(overlay, request, tmp_path, storage, victim, moment):
    """SIGKILL one of two workers: the other completes the study, the killed worker's trial (if
    it had one) is failed and raced again at once (on PostgreSQL without waiting for the 60 s
    heartbeat grace), the front reaps the dead worker, writes the summary, the report and the setup
    (in a folder it makes), and ends with one line naming the worker and its trial, exit 5."""
    import optuna

    from boxbox.tune.objective import runs_root

    url = request.getfixturevalue("postgres").url if storage == "postgres" else None
    study = f"fault-{uuid.uuid4().hex[:8]}"
    setup = tmp_path / "new" / "folder" / "best.toml"
    extra = ["--storage", url, "--grace-s", "60"] if url else []
    env = dict(os.environ, BOXBOX_TUNE_PAUSE_IN_CLAIM_S=PAUSED_IN_CLAIM_S) if moment is in_its_claim else None
    front = subprocess.Popen(tune_cmd("--study", study, "--trials", str(TRIALS), "--workers", "2", "--seed", "5",
                                      "--setup-out", str(setup), "--report", str(tmp_path / "report"), *extra),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        workers = workers_of(front, 2)
        if moment is in_a_race:
            victim = first_racing(workers)
        worker = workers[victim - 1]
        moment(worker, study)
        with contextlib.suppress(psutil.NoSuchProcess):  # in_its_claim killed it already
            worker.send_signal(signal.SIGKILL)
        killed_at = datetime.datetime.now()
        _until(lambda: not _exists_unreaped(worker.pid) or front.poll() is not None, 5)  # reaped, no zombie
        out, err = front.communicate(timeout=RUN_TIMEOUT_S)
    finally:
        if front.poll() is None:
            front.kill()
    try:
        assert front.returncode == 5, err
        last = err.strip().splitlines()[-1]
        assert f"the study completed without worker {victim} of 2 (pid {worker.pid}), killed by SIGKILL: " in last
        assert "complete," in err and "pruned" in err and f"setup: {setup}" in err  # the summary
        assert setup.read_text().count("mu_scale = ") == 1 and (tmp_path / "report" / "report.html").exists()
        trials = load(url, study).trials
        states = [t.state for t in trials]
        assert optuna.trial.TrialState.RUNNING not in states and optuna.trial.TrialState.WAITING not in states
        assert states.count(optuna.trial.TrialState.COMPLETE) + states.count(optuna.trial.TrialState.PRUNED) == TRIALS
        failed = [t for t in trials if t.state == optuna.trial.TrialState.FAIL]
        if moment is in_a_race:
            assert len(failed) == 1 and failed[0].user_attrs["worker"].split(":")[1] == str(worker.pid)
        for lost in failed:  # each lost trial raced again, at once, and the line says so
            again = next(t for t in trials if t.system_attrs.get("failed_trial") == lost.number)
            assert again.state != optuna.trial.TrialState.FAIL
            assert again.params == lost.params or not lost.params  # killed before it sampled: sampled afresh
            assert (again.datetime_start - killed_at).total_seconds() < 20  # not after the 60 s grace
            assert f"trial #{lost.number} failed and ran again as trial #{again.number}" in last
        if not failed:
            assert "between trials, no trial lost" in last
        assert not [p for p in runs_root().iterdir() if p.name.startswith(f"{worker.pid}:")]  # its race folders
    finally:
        forget(study)


def _cmdline(proc: psutil.Process) -> str:
    try:
        return " ".join(proc.cmdline())
    except psutil.NoSuchProcess:  # a child of the front's set-up that has just ended (a zombie)
        return ""


def _exists_unreaped(pid: int) -> bool:
    try:
        return psutil.Process(pid).status() is not None
    except psutil.NoSuchProcess:
        return False


START_TOGETHER = """
import sys, time
import optuna, psycopg, sqlalchemy  # imported before the start: the processes meet at the storage
from boxbox.cli import main
import boxbox.tune.study
at = float(sys.argv[1])
sys.argv = ["boxbox", *sys.argv[2:]]
time.sleep(max(0.0, at - time.time()))
main()
"""


def test_workers_started_at_once_on_a_fresh_database(overlay, postgres, tmp_path):
    """Three `boxbox tune` processes (a cluster's job array) start at the same moment on a new
    PostgreSQL database: one of them makes Optuna's schema, the others wait for it; together they
    complete the study and each writes its setup."""
    import optuna

    url = postgres.create_database(f"fresh_{uuid.uuid4().hex[:8]}")
    study = f"array-{uuid.uuid4().hex[:8]}"
    at = time.time() + 4  # after every process's imports, on a busy machine too
    procs = [subprocess.Popen([sys.executable, "-c", START_TOGETHER, str(at), *tune_cmd(
        "--storage", url, "--study", study, "--trials", "3", "--setup-out", str(tmp_path / f"w{i}" / "best.toml"))[3:]],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True) for i in range(3)]
    try:
        errors = [p.communicate(timeout=RUN_TIMEOUT_S)[1] for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    assert [p.returncode for p in procs] == [0, 0, 0], "\n".join(errors)
    states = [t.state for t in load(url, study).trials]
    assert states.count(optuna.trial.TrialState.COMPLETE) + states.count(optuna.trial.TrialState.PRUNED) == 3
    assert optuna.trial.TrialState.RUNNING not in states
    assert all((tmp_path / f"w{i}" / "best.toml").exists() for i in range(3))


def test_a_race_host_killed_from_outside_is_lost_not_scored(overlay):
    """A race host killed from outside (SIGKILL, the OOM killer's kind of death) gave its trial
    the 1000 s penalty, COMPLETE, as if the robot had failed; now the race is lost (RaceLost): the
    trial fails and runs again (tests/unit/test_tune_workers.py), as a lost worker's does."""
    import threading

    from boxbox.tune.objective import RaceLost, TuneConfig, run_race

    cfg = TuneConfig(study="outside-kill", robot="middle", tracks=[TRACK], categories=["road"], laps=20)
    me = psutil.Process()
    killed: list[int] = []

    def cmdline(proc: psutil.Process) -> list[str]:
        """Its command line; none for a child gone or a zombie (a robot check's child not yet reaped)."""
        try:
            return proc.cmdline()
        except psutil.Error:
            return []

    def kill_the_host() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            kids = me.children()
            if any("torcs" in " ".join(cmdline(k)) for k in kids):  # racing: the host is the Python child
                time.sleep(0.3)  # racing, not at the start: the whole race is about 1.7 s of wall time here
                for kid in kids:
                    with contextlib.suppress(psutil.Error):
                        if cmdline(kid) == me.cmdline():
                            kid.kill()
                            killed.append(kid.pid)
            time.sleep(0.05)

    killer = threading.Thread(target=kill_the_host, daemon=True)
    killer.start()
    with pytest.raises(RaceLost, match="the robot host was killed by SIGKILL with no fault of its robot said"):
        run_race(cfg, 0, {}, None)
    killer.join()
    assert killed
