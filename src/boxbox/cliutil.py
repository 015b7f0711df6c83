"""Small pieces every boxbox command shares: setup with progress, number parsing."""

from __future__ import annotations

from rich.console import Console

from boxbox.errors import UsageError


def ready(console: Console):
    """Set up TORCS and the bridge when needed, showing each step; returns the Overlay."""
    from boxbox.torcs import setup

    if not setup.packages_missing() and all(ok for _, ok, _ in setup.doctor()):
        return setup.ensure_ready()
    with console.status("setting up TORCS for boxbox") as status:
        def report(msg: str) -> None:
            status.update(msg)
            console.print(f"[dim]setup:[/] {msg}")
        overlay = setup.ensure_ready(report)
    console.print("[green]setup: ready[/]")
    return overlay


def positive_int(name: str, text: str, what: str = "") -> int:
    """A whole number >= 1 from an option's text; a one-line UsageError otherwise."""
    try:
        value = int(text)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a whole number{what} >= 1, got '{text}'") from None
    if value < 1:
        raise UsageError(f"{name} must be >= 1, got {value}")
    return value
