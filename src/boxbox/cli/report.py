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
