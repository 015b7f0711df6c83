"""`boxbox report RUN_DIR`: the HTML race report of a run directory."""

from __future__ import annotations

from pathlib import Path

import click

from boxbox.cli.common import out
from boxbox.cli.types import OutputFile


@click.command("report")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, resolve_path=True, path_type=Path))
@click.option("--out", "out_file", type=OutputFile(), help="Where to write the page (default: RUN_DIR/report.html).")
def report(run_dir: Path, out_file: Path | None) -> None:
    """Make the HTML race report of a run directory (result.json + telemetry.parquet).

    Example: boxbox report ~/.cache/boxbox/runs/20261124-101500-abcd1234 --out race.html
    """
    from boxbox.report.race_report import write_report

    out.print(str(write_report(run_dir, out_file)))
