"""The `boxbox` command line: one click group, its commands in this package (thin: they read the
options, set up TORCS, call boxbox.torcs / boxbox.bench / boxbox.report and print).

Bad input exits 2 with one line, a failed set-up 3, a failed race 4, a tune study that completed
though a worker was lost 5 (docs/tuning.md), Ctrl-C or SIGTERM 130.
"""

from __future__ import annotations

import importlib
import signal
import sys

import click

from boxbox.errors import BoxboxError

# each command's module in this package: a command loads its module when it is run (or its help
# shown), so `boxbox tracks` does not load the tuner's; the modules load numpy, TORCS's side and
# the rest inside their commands, so `boxbox --help`, which reads every command's help, stays quick
COMMANDS = {
    **dict.fromkeys(("race", "params", "drill"), "race"),
    **dict.fromkeys(("setup", "doctor", "tracks", "cars", "robots"), "info"),
    **dict.fromkeys(("bench", "bench-speed", "bench-pits", "bench-field", "bench-telemetry", "bench-learning",
                     "bench-table"),
                    "benches"),
    **dict.fromkeys(("report", "contacts"), "report"), "replay": "replay",
    **dict.fromkeys(("sweep", "soak"), "reliability"), **dict.fromkeys(("scr-server", "bench-gym"), "gym"),
    "limit": "limit", **dict.fromkeys(("tune", "bench-tune"), "tune"), "new-robot": "new_robot",
}


class LazyGroup(click.Group):
    """click's group, its commands found in COMMANDS and imported when first asked for."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return None
        module = importlib.import_module(f"boxbox.cli.{COMMANDS[cmd_name]}")
        command = getattr(module, cmd_name.replace("-", "_"))
        assert isinstance(command, click.Command) and command.name == cmd_name, cmd_name
        return command


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 110})
def main_group() -> None:
    """boxbox: write TORCS robots in Python and race them in the real TORCS.

    \b
    Examples:
      boxbox race --track g-track-1 --laps 2 --opponents bt:2
      boxbox bench --tracks e-track-2 --laps 30
      boxbox report RUN_DIR
      boxbox replay RUN_DIR --open
    """


def _sigterm_as_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt  # a race stops as on Ctrl-C: TORCS stopped, results so far written


def main() -> None:
    signal.signal(signal.SIGTERM, _sigterm_as_interrupt)
    try:
        main_group.main(standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.exceptions.Abort:
        _error("boxbox: aborted")
        sys.exit(130)
    except click.UsageError as exc:
        _error(f"boxbox: error: {exc.format_message()} (see --help)")
        sys.exit(2)
    except BoxboxError as exc:
        if exc.exit_code == 130:  # stopped by a signal: more of them (Ctrl-C pressed again) must not
            for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):  # kill the exit (SIG_IGN
                signal.signal(sig, signal.SIG_IGN)  # holds through the interpreter's shutdown)
        _error(f"boxbox: error: {exc}")
        sys.exit(exc.exit_code)


def _error(line: str) -> None:
    from boxbox.cli.common import err

    err.print(line, markup=False, highlight=False)
