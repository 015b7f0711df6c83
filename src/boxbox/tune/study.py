"""A study: its creation, the worker loop that takes trials until the study has enough, and the
figures of a finished study (best against the defaults, time saved by pruning).

Workers stop on Ctrl-C, SIGTERM or SIGHUP after the race that runs: its trial is marked failed
and queued again (a resumed study runs it), so the study never holds a half-written trial.  The
front of `--workers N` reaps each worker as it ends; the trial of one that was killed (or failed)
is failed and queued again at once, the others complete the study, and the run's Outcome names
the workers lost (exit 5 after the summary: WorkerLost).
"""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from boxbox.errors import BoxboxError
from boxbox.tune.objective import RaceLost, TrialInterrupted, TuneConfig, make_objective, sweep_dead_runs
from boxbox.tune.storage import WORKER_ATTR, Storage, worker_tag
from boxbox.tune.study_figures import progress

FINISHED = ("COMPLETE", "PRUNED")
WAIT_S = 1.0  # a worker with nothing to take looks again after this


def open_study(cfg: TuneConfig, storage: Storage | None = None, create: bool = False) -> tuple[Any, Storage]:
    """The study (created when asked and missing), with cfg's sampler and pruner."""
    import optuna

    from boxbox.tune.synced import SyncedPruner, SyncedSampler

    storage = storage or Storage(cfg.storage, cfg.study, cfg.heartbeat_s, cfg.grace_s, cfg.max_retry)
    # multivariate: the parameters sampled together (grip in turns and under braking go together),
    # and the trials read once per trial instead of once per parameter
    sampler = SyncedSampler(optuna.samplers.TPESampler(seed=cfg.seed, n_startup_trials=min(10, max(2, cfg.trials // 5)),
                                                       multivariate=True))
    # the first tracks decide little: prune only once a few trials have finished all of them
    pruner = SyncedPruner(optuna.pruners.MedianPruner(n_startup_trials=5, n_warmup_steps=0)) if cfg.prune \
        else optuna.pruners.NopPruner()
    study = optuna.create_study(study_name=cfg.study, storage=storage.optuna, sampler=sampler, pruner=pruner,
                                direction="minimize", load_if_exists=True) if create else \
        optuna.load_study(study_name=cfg.study, storage=storage.optuna, sampler=sampler, pruner=pruner)
    return study, storage


def tell(study: Any, trial: Any, value: float | None = None, state: Any = None) -> None:
    """Finish a trial as study.tell does, from the trial as its Trial object holds it (Optuna keeps
    its parameters, reports and notes there as they are written) instead of reading it back from
    the storage twice (12 SQL statements on a database).  A pruned trial's value is its last
    report, as with study.tell."""
    import optuna

    state = state or optuna.trial.TrialState.COMPLETE
    frozen = trial._get_latest_trial()
    values = None if value is None else [float(value)]
    if state == optuna.trial.TrialState.PRUNED and frozen.last_step is not None:
        values = [frozen.intermediate_values[frozen.last_step]]
    study._thread_local.cached_all_trials = None  # the next trial reads the study afresh
    try:
        study.sampler.after_trial(study, frozen, state, values)
    finally:  # an UpdateFinishedTrialError here: another worker found the trial stale and retried it
        study._storage.set_trial_state_values(trial._trial_id, state, values)


class StopFlag:
    """Ctrl-C, SIGTERM, SIGHUP noted (a race that runs notes them too, and stops)."""

    def __init__(self) -> None:
        self.event = threading.Event()

    def install(self) -> None:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
                signal.signal(sig, lambda *_: self.event.set())

    @property
    def set(self) -> bool:
        return self.event.is_set()


def _claim(study: Any, storage: Storage, target: int) -> tuple[Any, bool]:
    """(a trial to run or None, whether the study has all its trials), taken under the lock: a
    queued (retried) trial first, a new one only while finished + running + queued < target."""
    with storage.claim_lock():
        storage.fail_stale(study)
        c = storage.counts(study)
        finished = sum(c.get(s, 0) for s in FINISHED)
        if finished >= target:
            return None, True
        if c.get("WAITING", 0) == 0 and finished + c.get("RUNNING", 0) >= target:
            return None, False  # others run the last trials: wait, one of them may die
        trial = _ask(study, queued=c.get("WAITING", 0) > 0, tag=worker_tag())
        _pause_for_tests()
        # the first beat before anything else: Optuna never finds a trial without one stale, so a
        # worker killed between the two would leave it RUNNING for good
        storage.beat(trial._trial_id)
        return trial, False


def _pause_for_tests() -> None:
    """BOXBOX_TUNE_PAUSE_IN_CLAIM_S seconds here: the tests kill a worker at the riskiest moment of
    its claim (a trial made, not yet beating, the lock held), which otherwise lasts microseconds."""
    hold_s = os.environ.get("BOXBOX_TUNE_PAUSE_IN_CLAIM_S")
    if hold_s:
        time.sleep(float(hold_s))


def _ask(study: Any, queued: bool, tag: str) -> Any:
    """study.ask(), the trial noting its worker (`tag`) before it is RUNNING, so that a worker
    killed at any moment of its claim leaves no RUNNING trial that names no worker, or another.
    ask first reads every trial to look for a queued one (7 SQL statements on a database); when
    the count under the lock found none queued, the new trial is made directly, as ask then does.
    A trial queued meanwhile (Ctrl-C's retry, made outside the lock) replaces a running one, so the
    count still holds, and the next claim takes it."""
    import datetime

    import optuna

    study._thread_local.cached_all_trials = None  # as in ask: the trial's sampling reads the study afresh
    storage = study._storage
    running, waiting = optuna.trial.TrialState.RUNNING, optuna.trial.TrialState.WAITING
    for queued_trial in storage.get_all_trials(study._study_id, deepcopy=False, states=(waiting,)) if queued else []:
        storage.set_trial_user_attr(queued_trial._trial_id, WORKER_ATTR, tag)  # a retry has its dead worker's
        try:
            if storage.set_trial_state_values(queued_trial._trial_id, running):
                return optuna.Trial(study, queued_trial._trial_id)
        except optuna.exceptions.UpdateFinishedTrialError:
            continue
    template = optuna.trial.FrozenTrial(
        number=-1, state=running, value=None, datetime_start=datetime.datetime.now(), datetime_complete=None,
        params={}, distributions={}, user_attrs={WORKER_ATTR: tag}, system_attrs={}, intermediate_values={},
        trial_id=-1)  # made RUNNING with its worker noted: one write
    return optuna.Trial(study, storage.create_new_trial(study._study_id, template_trial=template))


def _beating(storage: Storage, trial_id: int, interval_s: float) -> threading.Event:
    done = threading.Event()

    def beat() -> None:
        while not done.wait(interval_s):
            try:
                storage.beat(trial_id)
            except Exception:  # a database hiccup: the next beat tries again
                pass

    if storage.has_heartbeat:
        threading.Thread(target=beat, daemon=True, name="boxbox-heartbeat").start()
    return done


def run_worker(cfg: TuneConfig, cpu: int | None = None, stop: StopFlag | None = None) -> int:
    """Take and run trials until the study has cfg.trials finished ones (or a stop signal); the
    number of trials this worker finished."""

    from boxbox.robot.loader import load_robot_class
    from boxbox.tune.space import distributions, tune_space

    stop = stop or StopFlag()
    sweep_dead_runs()
    study, storage = open_study(cfg)
    objective = make_objective(cfg, distributions(tune_space(load_robot_class(cfg.robot), cfg.car), cfg.params), cpu)
    try:
        return _work(cfg, study, storage, objective, stop)
    except Exception as exc:
        import optuna
        import sqlalchemy.exc

        if not isinstance(exc, sqlalchemy.exc.SQLAlchemyError | optuna.exceptions.StorageInternalError | OSError):
            raise
        from boxbox.errors import BoxboxError
        from boxbox.tune.storage import describe

        cause = exc.__cause__ if isinstance(exc, optuna.exceptions.StorageInternalError) and exc.__cause__ else exc
        first = (str(cause).strip().splitlines() or [type(cause).__name__])[0]
        raise BoxboxError(f"the study's storage ({describe(cfg.storage, cfg.study)}) failed: {first}; "
                          f"its finished trials are kept: resume with --study {cfg.study}") from None


def _work(cfg: TuneConfig, study: Any, storage: Storage, objective: Callable[[Any], float], stop: StopFlag) -> int:
    import optuna

    done_here = 0
    while not stop.set:
        trial, complete = _claim(study, storage, cfg.trials)
        if complete:
            break
        if trial is None:
            stop.event.wait(WAIT_S)
            continue
        beating = _beating(storage, trial._trial_id, cfg.heartbeat_s)
        try:
            done_here += _run_trial(study, trial, objective, stop, cfg.max_retry)
        except optuna.exceptions.UpdateFinishedTrialError:
            pass  # another worker found this one stale (no heartbeat for the grace period) and retried it
        finally:
            beating.set()
    return done_here


def _run_trial(study: Any, trial: Any, objective: Callable[[Any], float], stop: StopFlag, max_retry: int = 3) -> int:
    """Run one trial and tell the study how it ended; 1 if it finished (complete or pruned).  A
    race lost to an outside kill fails the trial and queues it again (at most max_retry times)."""
    import optuna

    try:
        value = objective(trial)
    except optuna.TrialPruned:
        tell(study, trial, state=optuna.trial.TrialState.PRUNED)
        return 1
    except TrialInterrupted:
        stop.event.set()
        _fail_and_requeue(study, trial, "interrupted")
        return 0
    except RaceLost as exc:
        _fail_and_requeue(study, trial, f"race lost: {exc}"[:300], max_retry)
        return 0
    except optuna.exceptions.UpdateFinishedTrialError:
        raise
    except Exception as exc:  # a bug in a robot's code path we did not foresee: this trial only
        trial.set_user_attr("error", f"{type(exc).__name__}: {exc}"[:300])
        tell(study, trial, state=optuna.trial.TrialState.FAIL)
        return 0
    tell(study, trial, value)
    return 1


def _fail_and_requeue(study: Any, trial: Any, why: str, max_retry: int | None = None) -> None:
    """The trial failed, its parameters queued again (the next worker, or a resumed study, runs them)
    unless it was already run again max_retry times."""
    import optuna

    trial.set_user_attr("stopped", why)
    tell(study, trial, state=optuna.trial.TrialState.FAIL)
    frozen = study._storage.get_trial(trial._trial_id)
    history = [*frozen.system_attrs.get("retry_history", []), frozen.number]
    if max_retry is not None and len(history) > max_retry:
        return
    study.add_trial(optuna.trial.create_trial(state=optuna.trial.TrialState.WAITING, params=frozen.params,
                                              distributions=frozen.distributions,
                                              system_attrs={"failed_trial": frozen.number,
                                                            "retry_history": history}))


# --- several local workers ------------------------------------------------------------------------
@dataclass
class Worker:
    """A worker process of the front: its number (1..N), process and tag (as its trials note it)."""

    number: int
    proc: subprocess.Popen
    tag: str
    lost_trials: list[int] = dataclasses.field(default_factory=list)  # failed by the front when it died

    @property
    def how_it_ended(self) -> str:
        code = self.proc.returncode
        if code is not None and code < 0:
            try:
                return f"killed by {signal.Signals(-code).name}"
            except ValueError:
                return f"killed by signal {-code}"
        return f"failed with exit status {code} (its error is above)"

    @property
    def lost(self) -> bool:
        """Ended without finishing its part (a stop signal's 130 is a finish)."""
        return self.proc.returncode not in (None, 0, 130, -signal.SIGINT)


def spawn_workers(cfg: TuneConfig, n: int) -> list[Worker]:
    """n worker processes (python -m boxbox.tune.worker), worker i racing on core i (mod the cores);
    each dies with this process."""
    cpus = sorted(os.sched_getaffinity(0))
    workers = []
    for i in range(n):
        cpu = cpus[i % len(cpus)] if cpus else -1
        # each worker its own seed: with one seed they would sample the same points side by side
        seeded = cfg if cfg.seed is None else dataclasses.replace(cfg, seed=cfg.seed + i)
        proc = subprocess.Popen([sys.executable, "-m", "boxbox.tune.worker", seeded.to_json(), str(cpu)],
                                stdin=subprocess.DEVNULL, preexec_fn=_die_with_parent)
        # Popen returns after the exec: the pid and its start time are the worker's own from here
        workers.append(Worker(i + 1, proc, worker_tag(proc.pid)))
    return workers


def _die_with_parent() -> None:
    from boxbox.torcs.processes import PR_SET_PDEATHSIG, _libc

    _libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


def compare(cfg: TuneConfig, candidates: dict[str, dict], tracks: list[str] | None = None,
            on_race: Callable[[str, str], None] | None = None) -> list[dict]:
    """Per track, the race time with the robot's own values (no settings, "defaults") and with each
    of `candidates` (label -> settings); the problem of each race under "LABEL_problem"."""
    from boxbox.torcs import checks
    from boxbox.tune.objective import run_race

    tracks = tracks or cfg.tracks
    cats = [checks.check_race(t, cfg.car, 1, (), (), cfg.laps)[0] for t in tracks]
    local = TuneConfig(**{**cfg.__dict__, "tracks": tracks, "categories": cats})
    rows = []
    for i, track in enumerate(tracks):
        row: dict = {"track": track}
        for label, settings in {"defaults": {}, **candidates}.items():
            if on_race:
                on_race(track, label)
            s = run_race(local, i, settings, None)
            row[label] = s.score_s
            row[f"{label}_problem"] = s.problem
        rows.append(row)
    return rows


def wait_workers(workers: list[Worker], tick: Callable[[], None], stop: StopFlag,
                 reclaim: Callable[[Worker], list[int]] | None = None) -> list[Worker]:
    """Until every worker has ended: each polled (so reaped) every half second, tick() between; on
    a stop signal, pass it on once.  A worker lost (killed, or failed: its error is on its stderr)
    is handed to reclaim at once, which fails and queues again the trial it ran, so the others
    need not wait for its heartbeat to go stale.  The workers lost."""
    passed = False
    running = list(workers)
    while running:
        if stop.set and not passed:
            for w in running:
                w.proc.send_signal(signal.SIGINT)
            passed = True
        for w in [w for w in running if w.proc.poll() is not None]:  # every one polled: none left a zombie
            running.remove(w)
            if w.lost and reclaim is not None:
                w.lost_trials = reclaim(w)
        tick()
        if running:
            time.sleep(0.5)
    return [w for w in workers if w.lost]


def reclaimer(study: Any, storage: Storage) -> Callable[[Worker], list[int]]:
    """reclaim for wait_workers: the RUNNING trials of a worker that died (and any trial claimed by
    a worker killed inside its claim) failed and queued again, under the claim lock; their numbers."""

    def reclaim(worker: Worker) -> list[int]:
        try:
            with storage.claim_lock():
                return storage.fail_trials_of(study, {worker.tag})
        except Exception:  # the storage is down too: the other workers' own checks find the trial
            return []

    return reclaim


def lost_trials(study: Any, worker: Worker) -> list[int]:
    """The trials a lost worker did not finish: those the front failed for it and the one its tag
    marks as failed by another worker's check (a robot's error or a stop signal are noted, a
    death is not)."""
    import optuna

    found = set(worker.lost_trials)
    for t in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.FAIL,)):
        if t.user_attrs.get(WORKER_ATTR) == worker.tag and not {"error", "stopped"} & t.user_attrs.keys():
            found.add(t.number)
    return sorted(found)


def fate(study: Any, number: int) -> str:
    """What became of lost trial `number`: the trial that raced its values again, or why none did."""
    retries = [t for t in study.get_trials(deepcopy=False)
               if (t.system_attrs.get("retry_history") or [None])[-1] == number]
    if not retries:
        return f"trial #{number} failed and was not run again (retried too often)"
    again = retries[0]
    return f"trial #{number} failed and ran again as trial #{again.number} ({again.state.name.lower()})"


def lost_line(study: Any, workers: int, lost: list[Worker]) -> str:
    """One line: each lost worker, how it ended and what became of its trial."""
    parts = []
    for w in lost:
        numbers = lost_trials(study, w)
        what = ", ".join(fate(study, n) for n in numbers) if numbers else "between trials, no trial lost"
        parts.append(f"worker {w.number} of {workers} (pid {w.proc.pid}), {w.how_it_ended}: {what}")
    return "; ".join(parts)


# --- a whole run: the study made, its workers run, watched -------------------------------------------
STUDY_KEYS = ("robot", "tracks", "params", "laps", "car", "skill_level", "damage_limit")


def prepare(cfg: TuneConfig) -> Any:
    """The study, created or resumed (its settings must match cfg's); a new study's first trial is
    the robot's declared defaults."""
    from boxbox.errors import UsageError
    from boxbox.robot.loader import load_robot_class
    from boxbox.tune.space import defaults_in_space, distributions, tune_space

    study, storage = open_study(cfg, create=True)
    mine = {k: getattr(cfg, k) for k in STUDY_KEYS}
    with storage.claim_lock():  # processes started together: one of them enqueues the defaults
        theirs = study.user_attrs.get("boxbox")
        if theirs is None:
            study.set_user_attr("boxbox", mine)
            space = tune_space(load_robot_class(cfg.robot), cfg.car)
            if not study.get_trials(deepcopy=False):
                study.enqueue_trial(defaults_in_space(space, distributions(space, cfg.params)))
    if theirs is not None and {k: theirs.get(k) for k in STUDY_KEYS} != mine:
        diff = ", ".join(f"{k} {theirs.get(k)!r}" for k in STUDY_KEYS if theirs.get(k) != mine[k])
        raise UsageError(f"study '{cfg.study}' was made with {diff}; resume it with those, or give another --study")
    return study


class WorkerLost(BoxboxError):
    """The study completed (its summary, setup and report written) without a worker that was killed
    or failed on the way: exit 5, so a job script can tell it from a clean run and from a failure."""

    exit_code = 5


@dataclass
class Outcome:
    """A run's study, and the local workers it lost (killed, or failed) on the way."""

    study: Any
    workers: int = 1
    lost: list[Worker] = dataclasses.field(default_factory=list)

    def complete(self, trials: int) -> bool:
        return progress(self.study).finished >= trials

    def check(self, cfg: TuneConfig) -> None:
        """Raise for the workers lost: WorkerLost when the others completed the study, a plain
        error (exit 1) when it stopped short."""
        if not self.lost:
            return
        line = lost_line(self.study, self.workers, self.lost)
        if self.complete(cfg.trials):
            raise WorkerLost(f"the study completed without {line}")
        raise BoxboxError(f"the study stopped at {progress(self.study).finished} of {cfg.trials} finished trials: "
                          f"{line}; its finished trials are kept: resume with --study {cfg.study}")


def run(cfg: TuneConfig, workers: int, tick: Callable[[Any], None], stop: StopFlag) -> Outcome:
    """Run the study to cfg.trials finished trials with `workers` local workers (1: this process),
    calling tick(study) about every second."""
    study = prepare(cfg)
    watcher, storage = open_study(cfg)  # its own storage connection: the worker's is busy in races
    lost: list[Worker] = []
    if workers == 1:
        done = threading.Event()

        def watch() -> None:
            while not done.wait(1.0):
                try:
                    tick(watcher)
                except Exception:  # a busy database: the next tick shows it
                    pass

        thread = threading.Thread(target=watch, daemon=True, name="boxbox-tune-watch")
        thread.start()
        try:
            run_worker(cfg, None, stop)
        finally:
            done.set()
            thread.join()
    else:
        lost = wait_workers(spawn_workers(cfg, workers), lambda: tick(watcher), stop,
                            reclaimer(watcher, storage))
        sweep_dead_runs()  # the race folders of a killed worker
    tick(watcher)
    return Outcome(study, workers, lost)
