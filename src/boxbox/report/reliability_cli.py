"""`boxbox sweep` and `boxbox soak` (registered in boxbox.cli with `main_group.add_command`)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import click
from rich.console import Console

from boxbox.cliutil import positive_int, ready
from boxbox.errors import BoxboxError, UsageError


class SweepFailed(BoxboxError):
    """Some sweep race missed a target (exit 1; the table says which)."""

    exit_code = 1


def _output(name: str, path: Path | None) -> None:
    if path is not None and not path.resolve().parent.is_dir():
        raise UsageError(f"{name} {path}: folder {path.resolve().parent} does not exist")


@click.command("sweep")
@click.option("--robot", default="boxbox", show_default=True, help="Python robot to race (alone).")
@click.option("--car", default="car1-trb1", show_default=True, help="The car on every track.")
@click.option("--cars-track", default="g-track-1", show_default=True, help="The track every car races on.")
@click.option("--tracks", default="all", show_default=True, help="Tracks for the first part: comma separated or 'all'.")
@click.option("--cars", default="all", show_default=True, help="Cars for the second part: comma separated or 'all'.")
@click.option("--laps", default="3", show_default=True)
@click.option("--jobs", default=None, help="Races run in parallel (default: the number of CPUs).")
@click.option("--no-cache", is_flag=True, help="Race again even what the bench cache has.")
@click.option("--json", "json_file", type=click.Path(dir_okay=False, path_type=Path), help="Write the rows as JSON.")
@click.option("--markdown", "markdown_file", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the table as Markdown, with the command that made it (e.g. docs/sweep.md).")
def sweep(robot, car, cars_track, tracks, cars, laps, jobs, no_cache, json_file, markdown_file) -> None:
    """Race a robot alone on every track, and on one track with every car; check each race.

    Targets per race: finished, damage under 1000, no stuck spell (below 1 m/s outside the pit)
    longer than 10 s.  Exit status 1 when a race misses one."""
    from boxbox.report.bench import parse_list
    from boxbox.report.sweep import SweepSpec, check, command_line, run_sweep, write_outputs
    from boxbox.torcs import catalog

    err = Console(stderr=True, soft_wrap=True)
    out = Console(width=None if sys.stdout.isatty() else 200)
    spec = SweepSpec(robot=robot, car=car, cars_track=cars_track, laps=positive_int("--laps", laps),
                     jobs=positive_int("--jobs", jobs) if jobs is not None else (os.cpu_count() or 1),
                     use_cache=not no_cache,
                     tracks=parse_list(tracks, list(catalog.tracks()), "track"),
                     cars=parse_list(cars, catalog.cars(), "car"))
    _output("--json", json_file)
    _output("--markdown", markdown_file)
    check(spec)  # every name checked before TORCS is even set up
    overlay = ready(err)
    result = run_sweep(spec, overlay, err)
    result.command = command_line()
    out.print(result.table())
    write_outputs(result, json_file, markdown_file)
    err.print(f"[dim]{result.raced} raced, {result.cached} cached, {result.wall_s:.1f} s wall[/]")
    if result.failed:
        raise SweepFailed(f"sweep: {result.summary()}")
    err.print(f"sweep: {result.summary()}", markup=False, highlight=False)


@click.command("soak")
@click.option("--track", default="g-track-1", show_default=True)
@click.option("--car", default="car1-trb1", show_default=True)
@click.option("--robot", default="boxbox", show_default=True, help="Python robot to race.")
@click.option("--long-laps", default="200", show_default=True, help="Laps of the long race (0: skip it).")
@click.option("--races", default="200", show_default=True, help="Short races back to back (0: skip them).")
@click.option("--race-laps", default="1", show_default=True, help="Laps of each short race.")
@click.option("--telemetry/--no-telemetry", default=True, show_default=True,
              help="Record telemetry in the races (as `boxbox race` does by default).")
@click.option("--keep-runs", is_flag=True, help="Keep the races' run folders (default: removed at the end).")
@click.option("--json", "json_file", type=click.Path(dir_okay=False, path_type=Path), help="Write the figures as JSON.")
def soak(track, car, robot, long_laps, races, race_laps, telemetry, keep_runs, json_file) -> None:
    """Long runs: one long race and many short ones, watching memory and open files of the Python processes."""
    from boxbox.files import write_json_atomic
    from boxbox.report.soak import SoakSpec, run_soak, tables
    from boxbox.robot.base import RaceOptions
    from boxbox.robot.loader import load_robot_class
    from boxbox.torcs import catalog

    def count(name: str, text: str) -> int:
        return 0 if text.strip() == "0" else positive_int(name, text)

    err = Console(stderr=True, soft_wrap=True)
    out = Console(width=None if sys.stdout.isatty() else 200)
    spec = SoakSpec(track=track, car=car, robot=robot, long_laps=count("--long-laps", long_laps),
                    races=count("--races", races), race_laps=positive_int("--race-laps", race_laps),
                    telemetry=telemetry, keep_runs=keep_runs)
    catalog.check_track(track)
    catalog.check_car(car)
    load_robot_class(robot).check_setup(RaceOptions(), track, car)
    _output("--json", json_file)
    overlay = ready(err)
    result = run_soak(spec, overlay, err)
    for table in tables(result):
        out.print(table)
    if json_file:
        write_json_atomic(json_file, result.to_json(), indent=1)
