"""The front of `boxbox tune --workers N` and the journal storage, with real processes (no races):
a killed worker is reaped and taken for dead at once, a journal writer killed holding its lock
stalls nobody, --setup-out makes its folder."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
import uuid

import psutil
import pytest


def forget(study: str) -> None:
    from boxbox.tune.storage import journal_path

    for p in journal_path(study).parent.glob(f"{study}.*"):
        p.unlink()


def _exists_unreaped(pid: int) -> bool:
    try:
        return psutil.Process(pid).status() is not None
    except psutil.NoSuchProcess:
        return False


def test_a_zombie_worker_is_dead():
    """A worker killed and not yet reaped keeps its /proc entry: it is dead all the same."""
    import socket
    from pathlib import Path

    from boxbox.tune.storage import worker_alive

    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:  # host:pid:start time, as a worker notes itself on its trials
        start = Path(f"/proc/{proc.pid}/stat").read_text().rpartition(")")[2].split()[19]
        tag = f"{socket.gethostname()}:{proc.pid}:{start}"
        assert worker_alive(tag)
        proc.send_signal(signal.SIGKILL)
        deadline = time.monotonic() + 10
        while psutil.Process(proc.pid).status() != psutil.STATUS_ZOMBIE:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert not worker_alive(tag)
    finally:
        proc.kill()
        proc.wait()
    assert not worker_alive(tag)


def test_setup_out_in_a_missing_folder(tmp_path):
    """--setup-out DIR/best.toml takes a DIR to be made, as --report does (read by the command's
    own option); a folder that cannot be made is still refused."""
    import click

    from boxbox.cli.tune import tune

    option = next(p for p in tune.params if p.name == "setup_out")
    target = tmp_path / "a" / "b" / "best.toml"
    assert option.type.convert(str(target), option, None) == target
    (tmp_path / "file").write_text("")
    with pytest.raises(click.BadParameter, match="is a file"):
        option.type.convert(str(tmp_path / "file" / "x" / "best.toml"), option, None)


def test_a_journal_writer_killed_holding_its_lock(tmp_path):
    """A worker killed while it writes to the journal (holding the write lock) does not stall the
    others: the next write goes through at once, not after a stale lock's 30 s."""
    from boxbox.tune.storage import Storage

    study = f"lock-{uuid.uuid4().hex[:8]}"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import os, signal, sys\n"
        "from boxbox.tune.storage import Storage\n"
        f"lock = Storage(None, {study!r}).optuna._backend._lock\n"
        "lock.acquire()\n"
        "print('held', flush=True)\n"
        "os.kill(os.getpid(), signal.SIGKILL)\n")], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        holder.wait(10)
        started = time.monotonic()
        storage = Storage(None, study)
        done = subprocess.run([sys.executable, "-c", (
            "import optuna\n"
            "from boxbox.tune.storage import Storage\n"
            f"optuna.create_study(study_name={study!r}, storage=Storage(None, {study!r}).optuna)\n")], timeout=25)
        assert done.returncode == 0 and time.monotonic() - started < 10
        assert storage.optuna.get_all_studies()[0].study_name == study
    finally:
        forget(study)


def test_the_front_reaps_every_worker(tmp_path):
    """wait_workers polls every worker each time (the first live one does not hide the others):
    a killed worker is reaped while the others still run, and named as lost."""
    from boxbox.tune.storage import worker_alive, worker_tag
    from boxbox.tune.study import StopFlag, Worker, wait_workers

    procs = [subprocess.Popen([sys.executable, "-c", "import time; time.sleep(3)"]) for _ in range(3)]
    workers = [Worker(i + 1, p, worker_tag(p.pid)) for i, p in enumerate(procs)]
    procs[2].kill()
    seen: list[bool] = []
    reclaimed: list[int] = []

    def tick() -> None:  # while the first two still sleep
        if procs[0].poll() is None:
            seen.append(_exists_unreaped(procs[2].pid))

    lost = wait_workers(workers, tick, StopFlag(), reclaim=lambda w: reclaimed.append(w.number) or [])
    assert [w.number for w in lost] == [3] and reclaimed == [3] and lost[0].how_it_ended == "killed by SIGKILL"
    assert seen and not seen[-1]  # reaped while the others ran
    assert all(p.returncode is not None for p in procs) and not any(worker_alive(w.tag) for w in workers)


def test_a_trial_whose_race_was_lost_fails_and_runs_again_at_most_max_retry_times():
    """RaceLost (a race host killed from outside): the trial fails and its values are queued again,
    as a lost worker's trial is; not scored, and not retried for ever."""
    import optuna

    from boxbox.tune.objective import RaceLost
    from boxbox.tune.study import StopFlag, _run_trial

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study()
    study.enqueue_trial({"x": 0.5})

    def objective(trial):
        trial.suggest_float("x", 0, 1)
        raise RaceLost("the robot host was killed by SIGKILL")

    for _ in range(5):
        trial = study.ask()
        assert _run_trial(study, trial, objective, StopFlag(), max_retry=2) == 0
    states = [t.state for t in study.get_trials()]
    assert optuna.trial.TrialState.COMPLETE not in states
    first, second, third = study.get_trials()[:3]
    assert first.state == second.state == third.state == optuna.trial.TrialState.FAIL
    assert second.params == third.params == {"x": 0.5}  # run again with the same values
    assert third.system_attrs["retry_history"] == [0, 1]  # ... twice, then no more
    assert study.get_trials()[3].params != {"x": 0.5}
