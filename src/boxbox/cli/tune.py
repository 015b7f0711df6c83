"""`boxbox tune` and `boxbox bench-tune`."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import click

from boxbox.cli.common import err, out, ready
from boxbox.cli.types import (
    LAPS,
    Choice,
    CommaList,
    FiniteFloatRange,
    OutputDir,
    OutputFile,
    WholeNumber,
    skill_level_option,
)
from boxbox.tune.pick import RADIUS, PickRule  # (pick.py loads nothing heavy: `boxbox --help` reads this)


class StudyName(click.ParamType):
    name = "study"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "NAME"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}", str(value)):
            self.fail(f"{value!r}: a study name takes letters, digits, '.', '_' and '-', e.g. g1-mu.", param, ctx)
        return str(value)


class SetupFile(OutputFile):
    """--setup-out: an output file whose missing folder is made, as --report's folder is (the
    folder above that exists must take it)."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        path = Path(os.path.abspath(os.path.expanduser(value)))
        if path.parent.exists():
            return super().convert(value, param, ctx)
        OutputDir().convert(str(path.parent), param, ctx)
        return path


class StorageURL(click.ParamType):
    """postgresql://USER@HOST/DB or sqlite:///FILE (checked for its form here, reached later)."""

    name = "url"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "URL"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from boxbox.errors import UsageError
        from boxbox.tune.storage import sqlalchemy_url

        try:
            sqlalchemy_url(str(value))
        except UsageError as exc:
            self.fail(str(exc).removeprefix("--storage: "), param, ctx)
        return str(value)


@click.command()
@click.option("--robot", default="boxbox", show_default=True, metavar="SPEC",
              help="The robot to tune: NAME, path/file.py:Class or module:Class (it declares its parameters).")
@click.option("--tracks", type=CommaList("TRACK,..."), default="g-track-1", show_default=True,
              help="Tracks each trial races, e.g. e-track-2,g-track-1,aalborg.")
@click.option("--params", "param_names", type=CommaList("NAME,..."), required=True,
              help="Parameters to search, e.g. mu_scale,brake_mu_scale (ranges from the robot's declaration).")
@click.option("--trials", type=WholeNumber(1, 100_000), default=20, show_default=True,
              help="Finished trials (complete or pruned) the study should hold, counted over every worker.")
@click.option("--laps", type=LAPS, default=2, show_default=True, help="Laps of each race.")
@click.option("--car", default="car1-trb1", show_default=True, help="The robot's car.")
@click.option("--study", "study_name", type=StudyName(), default=None,
              help="Study name; an existing study resumes (default: from robot, tracks, params and laps).")
@click.option("--storage", type=StorageURL(), default=None,
              help="postgresql://USER@HOST/DB to share the study between machines (default: a journal file "
                   "in the cache, ~/.cache/boxbox/tune/NAME.log).")
@click.option("--workers", type=WholeNumber(1, 64), default=1, show_default=True,
              help="Local worker processes (each races on its own core).")
@click.option("--grace-s", type=WholeNumber(2, 86_400), default=15, show_default=True,
              help="PostgreSQL: a trial whose worker sent no heartbeat for this long is failed and run again.")
@click.option("--damage-limit", type=FiniteFloatRange(0, 100_000), default=500, show_default=True,
              help="A race that ends with more damage counts as a penalty.")
@click.option("--seed", type=WholeNumber(0, 2**31 - 1), default=None, help="Sampler seed (one worker: repeatable).")
@click.option("--no-prune", is_flag=True, help="Race every track of every trial (no median pruner).")
@click.option("--setup-out", type=SetupFile(), default=None,
              help="Write the best parameters here as a setup (default: ~/.cache/boxbox/tune/NAME.toml); "
                   "race with them: boxbox race --setup FILE.")
@click.option("--report", "report_dir", type=OutputDir(), default=None,
              help="Write the study's HTML page (history, importances, slices) into this folder.")
@click.option("--no-compare", is_flag=True, help="Do not race the robot's own values at the end.")
@click.option("--pick", type=Choice(["robust", "fastest"]), default="robust", show_default=True,
              help="The best trial: robust = at least as fast as the robot's own values on every track without "
                   "more damage, as are the trials around it, by more than the study's noise floor, the most "
                   "gained on its worst track; fastest = the smallest total.")
@click.option("--pick-radius", type=FiniteFloatRange(0.0, 100.0, min_open=True), default=100 * RADIUS,
              show_default=True,
              metavar="PERCENT", help="robust: the trials with each value within this share of its range are "
                                      "around a trial; they must not lose either, and their differences make the "
                                      "noise floor a gain must pass.")
@skill_level_option
@click.option("--quiet", is_flag=True, help="No progress bar.")
def tune(robot, tracks, param_names, trials, laps, car, study_name, storage, workers, grace_s, damage_limit, seed,
         no_prune, setup_out, report_dir, no_compare, pick, pick_radius, skill_level, quiet) -> None:
    """Tune a robot's parameters with Optuna: each trial races the tracks; the value is the total time.

    \b
    Examples:
      boxbox tune --tracks e-track-2,g-track-1,aalborg --params mu_scale,brake_mu_scale --trials 100 --laps 3
      boxbox tune --params mu_scale --workers 2 --report out/
      boxbox tune --storage postgresql://me@db-host/tune --study road --params mu_scale   # on every machine
    """
    from boxbox.errors import Interrupted, UsageError
    from boxbox.robot.loader import load_robot_class
    from boxbox.torcs import checks
    from boxbox.tune import study as studies
    from boxbox.tune.objective import TuneConfig
    from boxbox.tune.space import distributions, tune_space
    from boxbox.tune.storage import Storage, describe

    if not tracks:
        raise UsageError("--tracks: name at least one track, e.g. g-track-1")
    cls = load_robot_class(robot)
    distributions(tune_space(cls, car, robot), param_names)  # unknown or unsearchable names: exit 2 here
    name = study_name or _default_name(cls.name, tracks, param_names, laps)
    cfg = TuneConfig(study=name, robot=robot, tracks=tracks, params=param_names, laps=laps, car=car, trials=trials,
                     damage_limit=damage_limit, skill_level=skill_level.torcs_name, storage=storage, seed=seed,
                     prune=not no_prune, heartbeat_s=max(1, grace_s // 3), grace_s=grace_s)
    if storage is not None:
        Storage(storage, name)  # a database that cannot be reached: exit 2 before TORCS is set up
    ready()
    cfg.categories = [checks.check_race(t, car, 1, (), (), laps)[0] for t in tracks]
    err.print(f"[dim]study {name} in {describe(storage, name)}: {trials} trials x {len(tracks)} tracks x "
              f"{laps} laps, {workers} worker(s)[/]")
    stop = studies.StopFlag()
    stop.install()
    outcome = _run_with_progress(cfg, workers, stop, quiet)
    # a lost worker costs the study nothing the others made up: summary, setup and report as ever
    compare = not (no_compare or stop.set) and outcome.complete(trials)
    _summary(cfg, outcome.study, setup_out, report_dir, compare=compare, pick=PickRule(pick, pick_radius / 100.0))
    if stop.set:
        raise Interrupted(f"tune stopped by a signal; the study keeps its finished trials: resume with --study {name}")
    outcome.check(cfg)  # then the one line on the workers lost (exit 5, or 1 if the study is short)


def _default_name(robot: str, tracks: list[str], params: list[str], laps: int) -> str:
    text = f"{robot}-{'+'.join(tracks)}-{'+'.join(sorted(params))}-{laps}l"
    text = re.sub(r"[^A-Za-z0-9._+-]", "_", text).replace("+", ".")
    return text[:100]


def _run_with_progress(cfg, workers: int, stop, quiet: bool):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from boxbox.tune import study as studies
    from boxbox.tune import study_figures

    if quiet:
        return studies.run(cfg, workers, lambda s: None, stop)
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("trials"),
                  TextColumn("{task.fields[note]}"), TimeElapsedColumn(), console=err) as bar:
        task = bar.add_task(f"tune {cfg.study[:40]}", total=cfg.trials, note="")

        def tick(study) -> None:
            p = study_figures.progress(study)
            best = "-" if p.best_value is None else f"{p.best_value:.3f} s"
            bar.update(task, completed=min(p.finished, cfg.trials),
                       note=f"best {best}, {p.pruned} pruned, {p.running} running, {p.failed} failed")

        return studies.run(cfg, workers, tick, stop)


def _summary(cfg, study, setup_out: Path | None, report_dir: Path | None, compare: bool, pick: PickRule) -> None:
    from rich.table import Table

    from boxbox.robot.loader import load_robot_class
    from boxbox.robot.tunable import write_setup
    from boxbox.tune import study_figures
    from boxbox.tune.space import tune_space
    from boxbox.tune.storage import journal_path

    p = study_figures.progress(study)
    skipped, run, saved_s = study_figures.pruning_savings(study, len(cfg.tracks))
    err.print(f"{p.complete} complete, {p.pruned} pruned, {p.failed} failed trials; pruning skipped {skipped} of "
              f"{skipped + run} races (about {saved_s:.0f} s of racing saved)")
    chosen = pick.choose(study, cfg)
    if chosen.trial is None:
        err.print("[yellow]no complete trial yet: nothing to compare or write[/]")
        return
    best = chosen.trial
    err.print(f"best ({pick.how}): trial #{best.number}, {chosen.why}")
    space = tune_space(load_robot_class(cfg.robot), cfg.car)
    params = Table("parameter", "declared default", "best", title=f"study {cfg.study}: best trial #{best.number}")
    for key, value in best.params.items():
        params.add_row(key, _fmt(space.defaults[key]), _fmt(value))
    out.print(params)
    if compare:
        _compare_table(cfg, best.params)
    target = setup_out or journal_path(cfg.study).with_suffix(".toml")
    target.parent.mkdir(parents=True, exist_ok=True)
    write_setup(target, best.params, [f"boxbox tune study {cfg.study}: best ({pick.label}) of {p.complete} "
                                      "complete trials",
                                      f"robot {cfg.robot}, tracks {', '.join(cfg.tracks)}, {cfg.laps} laps, "
                                      f"{cfg.car}: total {best.value:.3f} s"], robot=cfg.robot)
    err.print(f"setup: {target}")
    if report_dir is not None:
        from boxbox.tune.report import write_report

        err.print(f"report: {write_report(study, cfg, report_dir / 'report.html', pick)}")


def _compare_table(cfg, best: dict) -> None:
    """Race the robot's own values and the best on each track; print both times."""
    from rich.table import Table

    from boxbox.report.tables import fmt_time
    from boxbox.tune import study as studies

    with err.status("racing the robot's own values for comparison") as status:
        rows = studies.compare(cfg, {"best": best}, on_race=lambda t, label: status.update(f"{t}: {label}"))
    # the best trial's own races give its times (races are deterministic); the comparison re-races both
    times = Table("track", "robot's own values (s)", "best (s)", "gain (s)",
                  title=f"{cfg.laps} lap(s) each, {cfg.car}, {cfg.skill_level}")
    for row in rows:
        times.add_row(row["track"], fmt_time(row["defaults"]) + _flag(row["defaults_problem"]),
                      fmt_time(row["best"]) + _flag(row["best_problem"]), f"{row['defaults'] - row['best']:+.3f}")
    total_d, total_b = sum(r["defaults"] for r in rows), sum(r["best"] for r in rows)
    times.add_row("total", fmt_time(total_d), fmt_time(total_b), f"{total_d - total_b:+.3f}")
    out.print(times)


def _fmt(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def _flag(problem: str | None) -> str:
    return f" ({problem})" if problem else ""


GENERAL_A = "g-track-1,e-track-2,aalborg"  # the tuning set of the example
GENERAL_B = "e-track-4,g-track-2,ruudskogen"  # road tracks of similar kind the study never sees


@click.command("bench-tune")
@click.option("--robot", default="boxbox", show_default=True, metavar="SPEC", help="The robot to tune.")
@click.option("--tracks", type=CommaList("TRACK,..."), default=GENERAL_A, show_default=True,
              help="Tracks of each trial in the worker and storage measures.")
@click.option("--params", "param_names", type=CommaList("NAME,..."), default="mu_scale,brake_mu_scale",
              show_default=True, help="Parameters searched.")
@click.option("--laps", type=LAPS, default=3, show_default=True, help="Laps of each race.")
@click.option("--trials", type=WholeNumber(2, 10_000), default=8, show_default=True,
              help="Trials of the 1- and 2-worker runs.")
@click.option("--storage-trials", type=WholeNumber(1, 10_000), default=30, show_default=True,
              help="Trials whose storage calls are timed, per storage.")
@click.option("--storage", type=StorageURL(), default=None,
              help="PostgreSQL to time (default: a server started for the bench in a temporary folder).")
@click.option("--no-postgres", is_flag=True, help="Time the journal file only.")
@click.option("--general-trials", type=WholeNumber(0, 10_000), default=0, show_default=True,
              help="Trials of each generalisation study (0: none; the issue asks 50).")
@click.option("--general-tracks", nargs=2, type=CommaList("TRACK,..."), default=(GENERAL_A, GENERAL_B),
              show_default=True, help="The two sets of tracks: tune on each, race the best on both.")
@click.option("--rounds", type=WholeNumber(1, 100), default=3, show_default=True,
              help="Times each measure is taken, in turn; the median is shown (the machine's load moves).")
@click.option("--general-only", is_flag=True,
              help="Only the generalisation studies (no trials per hour, no storage measure).")
@click.option("--json", "json_file", type=OutputFile(), help="Write the figures as JSON.")
def bench_tune(robot, tracks, param_names, laps, trials, storage_trials, storage, no_postgres, general_trials,
               general_tracks, rounds, general_only, json_file) -> None:
    """Measure boxbox tune: trials per hour with 1 and 2 workers, the storage's cost per trial
    (journal file against PostgreSQL) and, with --general-trials, tuned parameters on unseen tracks.

    \b
    Examples:
      boxbox bench-tune
      boxbox bench-tune --general-trials 50 --json bench-tune.json
      boxbox bench-tune --general-trials 50 --general-only
    """
    import contextlib
    import dataclasses

    from rich.table import Table

    from boxbox.files import write_json_atomic
    from boxbox.robot.loader import load_robot_class
    from boxbox.robot.tunable import param_space
    from boxbox.torcs import checks
    from boxbox.tune.bench_tune import run_bench, summary_rows
    from boxbox.tune.objective import TuneConfig
    from boxbox.tune.postgres import TempServer
    from boxbox.tune.space import distributions

    distributions(param_space(load_robot_class(robot)), param_names)
    if general_only and not general_trials:
        raise click.UsageError("--general-only needs --general-trials N (the issue asks 50)")
    ready()
    for t in [*tracks, *general_tracks[0], *general_tracks[1]]:
        checks.check_race(t, "car1-trb1", 1, (), (), laps)
    base = TuneConfig(study="bench", robot=robot, tracks=tracks, params=param_names, laps=laps, trials=trials,
                      seed=7, categories=[checks.check_race(t, "car1-trb1", 1, (), (), laps)[0] for t in tracks])
    with contextlib.ExitStack() as stack, err.status("bench-tune") as status:
        def report(msg: str) -> None:
            status.update(msg)
            err.print(f"[dim]bench-tune:[/] {msg}")

        url = storage
        if url is None and not (no_postgres or general_only):
            url = stack.enter_context(TempServer(report)).url
        result = run_bench(base, storage_trials, url, general_trials, tuple(general_tracks), report, rounds,
                           costs=not general_only)
    table = Table("measure", "value", title=f"bench-tune: {robot}, {', '.join(tracks)}, {laps} lap(s), "
                                             f"{', '.join(param_names)}")
    for row in summary_rows(result):
        table.add_row(*row)
    if table.rows:
        out.print(table)
    if result.general:
        _general_table(result.general, laps)
    if json_file:
        write_json_atomic(json_file, dataclasses.asdict(result), indent=1)


def _general_table(rows: list[dict], laps: int) -> None:
    from rich.table import Table

    from boxbox.report.tables import fmt_time
    from boxbox.tune.pick import GENERAL_PICKS as PICKS

    table = Table("tuned on", "track", "", "robot's own values (s)", *(f"{h} pick (s), gain" for h in PICKS),
                  title=f"generalisation: {laps} lap(s) a race, the best of each study by each pick")
    for r in rows:
        cells = [fmt_time(r[h]) + _flag(r[f"{h}_problem"]) + f", {r['defaults'] - r[h]:+.3f}" if h in r else "-"
                 for h in PICKS]
        table.add_row(r["train"], r["track"], r["set"], fmt_time(r["defaults"]) + _flag(r["defaults_problem"]),
                      *cells)
    out.print(table)
    for train in dict.fromkeys(r["train"] for r in rows):
        first = next(r for r in rows if r["train"] == train)
        for how, params in first["best_params"].items():
            out.print(f"{how} pick of {train}: trial #{first['picked'][how]}, "
                      + ", ".join(f"{k}={_fmt(v)}" for k, v in params.items()) + f" ({first['why'][how]})")
