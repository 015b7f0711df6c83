"""The `boxbox` command line: one click group, its commands in this package (thin: they read the
options, set up TORCS, call boxbox.torcs / boxbox.bench / boxbox.report and print).

Bad input exits 2 with one line, a failed set-up 3, a failed race 4, a tune study that completed
though a worker was lost 5 (docs/tuning.md), Ctrl-C or SIGTERM 130.
"""

from __future__ import annotations

import signal
import sys

import click

from boxbox.cli.bench import bench, bench_field, bench_learning, bench_pits, bench_speed, bench_telemetry
from boxbox.cli.common import err
from boxbox.cli.gym import bench_gym, scr_server
from boxbox.cli.info import cars, doctor, robots, setup, tracks
from boxbox.cli.limit import limit
from boxbox.cli.race import drill, params, race
from boxbox.cli.reliability import soak, sweep
from boxbox.cli.replay import replay
from boxbox.cli.report import contacts, report
from boxbox.cli.tune import bench_tune, tune
from boxbox.errors import BoxboxError


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 110})
def main_group() -> None:
    """boxbox: write TORCS robots in Python and race them in the real TORCS.

    \b
    Examples:
      boxbox race --track g-track-1 --laps 2 --opponents bt:2
      boxbox bench --tracks e-track-2 --laps 30
      boxbox report RUN_DIR
      boxbox replay RUN_DIR --open
    """


for _command in (race, params, drill, setup, doctor, tracks, cars, robots, bench, bench_speed, bench_pits,
                 bench_field, bench_telemetry, bench_learning, report, contacts, replay, sweep, soak, scr_server,
                 bench_gym, limit, tune, bench_tune):
    main_group.add_command(_command)


def _sigterm_as_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt  # a race stops as on Ctrl-C: TORCS stopped, results so far written


def main() -> None:
    signal.signal(signal.SIGTERM, _sigterm_as_interrupt)
    try:
        main_group.main(standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.exceptions.Abort:
        err.print("boxbox: aborted")
        sys.exit(130)
    except click.UsageError as exc:
        err.print(f"boxbox: error: {exc.format_message()} (see --help)", markup=False, highlight=False)
        sys.exit(2)
    except BoxboxError as exc:
        if exc.exit_code == 130:  # stopped by a signal: more of them (Ctrl-C pressed again) must not
            for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):  # kill the exit (SIG_IGN
                signal.signal(sig, signal.SIG_IGN)  # holds through the interpreter's shutdown)
        err.print(f"boxbox: error: {exc}", markup=False, highlight=False)
        sys.exit(exc.exit_code)
