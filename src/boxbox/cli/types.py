"""click parameter types for boxbox's options: checked while the command line is read, so a bad
value fails with exit 2 and one line before anything is set up or raced.

Each type is a thin wrapper over boxbox/validate.py, the checks `boxbox.race`, the Gymnasium env
and the SCR server use too: the same value gets the same words everywhere.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from boxbox import validate
from boxbox.errors import UsageError
from boxbox.options import LEARNING_MODES, PIT_MODES
from boxbox.validate import MAX_LAPS

__all__ = ["MAX_LAPS"]  # re-exported: the lap limit's old home


class Checked:
    """Mixin: `check(value)` is a validate.py function; its UsageError becomes click's failure."""

    def checked(self, check: Callable[[Any], Any], value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> Any:
        try:
            return check(value)
        except UsageError as exc:
            self.fail(str(exc), param, ctx)  # type: ignore[attr-defined]


class WholeNumber(Checked, click.IntRange):
    """click's IntRange (its help shows the range), checked by validate.whole_number: True and 3.5
    are refused (click would take them as 1 and 3)."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        lo, hi = (None if b is None else int(b) for b in (self.min, self.max))
        return self.checked(lambda v: validate.whole_number(v, lo, hi), value, param, ctx)


class FiniteFloatRange(Checked, click.FloatRange):
    """click's FloatRange (its help shows the range), checked by validate.finite_number: NaN and
    the infinities are refused."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return self.checked(lambda v: validate.finite_number(v, self.min, self.max, lo_open=self.min_open,
                                                             hi_open=self.max_open), value, param, ctx)


LAPS = WholeNumber(1, MAX_LAPS)
FUEL_LAPS = FiniteFloatRange(*validate.FUEL_LAPS)
STEP_BUDGET_MS = FiniteFloatRange(*validate.STEP_BUDGET_MS)
SETUP_BUDGET_S = FiniteFloatRange(*validate.SETUP_BUDGET_S)


class Choice(Checked, click.Choice):
    """click's Choice (its help lists the choices), checked by validate.choice."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return self.checked(lambda v: validate.choice(v, tuple(self.choices)), value, param, ctx)


PIT_MODE = Choice(PIT_MODES)
LEARNING = Choice(LEARNING_MODES)


class SkillLevelChoice(Choice):
    """TORCS's skill level by its name ('semi-pro'), converted to a SkillLevel."""

    def __init__(self) -> None:
        super().__init__(validate.SKILL_LEVELS)

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


def step_budget_option(command: Any) -> Any:
    """--step-budget-ms for every command that races Python robots (the error of a late robot names it)."""
    return click.option("--step-budget-ms", type=STEP_BUDGET_MS, default=200, show_default=True,
                        help="Wall time a robot may take per drive step before the race is stopped "
                             "(more on a loaded machine).")(command)


def bench_race_options(command: Any) -> Any:
    """--no-cache, --learning and --set, as every bench of Python robots takes them."""
    for option in (
        click.option("--set", "settings", multiple=True, metavar="KEY=VALUE",
                     help="Override a parameter of the Python robots (see `boxbox params`), e.g. --set mu_scale=0.9."),
        click.option("--learning", type=LEARNING, default="fresh", show_default=True,
                     help="Python robots' learned data: from nothing each race, the shared store, or none."),
        click.option("--no-cache", is_flag=True, help="Race again even what the bench cache has (and refresh it)."),
    ):
        command = option(command)
    return command


class GridPosition(Checked, click.ParamType):
    """A grid slot: 1 (pole) .. 40, or 'last' (validate.grid_position)."""

    name = "grid position"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "N|last"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return self.checked(validate.grid_position, value, param, ctx)


class CommaList(Checked, click.ParamType):
    """'a,b,c' -> ['a', 'b', 'c'] (blanks dropped; with unique, repeats dropped too)."""

    name = "list"

    def __init__(self, metavar: str = "NAME,...", unique: bool = True, item: click.ParamType | None = None) -> None:
        self.metavar, self.unique, self.item = metavar, unique, item

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return self.metavar

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, list | tuple):
            return list(value)
        items = self.checked(lambda v: validate.names(v, "names", unique=False), value, param, ctx)
        if self.item is not None:
            items = [self.item.convert(part, param, ctx) for part in items]
        return list(dict.fromkeys(items)) if self.unique else items


class LapList(Checked, click.ParamType):
    """'3,7' -> [3, 7]: laps, each 1..10000, repeats dropped (validate.lap_list)."""

    name = "list"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "LAP,..."

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return self.checked(validate.lap_list, value, param, ctx)


LAP_LIST = LapList()


class LapLengths(Checked, click.ParamType):
    """Race lengths: '10', '8,10,12' or '6-14' (both ends included) -> [10], [8, 10, 12], [6, ..., 14]."""

    name = "lengths"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "N|N,N,..|N-M"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return self.checked(validate.lap_lengths, value, param, ctx)


class OutputFile(Checked, click.ParamType):
    """A file boxbox will write: made absolute, its folder must exist and take a new file."""

    name = "file"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "FILE"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return self.checked(validate.output_file, value, param, ctx)


class InputFile(Checked, click.ParamType):
    """A file boxbox will read: made absolute; it must exist and be a file."""

    name = "file"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "FILE"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return self.checked(validate.input_file, value, param, ctx)


class RunFile(click.ParamType):
    """A JSON file an earlier run wrote, to compare with: read and checked (`_check`) before any race."""

    name = "file"
    _hint = ""

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "FILE"

    def _check(self, doc: Any) -> None:
        raise NotImplementedError

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        import json

        if isinstance(value, tuple):
            return value
        path = Path(os.path.abspath(os.path.expanduser(value)))
        try:
            doc = json.loads(path.read_text())
            self._check(doc)
        except OSError as exc:
            self.fail(f"cannot read {path} ({exc.strerror or exc}); {self._hint}", param, ctx)
        except ValueError as exc:
            why = (str(exc).splitlines() or [type(exc).__name__])[0]
            self.fail(f"{path}: {why}; {self._hint}", param, ctx)
        return path, doc


class FieldRunFile(RunFile):
    """A `boxbox bench-field --json` file to compare with."""

    _hint = "give a file `boxbox bench-field --json` wrote."

    def _check(self, doc: Any) -> None:
        from boxbox.bench.field_compare import passes_of

        passes_of(doc)


class BenchRunFile(RunFile):
    """A `boxbox bench --json` file with a Python robot to judge (bench/judged_table.py)."""

    _hint = "give a file `boxbox bench --json` wrote."

    def _check(self, doc: Any) -> None:
        from boxbox.bench.judged_table import check_doc

        check_doc(doc)


class OutputDir(Checked, click.ParamType):
    """A folder boxbox will write into: made absolute; it, or the nearest folder above it that
    exists (where it will be created), must take a new file."""

    name = "dir"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "DIR"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        return self.checked(validate.output_dir, value, param, ctx)


class ClusterAddress(Checked, click.ParamType):
    """--cluster: 'auto' or a Ray head's HOST:PORT (Ray itself is looked for when the command runs: `need_ray`)."""

    name = "ADDRESS"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from boxbox.bench.cluster import check_address

        return self.checked(check_address, value, param, ctx)


def need_ray(cluster: str | None) -> None:
    """With --cluster, Ray installed: else one line saying how, exit 2, before anything is set up or raced."""
    if cluster:
        from boxbox.bench.cluster import require_ray

        require_ray()


cluster_option = click.option(
    "--cluster", type=ClusterAddress(), default=None,
    help="Race on the Ray cluster at ADDRESS ('auto': the one this machine joined, or the head's HOST:PORT), "
         "each race a task on a free CPU of any node, instead of --jobs here (docs/cluster.md).")
