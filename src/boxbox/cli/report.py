"""`boxbox report RUN_DIR`: the HTML race report of a run directory."""

from __future__ import annotations

from pathlib import Path

import click

from boxbox.cli.common import err, out
from boxbox.cli.types import OutputFile


@click.command("report")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, resolve_path=True, path_type=Path))
@click.option("--out", "out_file", type=OutputFile(), help="Where to write the page (default: RUN_DIR/report.html).")
@click.option("--no-limit", is_flag=True, help="Leave out the limit lap's speed (`boxbox limit`) in the lap plots.")
def report(run_dir: Path, out_file: Path | None, no_limit: bool) -> None:
    """Make the HTML race report of a run directory (result.json + telemetry.parquet), with the
    car's limit lap speed over every lap's speed and a map of where it took its damage.

    Example: boxbox report ~/.cache/boxbox/runs/20261124-101500-abcd1234 --out race.html
    """
    from boxbox.report.race_report import write_report

    out.print(str(write_report(run_dir, out_file, None if no_limit else _limit_speed(run_dir))))


def _limit_speed(run_dir: Path):
    """The limit lap's (distance, speed) for the race's track, car and skill level, or None."""
    import json

    from boxbox.bench.limit import limit_for
    from boxbox.errors import BoxboxError
    from boxbox.model.skill import SkillLevel

    try:
        r = json.loads((run_dir / "result.json").read_text())
        lap = limit_for(r["track"], r["car"], SkillLevel.parse(r.get("skill_level") or "semi-pro"))
    except (OSError, ValueError, KeyError, TypeError, BoxboxError) as exc:
        err.print(f"[yellow]no limit lap in the report: {exc}[/]")
        return None
    return lap.dist_m, lap.speed_mps


@click.command("contacts")
@click.argument("run_dirs", nargs=-1, type=click.Path(exists=True, file_okay=False, resolve_path=True,
                                                      path_type=Path))
@click.option("--bench", "bench_file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Take the robot's run dirs from a `bench-field --json` file.")
@click.option("--each", is_flag=True, help="Also list every incident.")
@click.option("--json", "json_file", type=OutputFile(), help="Write every race's incidents to this JSON file.")
def contacts(run_dirs: tuple[Path, ...], bench_file: Path | None, each: bool, json_file: Path | None) -> None:
    """Why the Python car took its damage (docs/racecraft.md): each damage incident of the first
    Python car of each race put down to a cause (hit from behind, into the car ahead, side by side
    and who changed line, alone), with the damage each cause holds and what would be left without it.

    Example: boxbox contacts RUN_DIR
    """
    import json

    from boxbox.errors import UsageError
    from boxbox.files import write_json_atomic
    from boxbox.report.contacts import bench_run_dirs, load_race

    dirs = list(run_dirs)
    if bench_file is not None:
        try:
            dirs += bench_run_dirs(json.loads(bench_file.read_text()))
        except (OSError, ValueError, AttributeError, KeyError, TypeError) as exc:
            raise UsageError(f"--bench {bench_file}: not a bench-field --json file ({exc})") from None
    if not dirs:
        raise UsageError("give run dirs (RUN_DIR...) or --bench FILE")
    missing = [d for d in dirs if not (d / "recording.parquet").exists()]
    if missing:
        raise UsageError(f"{missing[0]} has no recording.parquet (a race with a Python car writes one)")
    races = [load_race(d) for d in dirs]
    if each:
        out.print(_each_table(races))
    out.print(_cause_table(races))
    out.print(_ahead_table(races))
    out.print(_scenario_table(races))
    if json_file is not None:
        write_json_atomic(json_file, [r.to_json() for r in races], indent=1)


def _each_table(races):
    from rich.table import Table

    table = Table(title="every incident")
    for col in ("track", "lap", "dist m", "damage", "cause", "other", "ahead m", "left m", "closing m/s",
                "lapping", "we moved m", "it moved m"):
        table.add_column(col, justify="left" if col in ("track", "cause", "lapping") else "right")
    for r in races:
        for c in r.contacts:
            nums = [f"{v:.1f}" if v == v else "-" for v in (c.ahead_m, c.left_m, c.closing_mps)]
            moved = [f"{v:.1f}" if v == v else "-" for v in (c.we_moved_m, c.it_moved_m)]
            table.add_row(r.track, str(c.lap), f"{c.dist_m:.0f}", str(c.damage), c.cause,
                          str(c.other) if c.other >= 0 else "-", *nums, c.lapping or "-", *moved)
    return table


def _cause_table(races):
    from rich.table import Table

    from boxbox.report.contacts import LOW_DAMAGE, cause_rows

    table = Table(title=f"damage by cause over {len(races)} races")
    for col in ("cause", "incidents", "damage", "share", "on lap 1", "lapping", "others' damage",
                f"races >= {LOW_DAMAGE} it leads"):
        table.add_column(col, justify="left" if col == "cause" else "right")
    for r in cause_rows(races):
        table.add_row(r["cause"], str(r["incidents"]), str(r["damage"]), f"{100 * r['share']:.0f} %", str(r["lap1"]),
                      str(r["lapping"]), str(r["others_damage"]), str(r["races_led"]))
    return table


def _ahead_table(races):
    from rich.table import Table

    from boxbox.report.contacts import ahead_rows

    table = Table(title="we hit the car ahead: how")
    for col in ("how", "incidents", "damage", "on lap 1", "headway s (median, 1 s before)", "closing m/s (median)"):
        table.add_column(col, justify="left" if col == "how" else "right")
    for r in ahead_rows(races):
        nums = [f"{v:.2f}" if v == v else "-" for v in (r["headway_s"], r["closing_mps"])]
        table.add_row(r["how"], str(r["incidents"]), str(r["damage"]), str(r["lap1"]), *nums)
    return table


def _scenario_table(races):
    from rich.table import Table

    from boxbox.report.contacts import LOW_DAMAGE, scenario_rows

    table = Table(title="the damage left without some causes")
    for col in ("scenario", "damage", f"races under {LOW_DAMAGE}", "what"):
        table.add_column(col, justify="left" if col in ("scenario", "what") else "right")
    for r in scenario_rows(races):
        table.add_row(r["scenario"], str(r["damage"]), f"{r['under_low']}/{r['races']}", r["what"])
    return table
