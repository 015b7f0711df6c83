"""One trial of a study: the robot with the trial's parameters raced on each track in turn.

The value is the total race time over the tracks.  A race that faults, does not finish or ends
with more damage than the limit counts as a penalty time instead (PENALTY_S_PER_LAP a lap), so a
bad corner of the search space is a poor value, never a crash of the worker.  The running total
is reported after every track, and the pruner is asked then (races are what a trial is made of:
it stops between them).
"""

from __future__ import annotations

import json
import socket
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from boxbox.errors import BoxboxError, Interrupted
from boxbox.tune.storage import worker_alive, worker_tag

# a lap that does not count: well beyond any lap of TORCS's tracks by the boxbox robot (spring, 22 km,
# takes about 450 s), so a penalised trial always ranks below one that finishes
PENALTY_S_PER_LAP = 1000.0


RESULT_ATTR = "result"  # a trial's races (RaceScore each), races skipped by pruning, wall time


class TrialInterrupted(Interrupted):
    """Ctrl-C, SIGTERM or SIGHUP stopped a race of the trial: the trial fails, the worker stops."""


class RaceLost(BoxboxError):
    """A race's host was killed from outside (the OOM killer's kind of death): not the robot's
    doing, so no score; the trial fails and runs again, as a lost worker's does."""


@dataclass
class TuneConfig:
    """What a study's trials race (one JSON object: it is handed to worker processes as is)."""

    study: str
    robot: str = "boxbox"
    tracks: list[str] = field(default_factory=lambda: ["g-track-1"])
    categories: list[str] = field(default_factory=list)  # filled by the checks, one per track
    params: list[str] = field(default_factory=list)
    laps: int = 3
    car: str = "car1-trb1"
    trials: int = 20
    damage_limit: float = 500.0
    skill_level: str = "semi-pro"
    storage: str | None = None  # None: the journal file in the cache
    seed: int | None = None
    step_budget_ms: int = 200
    prune: bool = True
    heartbeat_s: int = 5  # PostgreSQL: a trial whose worker has not beaten for grace_s is retried
    grace_s: int = 15
    max_retry: int = 3

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> TuneConfig:
        return cls(**json.loads(text))


@dataclass
class RaceScore:
    track: str
    score_s: float  # race time, or the penalty
    time_s: float
    laps: int
    damage: int
    wall_s: float
    problem: str | None = None  # why it was penalised
    lap_times: list[float] = field(default_factory=list)


def score_race(result: Any, laps: int, damage_limit: float) -> RaceScore:
    """A race's contribution to the trial's value."""
    driver = next((d for d in result.drivers if d.is_python), None)
    penalty = PENALTY_S_PER_LAP * laps
    base = dict(track=result.track, wall_s=round(result.wall_s, 3))
    if driver is None:
        return RaceScore(score_s=penalty, time_s=0.0, laps=0, damage=0, problem=_first_line(result.error), **base)
    base.update(time_s=driver.time, laps=driver.laps, damage=driver.damage, lap_times=list(driver.lap_times))
    if result.error:
        return RaceScore(score_s=penalty, problem=f"fault: {_first_line(result.error)}", **base)
    if driver.laps < laps:
        return RaceScore(score_s=penalty, problem=f"did not finish ({driver.laps} of {laps} laps)", **base)
    if driver.damage > damage_limit:
        return RaceScore(score_s=penalty, problem=f"damage {driver.damage} > {damage_limit:g}", **base)
    return RaceScore(score_s=driver.time, **base)


def _first_line(text: str | None) -> str:
    return (text or "no result").partition("\n")[0][:200]


def runs_root() -> Path:
    """Where trials race (CACHE/tune/runs, a folder per race named after its worker process)."""
    from boxbox.cache import cache_dir

    root = cache_dir() / "tune" / "runs"
    root.mkdir(parents=True, exist_ok=True)
    return root


def sweep_dead_runs() -> None:
    """Remove the race folders of workers that died (SIGKILL leaves them): pid:start of the folder's
    worker no longer running."""
    import shutil

    for folder in runs_root().iterdir():
        pid, _, rest = folder.name.partition(":")
        start = rest.partition(":")[0]
        if not worker_alive(f"{socket.gethostname()}:{pid}:{start}"):
            shutil.rmtree(folder, ignore_errors=True)


def run_race(cfg: TuneConfig, index: int, settings: dict, cpu: int | None) -> RaceScore:
    """Race the robot on cfg.tracks[index] with settings, in a temporary run dir (removed after)."""
    from boxbox.model.skill import SkillLevel
    from boxbox.robot.base import race_options
    from boxbox.robot.loader import load_robot_class
    from boxbox.torcs import launch, setup
    from boxbox.torcs.launch import HOST_KILLED, INTERRUPTED

    options = race_options(settings)
    name = f"{load_robot_class(cfg.robot).name} 1"
    with tempfile.TemporaryDirectory(dir=runs_root(), prefix=f"{worker_tag().split(':', 1)[1]}:") as tmp:
        race_cfg = launch.RaceConfig(track=cfg.tracks[index], category=cfg.categories[index], car=cfg.car,
                                     laps=cfg.laps, robots=[cfg.robot], robot_names=[name], options=options,
                                     step_budget_ms=cfg.step_budget_ms, cpu=cpu, run_dir=Path(tmp) / "race",
                                     telemetry=False, skill_level=SkillLevel.parse(cfg.skill_level),
                                     learning="fresh")
        result = launch.run_race(race_cfg, setup.ensure_ready())
    if result.error and result.error.startswith(INTERRUPTED):
        raise TrialInterrupted(result.error)
    if result.error and result.error.startswith(HOST_KILLED):
        raise RaceLost(result.error.partition("\n")[0])
    return score_race(result, cfg.laps, cfg.damage_limit)


Race = Callable[[TuneConfig, int, dict, "int | None"], RaceScore]


def make_objective(cfg: TuneConfig, dists: dict[str, Any], cpu: int | None,
                   race: Race = run_race) -> Callable[[Any], float]:
    """The Optuna objective: race every track; with pruning, report the running total after each
    track but the last and ask the pruner (without pruning nothing reads the reports, so none are
    written).  Each race's figures (lap times included) go into one trial attribute, "races",
    written once at the end: every storage write costs a round trip (docs/tuning.md).  `race`
    stands in for run_race in the bench of the storage's cost."""
    import optuna

    from boxbox.tune.space import suggest

    def objective(trial: optuna.Trial) -> float:
        settings = suggest(trial, dists)
        started = time.monotonic()
        total = 0.0
        races: list[dict] = []
        for i, track in enumerate(cfg.tracks):
            score = race(cfg, i, settings, cpu)
            total += score.score_s
            races.append(asdict(score))
            if not cfg.prune or i == len(cfg.tracks) - 1:
                continue  # the last total is the trial's value: no report needed
            trial.report(total, i)
            if trial.should_prune():
                trial.set_user_attr(RESULT_ATTR, {"races": races, "races_skipped": len(cfg.tracks) - 1 - i,
                                                  "wall_s": round(time.monotonic() - started, 3)})
                raise optuna.TrialPruned(f"after {track}: {total:.3f} s")
        trial.set_user_attr(RESULT_ATTR, {"races": races, "races_skipped": 0,
                                          "wall_s": round(time.monotonic() - started, 3)})
        return total

    return objective
