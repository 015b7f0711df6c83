"""`boxbox replay RUN_DIR`: the race as a page that plays it (every car, the incidents marked)."""

from __future__ import annotations

from pathlib import Path

import click

from boxbox.cli.common import err, out
from boxbox.cli.types import OutputFile


@click.command("replay")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, resolve_path=True, path_type=Path))
@click.option("--out", "out_file", type=OutputFile(), help="Where to write the page (default: RUN_DIR/replay.html).")
@click.option("--open", "open_page", is_flag=True, help="Open the page in the web browser.")
def replay(run_dir: Path, out_file: Path | None, open_page: bool) -> None:
    """Write a race's replay: one HTML page that needs no network, with every car on the track, play,
    speed, a time scrubber, a car to follow, and the incidents (contacts, spins, passes, pit stops...)
    on the timeline and in a list.  Any race with a Python car is recorded (RUN_DIR/recording.parquet).

    Example: boxbox replay ~/.cache/boxbox/runs/20261124-101500-abcd1234 --open
    """
    from boxbox.report.replay import write_replay

    page = write_replay(run_dir, out_file)
    out.print(str(page))
    if open_page:
        import webbrowser

        if not webbrowser.open(page.as_uri()):
            err.print(f"[yellow]no web browser could be opened here: open {page} yourself[/]")
