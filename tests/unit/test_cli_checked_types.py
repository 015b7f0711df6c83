"""Every number and choice the command line takes is checked by boxbox.validate (through the
click types of cli/types.py), so a command cannot quietly take NaN, True or 3.5 where its twin
in boxbox.race() or the env refuses them."""

import click

from boxbox.cli import main_group as main
from boxbox.cli.types import Checked


def _commands(group: click.Group, prefix: str = ""):
    ctx = click.Context(group)  # the group loads its commands when asked for (cli/__init__.py)
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        assert command is not None
        if isinstance(command, click.Group):
            yield from _commands(command, f"{prefix}{name} ")
        else:
            yield f"{prefix}{name}", command


def test_every_number_and_choice_option_is_checked_by_validate():
    assert len(list(_commands(main))) >= 24
    raw = (click.types.IntParamType, click.types.FloatParamType, click.Choice)
    unchecked = [f"{name} {param.name}" for name, command in _commands(main) for param in command.params
                 if isinstance(param.type, raw) and not isinstance(param.type, Checked)]
    assert unchecked == []

