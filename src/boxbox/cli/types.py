"""click parameter types for boxbox's options: checked while the command line is read, so a bad
value fails with exit 2 and one line before anything is set up or raced."""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path
from typing import Any

import click

MAX_LAPS = 10_000  # far beyond any race worth running; keeps lap counts clear of C int overflows


class FiniteFloatRange(click.FloatRange):
    """click's FloatRange, which lets NaN through its bounds; this one refuses it."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return number


LAPS = click.IntRange(1, MAX_LAPS)


class SkillLevelChoice(click.Choice):
    """TORCS's skill level by its name ('semi-pro'), converted to a SkillLevel."""

    def __init__(self) -> None:
        from boxbox.model.skill import SkillLevel

        super().__init__([level.torcs_name for level in SkillLevel])

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from boxbox.model.skill import SkillLevel

        if isinstance(value, SkillLevel):
            return value
        return SkillLevel.parse(super().convert(value, param, ctx))


def skill_level_option(command: Any) -> Any:
    """--skill-level for every command that races: one level for every car in the race."""
    return click.option("--skill-level", type=SkillLevelChoice(), default="semi-pro", show_default=True,
                        help="TORCS's skill level of every car, boxbox's and TORCS's robots alike (see "
                             "docs/rules.md); semi-pro is what TORCS gives its own robots.")(command)


def bench_race_options(command: Any) -> Any:
    """--no-cache, --learning and --set, as every bench of Python robots takes them."""
    from boxbox.options import LEARNING_MODES

    for option in (
        click.option("--set", "settings", multiple=True, metavar="KEY=VALUE",
                     help="Override a parameter of the Python robots (see `boxbox params`), e.g. --set mu_scale=0.9."),
        click.option("--learning", type=click.Choice(LEARNING_MODES), default="fresh", show_default=True,
                     help="Python robots' learned data: from nothing each race, the shared store, or none."),
        click.option("--no-cache", is_flag=True, help="Race again even what the bench cache has (and refresh it)."),
    ):
        command = option(command)
    return command


class GridPosition(click.ParamType):
    """A grid slot: 1 (pole) .. 40, or 'last'."""

    name = "grid position"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "N|last"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, int) or value == "last":
            return value
        try:
            number = int(value)
        except ValueError:
            self.fail(f"{value!r} is not a grid slot; give a number from 1 (pole) or 'last'.", param, ctx)
        if not 1 <= number <= 40:
            self.fail(f"{number} is not a grid slot; TORCS grids have 1 to 40.", param, ctx)
        return number


class CommaList(click.ParamType):
    """'a,b,c' -> ['a', 'b', 'c'] (blanks dropped; with unique, repeats dropped too)."""

    name = "list"

    def __init__(self, metavar: str = "NAME,...", unique: bool = True, item: click.ParamType | None = None) -> None:
        self.metavar, self.unique, self.item = metavar, unique, item

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return self.metavar

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, list | tuple):
            return list(value)
        items = [part.strip() for part in str(value).split(",") if part.strip()]
        if self.item is not None:
            items = [self.item.convert(part, param, ctx) for part in items]
        return list(dict.fromkeys(items)) if self.unique else items


LAP_LIST = CommaList("LAP,...", item=LAPS)


class LapLengths(click.ParamType):
    """Race lengths: '10', '8,10,12' or '6-14' (both ends included) -> [10], [8, 10, 12], [6, ..., 14]."""

    name = "lengths"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "N|N,N,..|N-M"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, list | tuple):
            return list(value)
        text = str(value).strip()
        if "-" in text and "," not in text:
            lo, _, hi = text.partition("-")
            first, last = LAPS.convert(lo.strip(), param, ctx), LAPS.convert(hi.strip(), param, ctx)
            if last < first:
                self.fail(f"{text!r}: the range ends before it starts (e.g. 6-14).", param, ctx)
            return list(range(first, last + 1))
        lengths = LAP_LIST.convert(text, param, ctx)
        if not lengths:
            self.fail("give at least one race length, e.g. 10 or 6-14.", param, ctx)
        return lengths


def _probe_writable(folder: Path) -> str | None:
    """None when a file can be created in folder, else why not (a real create: permissions alone
    do not tell, e.g. /proc or a read-only mount)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".boxbox-probe-", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    os.unlink(probe)
    return None


class OutputFile(click.ParamType):
    """A file boxbox will write: made absolute, its folder must exist and take a new file."""

    name = "file"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "FILE"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        path = Path(os.path.abspath(os.path.expanduser(value)))
        if path.is_dir():
            self.fail(f"{path} is a folder; give a file name.", param, ctx)
        if not path.parent.is_dir():
            self.fail(f"folder {path.parent} does not exist; create it first.", param, ctx)
        if why := _probe_writable(path.parent):
            self.fail(f"cannot write in {path.parent} ({why}); choose another place.", param, ctx)
        if path.exists() and not os.access(path, os.W_OK):
            self.fail(f"{path} is not writable; choose another file.", param, ctx)
        return path


class FieldRunFile(click.ParamType):
    """A `boxbox bench-field --json` file to compare with: read and checked before any race."""

    name = "file"
    _hint = "give a file `boxbox bench-field --json` wrote."

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "FILE"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        import json

        from boxbox.bench.field_compare import passes_of

        if isinstance(value, tuple):
            return value
        path = Path(os.path.abspath(os.path.expanduser(value)))
        try:
            doc = json.loads(path.read_text())
            passes_of(doc)
        except OSError as exc:
            self.fail(f"cannot read {path} ({exc.strerror or exc}); {self._hint}", param, ctx)
        except ValueError as exc:
            why = (str(exc).splitlines() or [type(exc).__name__])[0]
            self.fail(f"{path}: {why}; {self._hint}", param, ctx)
        return path, doc


class OutputDir(click.ParamType):
    """A folder boxbox will write into: made absolute; it, or the nearest folder above it that
    exists (where it will be created), must take a new file."""

    name = "dir"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "DIR"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        path = Path(os.path.abspath(os.path.expanduser(value)))
        existing = next(p for p in (path, *path.parents) if p.exists())
        if not existing.is_dir():
            self.fail(f"{existing} is a file, so {path} cannot be a folder.", param, ctx)
        if why := _probe_writable(existing):
            where = path if existing == path else f"{path} (in {existing})"
            self.fail(f"cannot write in {where}: {why}; choose another place.", param, ctx)
        return path
