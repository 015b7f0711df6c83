"""`boxbox setup`, `doctor`, `tracks`, `cars` and `robots`: the set-up and what is installed."""

from __future__ import annotations

import sys

import click

from boxbox.cli.common import out, ready


@click.command()
def setup() -> None:
    """Install TORCS and its headers, build the bridge and the overlay (idempotent)."""
    overlay = ready()
    out.print(f"bridge: {overlay.bridge}\noverlay: {overlay.lib_dir.parent}")


@click.command()
def doctor() -> None:
    """Say what is present and what is missing (exit 1 when something is)."""
    from rich.table import Table

    from boxbox.torcs import setup as torcs_setup

    table = Table("component", "status", "where")
    missing = 0
    for name, ok, where in torcs_setup.doctor():
        table.add_row(name, "[green]ok[/]" if ok else "[red]missing[/]", where)
        missing += not ok
    out.print(table)
    if missing:
        out.print("run `boxbox setup` (or any `boxbox race`) to fix what is missing")
        sys.exit(1)


@click.command()
def tracks() -> None:
    """List the installed tracks (category and name)."""
    from boxbox.torcs import catalog

    for name, category in sorted(catalog.tracks().items(), key=lambda kv: (kv[1], kv[0])):
        out.print(f"{category:6} {name}")


@click.command()
def cars() -> None:
    """List the installed cars."""
    from boxbox.torcs import catalog

    for name in catalog.cars():
        out.print(name)


@click.command()
def robots() -> None:
    """List boxbox's built-in robots and the installed TORCS robots (module:idx, name, car)."""
    from boxbox.robot.loader import BUILTIN
    from boxbox.torcs import catalog

    for name, target in BUILTIN.items():
        out.print(f"python  {name:10} {target}")
    for module in catalog.robot_modules():
        for idx, info in sorted(catalog.robot_indices(module).items()):
            out.print(f"torcs   {module}:{idx:<6} {info['name']} ({info['car']})")
