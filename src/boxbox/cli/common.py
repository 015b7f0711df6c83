"""What the commands share: the two consoles, the set-up with progress, a race with a progress bar
and its error."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any, cast

from boxbox.errors import Interrupted, RaceError

if TYPE_CHECKING:
    from rich.console import Console

    from boxbox.torcs.raceprep import RaceConfig
    from boxbox.torcs.results import RaceResult
    from boxbox.torcs.setup import Overlay


class _FirstUseConsole:
    """A rich Console made when first used: rich took a third of `boxbox --help`, which click
    prints without it (0.13 of 0.28 s of CPU on a loaded machine)."""

    def __init__(self, **options: Any) -> None:
        self._options = options
        self._console: Console | None = None

    def __getattr__(self, name: str) -> Any:
        return getattr(self._made(), name)

    def __enter__(self) -> Console:  # rich's Live holds its console in a with (dunders skip __getattr__)
        return self._made().__enter__()

    def __exit__(self, *exc: Any) -> None:
        self._made().__exit__(*exc)

    def _made(self) -> Console:
        if self._console is None:
            from rich.console import Console

            self._console = Console(**self._options)
        return self._console


# Messages go to stderr, one line however narrow the terminal; tables to stdout, with room when piped.
err = cast("Console", _FirstUseConsole(stderr=True, soft_wrap=True))
out = cast("Console", _FirstUseConsole(width=None if sys.stdout.isatty() else 200))


def ready() -> Overlay:
    """Set up TORCS and the bridge when needed, showing each step; returns the Overlay.  Every
    command that races calls this before checking names against the installed TORCS."""
    from boxbox.torcs import setup

    if not setup.packages_missing() and all(ok for _, ok, _ in setup.doctor()):
        return setup.ensure_ready()
    with err.status("setting up TORCS for boxbox") as status:
        def report(msg: str) -> None:
            status.update(msg)
            err.print(f"[dim]setup:[/] {msg}")
        overlay = setup.ensure_ready(report)
    err.print("[green]setup: ready[/]")
    return overlay


def race_error(result: RaceResult) -> RaceError:
    """The error to raise for a race that did not end properly (its details printed first)."""
    from boxbox.torcs.launch import INTERRUPTED

    first, _, rest = (result.error or "").partition("\n")
    if rest:
        err.print(rest, markup=False, highlight=False)
    return Interrupted(first) if first.startswith(INTERRUPTED) else RaceError(first)


def run_with_progress(cfg: RaceConfig, overlay: Overlay, quiet: bool = False) -> RaceResult:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from boxbox.torcs import launch

    if quiet:
        return launch.run_race(cfg, overlay)
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("laps"),
                  TextColumn("{task.fields[sim]}"), TimeElapsedColumn(), console=err, transient=True) as bar:
        task = bar.add_task(f"{cfg.track} ({cfg.car})", total=cfg.laps, sim="")
        return launch.run_race(cfg, overlay, lambda lap, t: bar.update(task, completed=lap, sim=f"sim {t:.0f} s"))
