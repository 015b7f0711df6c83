"""`boxbox bench`, `bench-table` and the other benchmarks (in boxbox.bench)."""

from __future__ import annotations

import os

import click

from boxbox.cli.common import err, out, ready
from boxbox.cli.types import (
    LAPS,
    BenchRunFile,
    CommaList,
    FieldRunFile,
    GridPosition,
    LapLengths,
    OutputFile,
    WholeNumber,
    bench_race_options,
    cluster_option,
    need_ray,
    skill_level_option,
    step_budget_option,
)

DEFAULT_TRACKS = "e-track-2,e-track-4,mixed-2,g-track-1,aalborg,michigan"
DEFAULT_ROBOTS = "boxbox,bt:2,berniw:3,inferno:3,olethros:2"
JOBS = WholeNumber(1, 64)


@click.command("bench")
@click.option("--tracks", type=CommaList("TRACK,..."), default=DEFAULT_TRACKS, show_default=True,
              help="Tracks, comma separated, or 'all'.")
@click.option("--cars", type=CommaList("CAR,..."), default="car1-trb1", show_default=True,
              help="Cars, comma separated, or 'all': the Python robots drive each, and each TORCS robot module "
                   "races its index that drives that car (drivers/NAME/NAME.xml), or sits that car out.")
@click.option("--robots", type=CommaList("ROBOT,..."), default=DEFAULT_ROBOTS, show_default=True,
              help="Python robots (boxbox, middle, path/file.py:Class, module:Class) "
                   "and TORCS robots (module:idx, see `boxbox robots`), comma separated.")
@click.option("--laps", type=LAPS, default=3, show_default=True, help="Race length in laps.")
@click.option("--together", is_flag=True, help="All robots in one race per track and car (default: each alone).")
@click.option("--jobs", type=JOBS, default=None, help="Races run in parallel (default: the number of CPUs).")
@cluster_option
@bench_race_options
@click.option("--json", "json_file", type=OutputFile(), help="Write the rows as JSON.")
@click.option("--csv", "csv_file", type=OutputFile(), help="Write the rows as CSV.")
@click.option("--against", type=BenchRunFile(),
              help="An earlier run's --json file with the same tracks, cars and laps: the judged table set "
                   "against it (misses, damage, summed time per car, the cells that moved most).")
@click.option("--grid-position", type=GridPosition(), default=None,
              help="With --together: the Python robots' grid slot, 1 (pole, the default) .. or 'last'.")
@click.option("--no-limit", is_flag=True, help="Skip the limit lap per track (`boxbox limit`) and the gaps to it.")
@skill_level_option
@step_budget_option
def bench(tracks, cars, robots, laps, together, jobs, cluster, no_cache, learning, settings, json_file, csv_file,
          against, grid_position, no_limit, skill_level, step_budget_ms) -> None:
    """Race robots on tracks (each alone by default) and compare times; results are cached.

    \b
    Examples:
      boxbox bench --tracks e-track-2 --laps 30
      boxbox bench --robots boxbox,my_robot.py:MyRobot --tracks all --json b.json
      boxbox bench --cars all --json new.json --against base.json
    """
    from boxbox.bench.solo import BenchSpec, expand_all, plan, run_bench
    from boxbox.report.replay import replay_line
    from boxbox.robot.params import parse_set
    from boxbox.torcs import catalog

    need_ray(cluster)
    overlay = ready()  # first: 'all' and every name are read from the installed TORCS
    spec = BenchSpec(tracks=expand_all(tracks, list(catalog.tracks())), cars=expand_all(cars, catalog.cars()),
                     robots=robots, laps=laps, together=together, jobs=jobs or os.cpu_count() or 1,
                     use_cache=not no_cache, learning=learning, settings=parse_set(settings) if settings else None,
                     skill_level=skill_level, grid_position=_grid_slot(grid_position, robots, together),
                     limit=not no_limit, match_cars=True, step_budget_ms=int(step_budget_ms), cluster=cluster)
    if against is not None:
        _check_bench_against(against, {"laps": spec.laps, "tracks": spec.tracks, "cars": spec.cars,
                                       "robots": spec.robots},
                             "race the same --tracks, --cars and --laps as it, or leave --against out.")
    plan(spec)  # every name checked before anything races
    result = run_bench(spec, overlay, err)
    out.print(result.table())
    if len(result.tracks) > 1 or len(result.cars) > 1:
        out.print(result.summary_table())
    _print_judged(result.to_json(), against)
    # the last line says how to watch a race of it (tests/integration/test_replay.py)
    out.print(replay_line(r["run_dir"] for r in result.rows), markup=False, highlight=False, soft_wrap=True)
    failed = sum(1 for r in result.rows if r["error"])
    err.print(f"[dim]{result.raced} raced, {result.cached} cached, {result.wall_s:.1f} s wall"
              + (f"; [red]{failed} rows with errors[/]" if failed else "") + "[/]")
    if json_file:
        result.write_json(json_file)
    if csv_file:
        result.write_csv(csv_file)


def _check_bench_against(against, run: dict, what_to_do: str) -> None:
    """Exit 2 (before any race) when the base run cannot be set cell by cell against this one."""
    from boxbox.bench.judged_compare import mismatch

    path, base = against
    why = mismatch(base, run)
    if why:
        raise click.BadParameter(f"{path}: {why}; {what_to_do}", param_hint="--against")


def _print_judged(doc: dict, against=None, markdown: bool = False) -> None:
    """The judged table of each Python robot of a bench document (none: nothing), and its comparison."""
    from boxbox.bench.judged_compare import compare_docs
    from boxbox.bench.judged_table import judged_tables, python_robots

    if not python_robots(doc):
        return
    for table in judged_tables(doc):
        if markdown:
            out.print(table.markdown(), markup=False, highlight=False, soft_wrap=True)
        else:
            out.print(table.grid())
            if len(table.cars) > 1:
                out.print(table.per_car())
        out.print(table.summary_line(), markup=False, highlight=False, soft_wrap=True)
    if against is None:
        return
    path, base = against
    for comparison in compare_docs(base, doc):
        out.print(comparison.per_car(path.name))
        out.print(comparison.moved_table(path.name))
        for line in comparison.lines(path.name):
            out.print(line, markup=False, highlight=False, soft_wrap=True)


@click.command("bench-table")
@click.argument("run", type=BenchRunFile())
@click.option("--against", type=BenchRunFile(),
              help="An earlier `boxbox bench --json` file of the same tracks, cars and laps to set FILE against.")
@click.option("--markdown", is_flag=True, help="The table as docs/pace.md writes it (misses in bold).")
def bench_table(run, against, markdown) -> None:
    """The judged table of a `boxbox bench --json` file, without racing: the misses, damage, summed time per car.

    \b
    A cell misses when the robot did not finish, took 100 damage or more on a road or oval track,
    or was no faster than a Debian robot in that car.
    Examples:
      boxbox bench-table cars.json
      boxbox bench-table new.json --against base.json
    """
    _, doc = run
    if against is not None:
        _check_bench_against(against, doc, "give two runs of the same tracks, cars and laps.")
    _print_judged(doc, against, markdown)


def _grid_slot(position: int | str | None, robots: list[str], together: bool) -> int | None:
    """The Python robots' grid slot in a race --together ('last': behind every TORCS robot)."""
    from boxbox.bench.solo import classify_robot
    from boxbox.torcs import checks

    if position is None:
        return None
    if not together:
        raise click.UsageError("--grid-position needs --together (alone, every robot starts from pole)")
    opponents = sum(classify_robot(r)[0] == "torcs" for r in robots)
    return checks.check_grid_position(position, opponents)


@click.command("bench-speed")
@click.option("--track", default="g-track-1", show_default=True, help="Track name, e.g. e-track-2.")
@click.option("--laps", type=LAPS, default=20, show_default=True, help="Race length in laps.")
@click.option("--runs", type=WholeNumber(1, 50), default=3, show_default=True, help="Races per robot.")
@click.option("--robot", default="boxbox", show_default=True, help="Python robot to time, e.g. my_robot.py:MyRobot.")
@click.option("--against", default="bt:2", show_default=True, help="TORCS robot to compare with, e.g. berniw:3.")
@skill_level_option
def bench_speed(track, laps, runs, robot, against, skill_level) -> None:
    """Wall time of a Python robot's race against a C++ robot's, alternating runs; step times.

    Example: boxbox bench-speed --runs 5
    """
    from boxbox.bench.speed import run_speed_bench

    overlay = ready()
    out.print(run_speed_bench(overlay, track, laps, runs, robot, against, err, skill_level))


@click.command("bench-pits")
@click.option("--tracks", type=CommaList("TRACK,..."), default="g-track-1,e-track-2,e-track-4,aalborg",
              show_default=True, help="Tracks with a pit lane, comma separated.")
@click.option("--laps", type=WholeNumber(2, 10_000), default=6, show_default=True,
              help="Race length; stops are asked on every lap but the last.")
@click.option("--jobs", type=JOBS, default=2, show_default=True, help="Races run in parallel.")
@click.option("--json", "json_file", type=OutputFile(), help="Write the rows as JSON.")
@skill_level_option
def bench_pits(tracks, laps, jobs, json_file, skill_level) -> None:
    """Compare the two ways into the box (constant-decel, bang-bang) on real races.

    Example: boxbox bench-pits --tracks aalborg --laps 4
    """
    from boxbox.bench.pits import run_pit_bench
    from boxbox.files import write_json_atomic

    overlay = ready()
    table, rows = run_pit_bench(overlay, tracks, laps, jobs, err, skill_level)
    out.print(table)
    if json_file:
        write_json_atomic(json_file, rows, indent=1)


@click.command("bench-learning")
@click.option("--tracks", type=CommaList("TRACK,..."), default=DEFAULT_TRACKS, show_default=True,
              help="Tracks, comma separated.")
@click.option("--races", type=WholeNumber(2, 50), default=5, show_default=True,
              help="Races in a row per track on one learning store.")
@click.option("--laps", type=LAPS, default=3, show_default=True, help="Race length in laps.")
@click.option("--robot", default="boxbox", show_default=True, help="Python robot that learns.")
@click.option("--jobs", type=JOBS, default=None, help="Tracks raced in parallel (default: the number of CPUs).")
@click.option("--json", "json_file", type=OutputFile(), help="Write the races as JSON.")
@skill_level_option
def bench_learning(tracks, races, laps, robot, jobs, json_file, skill_level) -> None:
    """Race each track several times in a row on one learning store: is the last race as fast as the first?

    Example: boxbox bench-learning --tracks g-track-1,aalborg --races 5
    """
    from boxbox.bench.learning import run_learning_bench
    from boxbox.files import write_json_atomic
    from boxbox.robot.loader import load_robot_class

    overlay = ready()
    load_robot_class(robot)
    table, series = run_learning_bench(overlay, tracks, laps, races, robot, jobs or os.cpu_count() or 1, err,
                                       skill_level)
    out.print(table)
    if json_file:
        write_json_atomic(json_file, series, indent=1)


@click.command("bench-telemetry")
@click.option("--track", default="g-track-1", show_default=True, help="Track name, e.g. e-track-2.")
@click.option("--laps", type=LAPS, default=20, show_default=True, help="Race length in laps.")
@click.option("--runs", type=WholeNumber(1, 50), default=5, show_default=True,
              help="Races with telemetry on, and as many with it off.")
@click.option("--robot", default="boxbox", show_default=True, help="Python robot to time.")
@click.option("--json", "json_file", type=OutputFile(), help="Write the figures as JSON.")
@skill_level_option
def bench_telemetry(track, laps, runs, robot, json_file, skill_level) -> None:
    """Drive step time with telemetry recorded and without, and their ratio (alternating races).

    Example: boxbox bench-telemetry --runs 3 --laps 10
    """
    from rich.progress import Progress

    from boxbox.bench.telemetry import run_telemetry_bench, summary_lines, table
    from boxbox.files import write_json_atomic

    overlay = ready()
    with Progress(console=err, transient=True) as bar:
        task = bar.add_task(f"{track}, {laps} laps, telemetry on/off", total=2 * runs)
        res = run_telemetry_bench(overlay, track, laps, runs, robot, lambda: bar.advance(task), skill_level)
    out.print(table(res))
    for line in summary_lines(res):
        out.print(line)
    if json_file:
        write_json_atomic(json_file, res, indent=1)


@click.command("bench-field")
@click.option("--tracks", type=CommaList("TRACK,..."), default=DEFAULT_TRACKS, show_default=True,
              help="Tracks, comma separated, or 'all'.")
@click.option("--robot", default="boxbox", show_default=True, help="Python robot under test, e.g. my_robot.py:MyRobot.")
@click.option("--laps", type=LapLengths(), default="10", show_default=True,
              help="Race length in laps, or several (8,10,12 or 6-14: a summary per track over them).")
@click.option("--jobs", type=JOBS, default=1, show_default=True, help="Races run in parallel.")
@cluster_option
@click.option("--repeats", type=WholeNumber(1, 20), default=1, show_default=True,
              help="Race each length this many times, the robot's start fuel 0.05 l more each time (less "
                   "where the tank is full): the spread of places that is the field's chaos, not the robot.")
@bench_race_options
@click.option("--json", "json_file", type=OutputFile(), help="Write the rows as JSON.")
@click.option("--against", type=FieldRunFile(),
              help="An earlier run's --json file with the same tracks, laps and repeats: the robot's races "
                   "set against it race by race, with how much of the difference chance alone makes.")
@skill_level_option
@step_budget_option
def bench_field(tracks, robot, laps, jobs, cluster, repeats, no_cache, learning, settings, json_file, against,
                skill_level, step_budget_ms) -> None:
    """The robot from last of ten behind nine TORCS robots, and inferno:3 from the same slot.

    \b
    Grid: inferno:4, berniw:3, bt:2, olethros:2, lliaw:3, tita:3, damned:6, bt:3, berniw:4, then
    the robot; the anchor race puts inferno:3 (car1-trb1, like the robot) in its slot.
    Examples:
      boxbox bench-field
      boxbox bench-field --tracks g-track-1 --laps 5 --json f.json
      boxbox bench-field --laps 6-14 --jobs 2     # 54 races each: places per length and track
      boxbox bench-field --repeats 5 --jobs 2     # each race 5 times: how much is chance
      boxbox bench-field --repeats 5 --set side_margin_m=0.5 --against base.json
    """
    from boxbox.bench.field import FieldSpec, run_field, runs_root
    from boxbox.bench.solo import expand_all
    from boxbox.report.replay import replay_line
    from boxbox.robot.params import parse_set
    from boxbox.torcs import catalog

    need_ray(cluster)
    overlay = ready()
    spec = FieldSpec(tracks=expand_all(tracks, list(catalog.tracks())), robot=robot, laps=laps[0], jobs=jobs,
                     use_cache=not no_cache, learning=learning, settings=parse_set(settings) if settings else None,
                     skill_level=skill_level, step_budget_ms=int(step_budget_ms), cluster=cluster)
    if against is not None:
        _check_against(against, spec.tracks, laps, repeats)
    if len(laps) > 1 or repeats > 1:
        _field_grid(spec, laps, overlay, json_file, repeats, against)
        return
    result = run_field(spec, overlay, err)
    out.print(result.table())
    out.print(result.summary_line())
    out.print(replay_line((r["run_dir"] for r in result.rows), "the run dir column, under the folder below"),
              markup=False, highlight=False, soft_wrap=True)
    err.print(f"[dim]run dirs (for `boxbox report`) under {runs_root()}[/]")
    failed = sum(1 for r in result.rows if r["error"])
    err.print(f"[dim]{result.raced} raced, {result.cached} cached, {result.wall_s:.1f} s wall"
              + (f"; [red]{failed} rows with errors[/]" if failed else "") + "[/]")
    if json_file:
        result.write_json(json_file)
    if against is not None:
        _print_against(against, result.to_json())


def _check_against(against, tracks: list[str], lengths: list[int], repeats: int) -> None:
    """Exit 2 before any race when the base run did not race these tracks, lengths and repeats."""
    from boxbox.bench.field_compare import shape_of

    path, doc = against
    want = [(n, tuple(tracks)) for n in lengths for _ in range(repeats)]
    if shape_of(doc) != want:
        raise click.BadParameter(f"{path} raced other tracks, laps or repeats; race the same --tracks, --laps and "
                                 "--repeats as it, or leave --against out.", param_hint="--against")


def _print_against(against, doc: dict) -> None:
    from boxbox.bench.field_compare import compare

    path, base = against
    comparison = compare(base, doc)
    out.print(comparison.table(path.name))
    for line in comparison.lines(path.name):
        out.print(line)


def _field_grid(spec, lengths: list[int], overlay, json_file, repeats: int, against=None) -> None:
    """bench-field at several lengths or repeats: the places per track and race, wins and damage."""
    from boxbox.bench.field import runs_root
    from boxbox.bench.field_grid import run_field_grid
    from boxbox.report.replay import replay_line

    grid = run_field_grid(spec, lengths, overlay, err, repeats)
    out.print(grid.table())
    for line in grid.summary_lines():
        out.print(line)
    out.print(replay_line(r["run_dir"] for res in grid.results for r in res.rows), markup=False, highlight=False,
              soft_wrap=True)
    err.print(f"[dim]run dirs (for `boxbox report`) under {runs_root()}[/]")
    raced, cached = sum(r.raced for r in grid.results), sum(r.cached for r in grid.results)
    wall = grid.results[0].wall_s  # the batch's: every run's races raced together
    err.print(f"[dim]{raced} raced, {cached} cached, {wall:.1f} s wall[/]")
    if json_file:
        grid.write_json(json_file)
    if against is not None:
        _print_against(against, grid.to_json())
