"""`boxbox new-robot NAME`: a robot to start from, and its offline tests (robot/template.py)."""

from __future__ import annotations

from pathlib import Path

import click

from boxbox.cli.common import err
from boxbox.errors import UsageError


@click.command("new-robot")
@click.argument("name")
@click.option("--dir", "folder", type=click.Path(file_okay=False, path_type=Path), default=".",
              help="Write the files into this existing folder (default: the current one).")
def new_robot(name: str, folder: Path) -> None:
    """Write NAME.py, a robot of boxbox's documented parts that finishes the public tracks, and
    test_NAME.py, tests of its drive() that run without TORCS (pytest test_NAME.py).

    \b
    Examples:
      boxbox new-robot my_robot
      boxbox race --robot my_robot.py:MyRobot --track g-track-1 --laps 1
    """
    from boxbox.files import write_text_atomic
    from boxbox.robot.template import class_name, robot_files

    files = robot_files(name)
    if not folder.is_dir():
        raise UsageError(f"--dir {folder}: no such folder; make it first")
    taken = [f for f in files if (folder / f).exists() or (folder / f).is_symlink()]
    if taken:
        raise UsageError(f"{folder / taken[0]} already exists: pick another name, or move it away")
    for file_name, text in files.items():
        write_text_atomic(folder / file_name, text)
    robot, tests = (folder / f for f in files)
    err.print(f"wrote {robot} and {tests}; race it with `boxbox race --robot {robot}:{class_name(name)}`, "
              f"test it with `pytest {tests}`", highlight=False)
