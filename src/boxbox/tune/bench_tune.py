"""`boxbox bench-tune`: what tuning costs and what it finds.

1. Trials per hour with 1 and with 2 local workers (the same study size, pruning off so that each
   trial races every track; each worker a process of its own, started the same way).
2. What the storage costs a trial: a worker's own claim and trial (claim under the lock, the
   worker's note, suggestions, a report and a pruning check after each track but the last, the
   races' notes, the result) with its races stood in for, against the journal file and against a
   real PostgreSQL on a unix socket; as a share of the mean wall time of a trial from 1.
3. Optionally, generalisation: a study on three tracks, its best parameters by each pick
   (tune.pick) raced on three tracks it never saw against the robot's own values, and the same the
   other way round.
"""

from __future__ import annotations

import dataclasses
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from boxbox.tune.objective import RaceScore, TuneConfig
from boxbox.tune.storage import Storage, journal_path

Report = Callable[[str], None]


@dataclass
class BenchTuneResult:
    trial_wall_s: dict[int, float] = field(default_factory=dict)  # workers -> first trial's start to last's end
    run_wall_s: dict[int, float] = field(default_factory=dict)  # workers -> the run with the workers' start-up
    all_trial_wall_s: dict[int, list[float]] = field(default_factory=dict)  # every round's, the median above
    rounds: int = 1
    trials: int = 0
    storage_ms: dict[str, float] = field(default_factory=dict)  # storage -> ms per trial
    statements: dict[str, int] = field(default_factory=dict)  # storage -> SQL statements per trial
    round_trip_ms: float | None = None  # PostgreSQL: one `SELECT 1`, the machine's floor per statement
    general: list[dict] = field(default_factory=list)

    def per_hour(self, workers: int) -> float:
        return 3600.0 * self.trials / self.trial_wall_s[workers]

    @property
    def mean_trial_s(self) -> float:
        return self.trial_wall_s[1] / self.trials


def _cleanup(study: str) -> None:
    path = journal_path(study)
    for p in (path, path.with_suffix(".lock"), path.with_suffix(".toml"), Path(f"{path}.flock")):
        p.unlink(missing_ok=True)


def time_workers(base: TuneConfig, workers: int) -> tuple[float, float]:
    """A fresh study of base.trials trials run by `workers` worker processes: the time from the
    first trial's start to the last one's end (what a long study sees), and the whole run's."""
    from boxbox.tune import study as studies
    from boxbox.tune import study_figures

    cfg = dataclasses.replace(base, study=f"bench-{workers}w-{uuid.uuid4().hex[:8]}", prune=False)
    try:
        studies.prepare(cfg)
        started = time.monotonic()
        lost = studies.wait_workers(studies.spawn_workers(cfg, workers), lambda: None, studies.StopFlag())
        wall = time.monotonic() - started
        study, _ = studies.open_study(cfg)
        if lost:
            raise RuntimeError(f"bench study {cfg.study}: {studies.lost_line(study, workers, lost)}")
        done = study_figures.counts(study).get("COMPLETE", 0)
        if done != cfg.trials:
            raise RuntimeError(f"bench study {cfg.study} ended with {done} of {cfg.trials} complete trials")
        trials = study.get_trials(deepcopy=False)
        window = max(t.datetime_complete for t in trials) - min(t.datetime_start for t in trials)
        return window.total_seconds(), wall
    finally:
        _cleanup(cfg.study)


def round_trip_ms(url: str, n: int = 200) -> float:
    """Mean wall time of `SELECT 1` on one open connection."""
    from sqlalchemy import create_engine, text

    from boxbox.tune.storage import sqlalchemy_url

    engine = create_engine(sqlalchemy_url(url))
    try:
        with engine.connect() as conn:
            conn.execute(text("SELECT 1"))
            started = time.perf_counter()
            for _ in range(n):
                conn.execute(text("SELECT 1"))
            return 1000.0 * (time.perf_counter() - started) / n
    finally:
        engine.dispose()


def _no_race(cfg: TuneConfig, index: int, settings: dict, cpu: int | None) -> RaceScore:
    """A race's result without racing (every trial the same: none is pruned, each makes every call)."""
    return RaceScore(track=cfg.tracks[index], score_s=40.0 * cfg.laps, time_s=40.0 * cfg.laps, laps=cfg.laps,
                     damage=0, wall_s=0.0, lap_times=[40.0] * cfg.laps)


def time_storage(base: TuneConfig, url: str | None, trials: int) -> tuple[float, int]:
    """Mean wall time (ms) of the storage calls of one trial, without its races: the worker's own
    claim and trial (study._claim, study._run_trial, the objective with a stand-in race), so the
    pruning reports and checks are counted when base.prune; and (databases) the SQL statements a
    trial makes."""
    from boxbox.robot.loader import load_robot_class
    from boxbox.robot.tunable import param_space
    from boxbox.tune import study as studies
    from boxbox.tune.objective import make_objective
    from boxbox.tune.space import distributions

    cfg = dataclasses.replace(base, study=f"bench-storage-{uuid.uuid4().hex[:8]}", storage=url, trials=trials)
    objective = make_objective(cfg, distributions(param_space(load_robot_class(cfg.robot)), cfg.params), None,
                               race=_no_race)
    try:
        studies.prepare(cfg)
        study, storage = studies.open_study(cfg, Storage(url, cfg.study, cfg.heartbeat_s, cfg.grace_s))
        statements = [0]
        if url is not None:
            from sqlalchemy import event

            event.listen(storage.optuna.engine, "before_cursor_execute",
                         lambda *args: statements.__setitem__(0, statements[0] + 1))
        started = time.perf_counter()
        for _ in range(trials):
            trial, _ = studies._claim(study, storage, trials)
            studies._run_trial(study, trial, objective, studies.StopFlag())
        return 1000.0 * (time.perf_counter() - started) / trials, round(statements[0] / trials)
    finally:
        _cleanup(cfg.study)


def generalisation(base: TuneConfig, train: list[str], test: list[str], trials: int, workers: int,
                   report: Report) -> list[dict]:
    """Tune on `train`, then race the robot's own values and the best of each pick (tune.pick,
    GENERAL_PICKS) on train and test tracks."""
    from boxbox.torcs import checks
    from boxbox.tune import study as studies
    from boxbox.tune.pick import GENERAL_PICKS

    cats = [checks.check_race(t, base.car, 1, (), (), base.laps)[0] for t in train]
    cfg = dataclasses.replace(base, study=f"bench-general-{uuid.uuid4().hex[:8]}", tracks=train, categories=cats,
                              trials=trials, prune=True)
    try:
        report(f"generalisation: {trials} trials on {', '.join(train)}")
        study = studies.run(cfg, workers, lambda s: None, studies.StopFlag()).study
        picks = {label: rule.choose(study, cfg) for label, rule in GENERAL_PICKS.items()}
        best = {how: p.trial.params for how, p in picks.items() if p.trial is not None}
        rows = []
        for label, tracks in (("tuned on", train), ("unseen", test)):
            for row in studies.compare(cfg, best, tracks):
                rows.append({"train": "+".join(train), "set": label, "best_params": best,
                             "picked": {how: p.trial.number for how, p in picks.items() if p.trial is not None},
                             "why": {how: p.why for how, p in picks.items()}, **row})
        return rows
    finally:
        _cleanup(cfg.study)


def run_bench(base: TuneConfig, storage_trials: int, postgres_url: str | None, general_trials: int,
              general_tracks: tuple[list[str], list[str]] | None, report: Report, rounds: int = 3,
              costs: bool = True) -> BenchTuneResult:
    """The measures (without `costs`, the generalisation studies only), each taken `rounds` times in
    turn (1 worker, 2 workers, journal, PostgreSQL, again...) and the median kept: on a shared
    machine the load moves within minutes."""
    result = BenchTuneResult(trials=base.trials, rounds=rounds)
    if costs:
        measure_costs(base, storage_trials, postgres_url, report, result)
    if general_trials and general_tracks:
        a, b = general_tracks
        result.general = (generalisation(base, a, b, general_trials, 2, report)
                          + generalisation(base, b, a, general_trials, 2, report))
    return result


def measure_costs(base: TuneConfig, storage_trials: int, postgres_url: str | None, report: Report,
                  result: BenchTuneResult) -> None:
    """Trials per hour with 1 and 2 workers and the storage's calls of a trial, into `result`."""
    import statistics

    from boxbox.tune.objective import run_race

    report("a race on each track first (racing lines computed once and cached)")
    for i in range(len(base.tracks)):
        run_race(base, i, {}, None)
    walls: dict[int, list[tuple[float, float]]] = {1: [], 2: []}
    stores: dict[str, list[float]] = {"journal file": [], "PostgreSQL": []}
    for r in range(result.rounds):
        for workers in (1, 2):
            report(f"round {r + 1} of {result.rounds}: {base.trials} trials with {workers} worker(s)")
            walls[workers].append(time_workers(base, workers))
        report(f"round {r + 1} of {result.rounds}: storage calls of a trial")
        stores["journal file"].append(time_storage(base, None, storage_trials)[0])
        if postgres_url is not None:
            ms, result.statements["PostgreSQL"] = time_storage(base, postgres_url, storage_trials)
            stores["PostgreSQL"].append(ms)
    for workers, pairs in walls.items():
        result.trial_wall_s[workers] = statistics.median(p[0] for p in pairs)
        result.run_wall_s[workers] = statistics.median(p[1] for p in pairs)
        result.all_trial_wall_s[workers] = [round(p[0], 2) for p in pairs]
    result.storage_ms = {name: statistics.median(v) for name, v in stores.items() if v}
    if postgres_url is not None:
        result.round_trip_ms = round_trip_ms(postgres_url)


def summary_rows(result: BenchTuneResult) -> list[tuple[str, str]]:
    if not result.trial_wall_s:
        return []  # the generalisation studies only
    rows = [(f"trials per hour, {w} worker(s)", f"{result.per_hour(w):.0f} ({result.trials} trials in "
             f"{result.trial_wall_s[w]:.1f} s, median of {', '.join(f'{x:.1f}' for x in result.all_trial_wall_s[w])}; "
             f"{result.run_wall_s[w]:.1f} s with start-up)") for w in (1, 2)]
    fastest = min(result.all_trial_wall_s[1]) / min(result.all_trial_wall_s[2])
    rows.append(("speed-up with 2 workers", f"{result.per_hour(2) / result.per_hour(1):.2f}x (medians; "
                                            f"{fastest:.2f}x between the fastest rounds)"))
    rows.append(("mean trial (1 worker)", f"{result.mean_trial_s:.2f} s"))
    for name, ms in result.storage_ms.items():
        extra = f", {result.statements[name]} SQL statements" if name in result.statements else ""
        rows.append((f"storage per trial, {name}", f"{ms:.1f} ms ({100 * ms / 1000 / result.mean_trial_s:.2f} % "
                                                   f"of a trial{extra})"))
    if result.round_trip_ms is not None:
        rows.append(("PostgreSQL round trip (SELECT 1)", f"{result.round_trip_ms:.2f} ms"))
    return rows
