"""`boxbox sweep` and `boxbox soak`: reliability over every track and car, and over long runs."""

from __future__ import annotations

import os

import click

from boxbox.cli.common import err, out, ready
from boxbox.cli.types import (
    LAPS,
    CommaList,
    OutputFile,
    WholeNumber,
    cluster_option,
    need_ray,
    skill_level_option,
    step_budget_option,
)
from boxbox.errors import BoxboxError

RACES = WholeNumber(0, 100_000)


class SweepFailed(BoxboxError):
    """Some sweep race missed a target (exit 1; the table says which)."""

    exit_code = 1


@click.command("sweep")
@click.option("--robot", default="boxbox", show_default=True, help="Python robot to race (alone).")
@click.option("--car", default="car1-trb1", show_default=True, help="The car on every track.")
@click.option("--cars-track", default="g-track-1", show_default=True, help="The track every car races on.")
@click.option("--tracks", type=CommaList("TRACK,..."), default="all", show_default=True,
              help="Tracks for the first part, comma separated (e.g. aalborg,e-track-2) or 'all'.")
@click.option("--cars", type=CommaList("CAR,..."), default="all", show_default=True,
              help="Cars for the second part, comma separated (e.g. car1-trb1,car1-ow1) or 'all'.")
@click.option("--laps", type=LAPS, default=3, show_default=True, help="Race length in laps.")
@click.option("--jobs", type=WholeNumber(1, 64), default=None, help="Races run in parallel (default: the CPUs).")
@cluster_option
@click.option("--no-cache", is_flag=True, help="Race again even what the bench cache has.")
@click.option("--json", "json_file", type=OutputFile(), help="Write the rows as JSON.")
@click.option("--markdown", "markdown_file", type=OutputFile(),
              help="Write the table as Markdown, with the command that made it, e.g. docs/sweep.md.")
@skill_level_option
@step_budget_option
def sweep(robot, car, cars_track, tracks, cars, laps, jobs, cluster, no_cache, json_file, markdown_file, skill_level,
          step_budget_ms) -> None:
    """Race a robot alone on every track, and on one track with every car; check each race.

    Targets per race: finished, damage under 1000, no stuck spell (below 1 m/s outside the pit)
    longer than 10 s.  Exit status 1 when a race misses one.

    Example: boxbox sweep --tracks aalborg,e-track-2 --cars car1-trb1 --laps 1
    """
    from boxbox.bench.solo import expand_all
    from boxbox.bench.sweep import SweepSpec, check, command_line, run_sweep, write_outputs
    from boxbox.report.replay import replay_line
    from boxbox.torcs import catalog

    need_ray(cluster)
    overlay = ready()  # first: 'all' and every name are read from the installed TORCS
    spec = SweepSpec(robot=robot, car=car, cars_track=cars_track, laps=laps, jobs=jobs or os.cpu_count() or 1,
                     use_cache=not no_cache, tracks=expand_all(tracks, list(catalog.tracks())),
                     cars=expand_all(cars, catalog.cars()), skill_level=skill_level,
                     step_budget_ms=int(step_budget_ms), cluster=cluster)
    check(spec)  # every name checked before anything races
    result = run_sweep(spec, overlay, err)
    result.command = command_line()
    out.print(result.table())
    out.print(replay_line(r["run_dir"] for r in result.rows), markup=False, highlight=False, soft_wrap=True)
    write_outputs(result, json_file, markdown_file)
    err.print(f"[dim]{result.raced} raced, {result.cached} cached, {result.wall_s:.1f} s wall[/]")
    if result.failed:
        raise SweepFailed(f"sweep: {result.summary()}")
    err.print(f"sweep: {result.summary()}", markup=False, highlight=False)


@click.command("soak")
@click.option("--track", default="g-track-1", show_default=True, help="Track name, e.g. e-track-2.")
@click.option("--car", default="car1-trb1", show_default=True, help="Car name, e.g. car1-trb1.")
@click.option("--robot", default="boxbox", show_default=True, help="Python robot to race.")
@click.option("--long-laps", type=WholeNumber(0, 10_000), default=200, show_default=True,
              help="Laps of the long race (0: skip it).")
@click.option("--races", type=RACES, default=200, show_default=True, help="Short races back to back (0: skip them).")
@click.option("--race-laps", type=LAPS, default=1, show_default=True, help="Laps of each short race.")
@click.option("--telemetry/--no-telemetry", default=True, show_default=True,
              help="Record telemetry in the races (as `boxbox race` does by default).")
@click.option("--keep-runs", is_flag=True, help="Keep the races' run folders (default: removed at the end).")
@click.option("--json", "json_file", type=OutputFile(), help="Write the figures as JSON.")
@skill_level_option
def soak(track, car, robot, long_laps, races, race_laps, telemetry, keep_runs, json_file, skill_level) -> None:
    """Long runs: one long race and many short ones, watching memory and open files of the Python processes.

    Example: boxbox soak --long-laps 0 --races 5
    """
    from boxbox.bench.soak import SoakSpec, run_soak, tables
    from boxbox.files import write_json_atomic
    from boxbox.robot.base import RaceOptions
    from boxbox.robot.loader import load_robot_class
    from boxbox.torcs import checks

    load_robot_class(robot).check_setup(RaceOptions(), track, car)
    overlay = ready()
    checks.check_race(track, car, 1)
    spec = SoakSpec(track=track, car=car, robot=robot, long_laps=long_laps, races=races, race_laps=race_laps,
                    telemetry=telemetry, keep_runs=keep_runs, skill_level=skill_level)
    result = run_soak(spec, overlay, err)
    for table in tables(result):
        out.print(table)
    if json_file:
        write_json_atomic(json_file, result.to_json(), indent=1)
