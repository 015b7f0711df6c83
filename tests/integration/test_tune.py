"""boxbox tune against real races and a real PostgreSQL server: workers killed with SIGKILL in the
middle of a trial lose only that trial, which is run again; bad input exits 2 before any race."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

pytestmark = pytest.mark.torcs

TRACK = "g-track-1"  # about 0.4 s of wall time a lap here


@pytest.fixture(scope="module")
def postgres():
    """A real PostgreSQL (Debian's package, installed when missing): initdb in a temp dir, a unix
    socket there, an unprivileged user; stopped and removed afterwards."""
    from boxbox.tune.postgres import TempServer

    with TempServer() as server:
        folder = server.folder
        yield server
    assert folder is not None and not folder.exists()


def tune_cmd(*args: str) -> list[str]:
    return [sys.executable, "-m", "boxbox.cli", "tune", "--tracks", TRACK, "--params", "mu_scale", "--laps", "2",
            "--quiet", "--no-compare", *args]


def load(storage_url: str | None, study: str):
    from boxbox.tune.objective import TuneConfig
    from boxbox.tune.study import open_study

    study_obj, _ = open_study(TuneConfig(study=study, storage=storage_url))
    return study_obj


def forget(study: str) -> None:
    """The study's journal, its lock files and its setup in the cache."""
    from boxbox.tune.storage import journal_path

    for p in journal_path(study).parent.glob(f"{study}.*"):
        p.unlink()


def kill_mid_trial(proc: subprocess.Popen, storage_url: str | None, study: str, timeout_s: float = 60,
                   sig: int = signal.SIGKILL, fresh_s: float = 0.6) -> int:
    """Signal proc (SIGKILL) while a trial of its own is RUNNING, has its parameters (its races have
    begun: a kill between the claim and the first sampling leaves a trial with none to compare) and
    began less than fresh_s ago (its races take longer than that, so the signal lands inside them,
    not after its result); the trial's number."""
    import datetime

    import optuna

    deadline = time.monotonic() + timeout_s
    study_obj = None
    while time.monotonic() < deadline:
        assert proc.poll() is None, "the worker ended before it could be killed mid-trial"
        try:  # opened once: each open costs a busy machine a good part of a trial
            study_obj = study_obj or load(storage_url, study)
            running = study_obj.get_trials(states=(optuna.trial.TrialState.RUNNING,))
        except Exception:  # the study is not made yet
            running = []
        now = datetime.datetime.now()
        mine = [t for t in running if t.user_attrs.get("worker", "").split(":")[1:2] == [str(proc.pid)]
                and t.params and t.datetime_start is not None and (now - t.datetime_start).total_seconds() < fresh_s]
        if mine:
            proc.send_signal(sig)
            proc.wait(30)
            return mine[0].number
        time.sleep(0.02)
    raise AssertionError("no trial of the worker seen running")


def assert_retried(study, killed: int, trials: int) -> None:
    import optuna

    states = [t.state for t in study.trials]
    assert states.count(optuna.trial.TrialState.COMPLETE) == trials
    assert states.count(optuna.trial.TrialState.RUNNING) == 0 and states.count(optuna.trial.TrialState.WAITING) == 0
    assert study.trials[killed].state == optuna.trial.TrialState.FAIL
    retried = [t for t in study.trials if t.system_attrs.get("failed_trial") == killed]
    assert len(retried) == 1 and retried[0].state == optuna.trial.TrialState.COMPLETE
    assert retried[0].params == study.trials[killed].params


def test_two_workers_on_postgres_one_killed(overlay, postgres, tmp_path):
    study = f"kill-{uuid.uuid4().hex[:8]}"
    common = ("--storage", postgres.url, "--study", study, "--trials", "6", "--grace-s", "3", "--setup-out",
              str(tmp_path / "best.toml"), "--laps", "4")  # trials of a few seconds: the kill lands inside one
    a = subprocess.Popen(tune_cmd(*common, "--seed", "1"), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    time.sleep(1.0)  # a first: it makes the study
    b = subprocess.Popen(tune_cmd(*common, "--seed", "2"), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    workers = [a, b]
    try:
        killed = kill_mid_trial(a, postgres.url, study)
        if not still_running(postgres.url, study, killed):
            # the trial ended (a race that failed at once is told in milliseconds) between the look and
            # the signal: once more with a third worker, so the kill lands inside a trial
            workers.append(subprocess.Popen(tune_cmd(*common, "--seed", "3"), stdout=subprocess.DEVNULL,
                                            stderr=subprocess.PIPE))
            killed = kill_mid_trial(workers[-1], postgres.url, study)
        _, b_err = b.communicate(timeout=180)
        assert b.returncode == 0, b_err.decode()
    finally:
        for p in workers:
            if p.poll() is None:
                p.kill()
    assert_retried(load(postgres.url, study), killed, 6)


def still_running(storage_url: str, study: str, number: int) -> bool:
    """Whether trial number is still RUNNING (its worker killed inside it) right after the kill."""
    import optuna

    return load(storage_url, study).trials[number].state == optuna.trial.TrialState.RUNNING


def test_storage_calls_of_a_trial_on_postgres(postgres):
    """bench-tune's storage measure on a real PostgreSQL (races stood in for): a trial of two
    parameters on three tracks with pruning makes at most 44 SQL statements (82 when ask looked for
    queued trials, the pruner and TPE's constant liar read the study again and tell read the trial
    back twice)."""
    from boxbox.tune.bench_tune import time_storage
    from boxbox.tune.objective import TuneConfig

    base = TuneConfig(study="x", tracks=["g-track-1", "e-track-2", "aalborg"], categories=["road"] * 3,
                      params=["mu_scale", "brake_mu_scale"], laps=3, seed=7)
    ms, statements = time_storage(base, postgres.url, 12)
    assert 30 <= statements <= 44 and ms > 0


def test_journal_resumes_after_kill(overlay):
    from boxbox.tune.storage import journal_path

    study = f"resume-{uuid.uuid4().hex[:8]}"
    path = journal_path(study)
    try:
        a = subprocess.Popen(tune_cmd("--study", study, "--trials", "5"), stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE)
        try:
            killed = kill_mid_trial(a, None, study)
        finally:
            if a.poll() is None:
                a.kill()
        done = subprocess.run(tune_cmd("--study", study, "--trials", "5"), capture_output=True, text=True,
                              timeout=180)
        assert done.returncode == 0, done.stderr
        assert_retried(load(None, study), killed, 5)
        from boxbox.tune.objective import runs_root

        assert not [p for p in runs_root().iterdir() if p.name.startswith(f"{a.pid}:")]  # its race folder swept
        setup = path.with_suffix(".toml")
        assert setup.read_text().count("mu_scale = ") == 1
    finally:
        forget(study)


def test_ctrl_c_leaves_no_half_written_trial(overlay):
    import optuna


    study = f"int-{uuid.uuid4().hex[:8]}"
    try:
        proc = subprocess.Popen(tune_cmd("--study", study, "--trials", "30"), stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)
        try:
            stopped = kill_mid_trial(proc, None, study, sig=signal.SIGINT)
        finally:
            if proc.poll() is None:
                proc.kill()
        assert proc.returncode == 130 and "resume with --study" in proc.stderr.read().decode()
        trials = load(None, study).trials
        assert optuna.trial.TrialState.RUNNING not in [t.state for t in trials]
        # the trial under way is failed and queued again, unless its races ended before the stop
        # reached them (a signal between a trial's claim and its first race lets it finish)
        if trials[stopped].state != optuna.trial.TrialState.COMPLETE:
            assert trials[stopped].state == optuna.trial.TrialState.FAIL
            assert trials[-1].state == optuna.trial.TrialState.WAITING and trials[-1].params == trials[stopped].params
    finally:
        forget(study)


def test_two_local_workers_share_a_study(overlay, tmp_path):

    study = f"two-{uuid.uuid4().hex[:8]}"
    try:
        done = subprocess.run(tune_cmd("--study", study, "--trials", "4", "--workers", "2", "--seed", "3",
                                       "--report", str(tmp_path)), capture_output=True, text=True, timeout=180)
        assert done.returncode == 0, done.stderr
        trials = load(None, study).trials
        assert len(trials) == 4 and len({t.user_attrs["worker"] for t in trials}) == 2
        assert len({t.params["mu_scale"] for t in trials}) == 4  # the workers did not sample the same points
        page = (tmp_path / "report.html").read_text()
        assert "Optimisation history" in page and page.count("data:image/png;base64") >= 2
    finally:
        forget(study)


@pytest.mark.parametrize("args, message", [
    (("--params", "mu_scal"), "did you mean mu_scale"),
    (("--params", "name"), "is not a parameter"),
    (("--storage", "mysql://me@host/db"), "is not a storage boxbox knows"),
    (("--storage", "postgresql://nobody@/nothing?host=/nonexistent"), "cannot open it"),
    (("--tracks", "g-track-9"), "g-track-1"),
])
def test_bad_input_exits_2(overlay, args, message):
    base = ["--tracks", TRACK, "--params", "mu_scale", "--trials", "1", "--laps", "1", "--quiet", "--study",
            f"bad-{uuid.uuid4().hex[:8]}"]
    proc = subprocess.run([sys.executable, "-m", "boxbox.cli", "tune", *base, *args], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    from boxbox.tune.storage import journal_path

    assert not journal_path(base[-1]).exists()  # nothing left behind


def test_race_setup_file(overlay, tmp_path):
    import boxbox
    from boxbox.errors import UsageError

    good = tmp_path / "good.toml"
    good.write_text("mu_scale = 0.9\n")
    with_file = boxbox.race(TRACK, laps=1, setup=good, telemetry=False)
    with_set = boxbox.race(TRACK, laps=1, settings={"mu_scale": 0.9}, telemetry=False)
    assert with_file.drivers[0].time == with_set.drivers[0].time
    bad = tmp_path / "bad.toml"
    bad.write_text("mu_scal = 0.9\n")
    with pytest.raises(UsageError, match="unknown parameter 'mu_scal'"):
        boxbox.race(TRACK, laps=1, setup=bad)
    proc = subprocess.run([sys.executable, "-m", "boxbox.cli", "race", "--setup", str(bad)], capture_output=True,
                          text=True, timeout=60, env={**os.environ})
    assert proc.returncode == 2 and "mu_scal" in proc.stderr


def test_a_users_robot_declares_its_own_parameters(overlay, tmp_path):
    """The example of docs/tuning.md, tuned and raced with the setup it gets."""
    import re

    doc = (Path(__file__).resolve().parents[2] / "docs" / "tuning.md").read_text()
    code = re.search(r"<!-- example: tunable -->\s*```python\n(.*?)```", doc, re.S)
    assert code, "docs/tuning.md has no tunable example"
    (tmp_path / "follower.py").write_text(code.group(1))
    robot = f"{tmp_path / 'follower.py'}:TunedFollower"
    setup = tmp_path / "best.toml"
    study = f"user-{uuid.uuid4().hex[:8]}"
    done = subprocess.run([sys.executable, "-m", "boxbox.cli", "tune", "--robot", robot, "--tracks", TRACK, "--laps",
                           "1", "--params", "accel,steer_gain_per_m,mode", "--trials", "3", "--quiet", "--no-compare",
                           "--study", study, "--setup-out", str(setup)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    from boxbox.robot.tunable import read_setup

    best = read_setup(setup)
    assert set(best) == {"accel", "steer_gain_per_m", "mode"} and 0.2 <= best["accel"] <= 1.0
    race = subprocess.run([sys.executable, "-m", "boxbox.cli", "race", "--robot", robot, "--track", TRACK, "--laps",
                           "1", "--setup", str(setup), "--quiet", "--no-telemetry"], capture_output=True, text=True,
                          timeout=300)
    assert race.returncode == 0, race.stderr
    bad = subprocess.run([sys.executable, "-m", "boxbox.cli", "tune", "--robot", robot, "--params", "steer_gain"],
                         capture_output=True, text=True, timeout=60)
    # one line: the nearest names, and where all of them are (the car's 30-odd setup settings and the robot's)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1, bad.stderr
    assert "(did you mean steer_gain_per_m?); `boxbox params --robot " in bad.stderr
    assert bad.stderr.endswith(":TunedFollower --car car1-trb1` lists every one, with its range\n")
    from boxbox.tune.storage import journal_path

    assert journal_path(study).exists()
    forget(study)


def test_the_cautious_robot_of_the_docs_races_its_own_values(tmp_path):
    """docs/tuning.md's poor-values robot (bench-tune's check that the pick still hands out real
    gains): without settings it races its own 0.85 and 0.55, and a trial's values replace them."""
    import re

    from boxbox.torcs import checks
    from boxbox.tune.objective import TuneConfig, run_race

    doc = (Path(__file__).resolve().parents[2] / "docs" / "tuning.md").read_text()
    code = re.search(r"<!-- example: cautious -->\s*```python\n(.*?)```", doc, re.S)
    assert code, "docs/tuning.md has no cautious example"
    (tmp_path / "cautious.py").write_text(code.group(1))
    cfg = TuneConfig(study="cautious", robot=f"{tmp_path / 'cautious.py'}:Cautious", tracks=[TRACK], laps=1,
                     categories=[checks.check_race(TRACK, "car1-trb1", 1, (), (), 1)[0]])
    own = run_race(cfg, 0, {}, None)
    assert own.problem is None
    assert run_race(cfg, 0, {"mu_scale": 0.85, "brake_mu_scale": 0.55}, None).time_s == own.time_s
    assert run_race(cfg, 0, {"mu_scale": 1.0, "brake_mu_scale": 0.7}, None).time_s < own.time_s


def test_no_server_left(postgres):
    assert Path(postgres.folder, "data", "postmaster.pid").exists()
