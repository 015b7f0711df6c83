"""The `boxbox bench` command (registered in boxbox.cli with `main_group.add_command(bench)`)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import click
from rich.console import Console

from boxbox.cliutil import positive_int, ready

DEFAULT_TRACKS = "e-track-2,e-track-4,mixed-2,g-track-1,aalborg,michigan"
DEFAULT_ROBOTS = "boxbox,bt:2,berniw:3,inferno:3,olethros:2"


@click.command("bench")
@click.option("--tracks", default=DEFAULT_TRACKS, show_default=True, help="Comma separated tracks, or 'all'.")
@click.option("--cars", default="car1-trb1", show_default=True,
              help="Comma separated cars of the Python robots, or 'all' (TORCS robots drive their own).")
@click.option("--robots", default=DEFAULT_ROBOTS, show_default=True,
              help="Comma separated: Python robots (boxbox, middle, path/file.py:Class, module:Class) "
                   "and TORCS robots (module:idx, see `boxbox robots`).")
@click.option("--laps", default="3", show_default=True, help="Race length in laps.")
@click.option("--together", is_flag=True, help="All robots in one race per track and car (default: each alone).")
@click.option("--jobs", default=None, help="Races run in parallel (default: the number of CPUs).")
@click.option("--no-cache", is_flag=True, help="Race again even what the bench cache has (and refresh it).")
@click.option("--learning", type=click.Choice(["fresh", "on", "off"]), default="fresh", show_default=True,
              help="Python robots' learned data: from nothing each race, the shared store, or none.")
@click.option("--set", "settings", multiple=True, metavar="KEY=VALUE",
              help="Override a parameter of the Python robots (see `boxbox params`). Repeatable.")
@click.option("--json", "json_file", type=click.Path(dir_okay=False, path_type=Path), help="Write the rows as JSON.")
@click.option("--csv", "csv_file", type=click.Path(dir_okay=False, path_type=Path), help="Write the rows as CSV.")
def bench(tracks, cars, robots, laps, together, jobs, no_cache, learning, settings, json_file, csv_file) -> None:
    """Race robots on tracks (each alone by default) and compare times; results are cached."""
    from boxbox.report.bench import BenchSpec, parse_list, run_bench
    from boxbox.robot.params import parse_set
    from boxbox.torcs import catalog

    err = Console(stderr=True, soft_wrap=True)
    out = Console(width=None if sys.stdout.isatty() else 160)
    spec = BenchSpec(tracks=parse_list(tracks, list(catalog.tracks()), "track"),
                     cars=parse_list(cars, catalog.cars(), "car"),
                     robots=parse_list(robots, None, "robot"),
                     laps=positive_int("--laps", laps),
                     together=together,
                     jobs=positive_int("--jobs", jobs) if jobs is not None else (os.cpu_count() or 1),
                     use_cache=not no_cache, learning=learning,
                     settings=parse_set(settings) if settings else None)
    from boxbox.report.bench import plan

    plan(spec)  # every name checked before TORCS is even set up
    overlay = ready(err)
    result = run_bench(spec, overlay, err)
    out.print(result.table())
    if len(result.tracks) > 1 or len(result.cars) > 1:
        out.print(result.summary_table())
    failed = sum(1 for r in result.rows if r["error"])
    err.print(f"[dim]{result.raced} raced, {result.cached} cached, {result.wall_s:.1f} s wall"
              + (f"; [red]{failed} rows with errors[/]" if failed else "") + "[/]")
    if json_file:
        result.write_json(json_file)
    if csv_file:
        result.write_csv(csv_file)
