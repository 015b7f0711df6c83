"""The `boxbox` command line."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click
from rich.console import Console

from boxbox.cliutil import positive_int, ready
from boxbox.errors import BoxboxError, UsageError

# Errors are one line however narrow the terminal; tables get room when piped.
console = Console(stderr=True, soft_wrap=True)
out = Console(width=None if sys.stdout.isatty() else 160)


def _ready():
    return ready(console)


def _parse_laps(text: str) -> int:
    return positive_int("--laps", text, " of laps")


def _parse_float(name: str, text: str | None, minimum: float) -> float | None:
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise UsageError(f"{name} must be a number, got '{text}'") from None
    if not value >= minimum or value == float("inf"):
        raise UsageError(f"{name} must be a finite number >= {minimum:g}, got {text}")
    return value


def _parse_int_list(name: str, text: str | None) -> tuple[int, ...]:
    if not text:
        return ()
    try:
        values = tuple(sorted({int(x) for x in text.split(",") if x.strip()}))
    except ValueError:
        raise UsageError(f"{name} takes lap numbers like 3,7; got '{text}'") from None
    if any(v < 1 for v in values):
        raise UsageError(f"{name}: lap numbers start at 1; got '{text}'")
    return values


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
def main_group() -> None:
    """boxbox: write TORCS robots in Python and race them in the real TORCS."""


@main_group.command()
@click.option("--track", default="e-track-2", show_default=True, help="Track name (category found automatically).")
@click.option("--car", default="car1-trb1", show_default=True, help="Car of the Python robots.")
@click.option("--laps", default="3", show_default=True, help="Race length in laps.")
@click.option("--robot", "robots", multiple=True,
              help="Python robot: NAME (boxbox, middle), path/file.py:Class or module:Class. Repeat for more cars.")
@click.option("--opponents", default="", help="TORCS robots as module:idx, comma separated (e.g. bt:2,berniw:3).")
@click.option("--fuel-laps", default=None, help="Start with fuel for this many laps.")
@click.option("--pit-laps", default=None, help="Ask for pit stops on these laps (e.g. 3,7).")
@click.option("--pit-mode", type=click.Choice(["constant-decel", "bang-bang"]), default="constant-decel",
              show_default=True, help="How the robot brakes into its pit box.")
@click.option("--json", "json_file", type=click.Path(dir_okay=False, path_type=Path), help="Write results as JSON.")
@click.option("--step-budget-ms", default="200", show_default=True,
              help="Wall time a robot may take per drive step before the race is stopped.")
@click.option("--setup-budget-s", default="120", show_default=True,
              help="Wall time a robot may take in initial_fuel_l, on_track, pit_stop or on_race_end.")
@click.option("--set", "settings", multiple=True, metavar="KEY=VALUE",
              help="Override a parameter of the boxbox robot (see `boxbox params`). Repeatable.")
@click.option("--learning", type=click.Choice(["on", "off", "fresh"]), default="on", show_default=True,
              help="Robots' learned data: keep and use it, ignore it, or start from nothing (and keep that).")
@click.option("--run-dir", type=click.Path(file_okay=False, path_type=Path),
              help="Keep this race's files here (default: a new folder under the cache).")
@click.option("--no-telemetry", is_flag=True,
              help="Do not record telemetry (RUN_DIR/telemetry.parquet: every drive step of the Python cars).")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Write the race report (report.html, see `boxbox report`) into this folder.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
def race(track, car, laps, robots, opponents, fuel_laps, pit_laps, pit_mode, json_file, step_budget_ms, settings,
         learning, run_dir, quiet, no_telemetry=False, report_dir=None, setup_budget_s="120") -> None:
    """Run one race in TORCS (console mode) and print the results."""
    from boxbox.report.tables import results_table
    from boxbox.robot.base import RaceOptions
    from boxbox.robot.loader import DEFAULT_ROBOT, load_robot_class
    from boxbox.torcs import catalog, launch

    laps_n = _parse_laps(laps)
    budget = _parse_float("--step-budget-ms", step_budget_ms, 1)
    setup_budget = _parse_float("--setup-budget-s", setup_budget_s, 0.1)
    from boxbox.robot.params import parse_set

    options = RaceOptions(fuel_laps=_parse_float("--fuel-laps", fuel_laps, 0.01),
                          pit_laps=_parse_int_list("--pit-laps", pit_laps), pit_mode=pit_mode,
                          learning_dir=_learning_dir(learning, track, car),
                          robot_args={"set": parse_set(settings)} if settings else {})
    if options.pit_laps and max(options.pit_laps) >= laps_n:
        raise UsageError(f"--pit-laps {pit_laps}: a stop must be before the last lap ({laps_n} laps)")
    specs = list(robots) or [DEFAULT_ROBOT]
    if len(specs) > 10:
        raise UsageError("at most 10 --robot cars per race")
    category = catalog.check_track(track)
    catalog.check_car(car)
    names = []
    for i, spec in enumerate(specs):
        cls = load_robot_class(spec)
        cls.check_setup(options, track, car)
        names.append(f"{cls.name} {i + 1}")
    opp = [catalog.parse_opponent(o) for o in opponents.split(",") if o.strip()]
    if options.pit_laps and not catalog.has_pit_lane(track):
        raise UsageError(f"track '{track}' has no pit lane, so --pit-laps cannot be met; choose a track with pits")
    _check_output_file("--json", json_file)
    overlay = _ready()
    cfg = launch.RaceConfig(track=track, category=category, car=car, laps=laps_n, robots=specs, robot_names=names,
                            opponents=opp, options=options, step_budget_ms=int(budget), run_dir=run_dir,
                            setup_budget_ms=int(setup_budget * 1000),
                            telemetry=not no_telemetry)
    result = _run_with_progress(cfg, overlay, quiet)
    out.print(results_table(result))
    if json_file:
        from boxbox.files import write_json_atomic

        write_json_atomic(json_file, result.to_json(), indent=1)  # whole, even with a race at once on it
    if report_dir is not None:  # also for a race stopped by a fault: its partial telemetry is the point
        from boxbox.report.race_report import write_report

        console.print(f"report: {write_report(Path(result.run_dir), report_dir / 'report.html')}")
    if result.error:
        raise _race_error(result)
    for d in result.drivers:
        if d.module == "boxbox" and d.laps < laps_n:
            console.print(f"[yellow]warning:[/] {d.name} did not finish: {d.laps} of {laps_n} laps "
                          f"(damage {d.damage}, penalty {d.penalty_time:.1f} s)")
        if d.step_us_median is not None:
            console.print(f"[dim]{d.name}: drive step median {d.step_us_median:.1f} us, "
                          f"p99 {d.step_us_p99:.1f} us; run dir {result.run_dir}[/]")


def _check_output_file(name: str, path: Path | None) -> None:
    """The folder of an output file must exist before the race, not only after it."""
    if path is not None and not path.resolve().parent.is_dir():
        raise UsageError(f"{name} {path}: folder {path.resolve().parent} does not exist")


def _learning_dir(mode: str, track: str, car: str) -> str | None:
    """on: the shared learning folder; off: none; fresh: a new empty folder for this race."""
    import tempfile

    from boxbox.torcs.paths import cache_dir

    if mode == "off":
        return None
    if mode == "fresh":
        return tempfile.mkdtemp(prefix="boxbox-learning-")
    return str(cache_dir() / "learning")


def _race_error(result):
    from boxbox.errors import Interrupted, RaceError
    from boxbox.torcs.launch import INTERRUPTED

    first, _, rest = result.error.partition("\n")
    if rest:
        console.print(rest, markup=False, highlight=False)
    return Interrupted(first) if result.error == INTERRUPTED else RaceError(first)


def _run_with_progress(cfg, overlay, quiet: bool):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from boxbox.torcs import launch

    if quiet:
        return launch.run_race(cfg, overlay)
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("laps"),
                  TextColumn("{task.fields[sim]}"), TimeElapsedColumn(), console=console, transient=True) as bar:
        task = bar.add_task(f"{cfg.track} ({cfg.car})", total=cfg.laps, sim="")
        result = launch.run_race(cfg, overlay, lambda lap, t: bar.update(task, completed=lap, sim=f"sim {t:.0f} s"))
    return result


@main_group.command("bench-speed")
@click.option("--track", default="g-track-1", show_default=True)
@click.option("--laps", default="20", show_default=True)
@click.option("--runs", default=3, show_default=True, type=click.IntRange(1, 50), help="Races per robot.")
@click.option("--robot", default="boxbox", show_default=True, help="Python robot to time.")
@click.option("--against", default="bt:2", show_default=True, help="TORCS robot to compare with.")
def bench_speed(track, laps, runs, robot, against) -> None:
    """Wall time of a Python robot's race against a C++ robot's, alternating runs; step times."""
    from boxbox.report.speed import run_speed_bench

    laps_n = _parse_laps(laps)
    overlay = _ready()
    out.print(run_speed_bench(overlay, track, laps_n, runs, robot, against, console))


@main_group.command("bench-pits")
@click.option("--tracks", default="g-track-1,e-track-2,e-track-4,aalborg", show_default=True)
@click.option("--laps", default="6", show_default=True, help="Race length; stops are asked on every lap but the last.")
@click.option("--jobs", default=2, show_default=True, type=click.IntRange(1, 64))
@click.option("--json", "json_file", type=click.Path(dir_okay=False, path_type=Path))
def bench_pits(tracks, laps, jobs, json_file) -> None:
    """Compare the two ways into the box (constant-decel, bang-bang) on real races."""
    from boxbox.report.pitbench import run_pit_bench

    laps_n = _parse_laps(laps)
    if laps_n < 2:
        raise UsageError("--laps must be at least 2 to ask for a stop")
    overlay = _ready()
    table, rows = run_pit_bench(overlay, [t.strip() for t in tracks.split(",") if t.strip()], laps_n, jobs, console)
    out.print(table)
    if json_file:
        json_file.write_text(json.dumps(rows, indent=1))


@main_group.command()
@click.option("--track", default="e-track-2", show_default=True)
@click.option("--car", default="car1-trb1", show_default=True)
@click.option("--set", "settings", multiple=True, metavar="KEY=VALUE", help="Override, as in `boxbox race --set`.")
def params(track, car, settings) -> None:
    """Print the boxbox robot's effective parameters for a track and car, and where each comes from."""
    from rich.table import Table

    from boxbox.robot.params import load_params, parse_set, setup_files

    values, sources = load_params(car, track, parse_set(settings))
    table = Table("parameter", "value", "from", title=f"boxbox robot parameters: {track}, {car}")
    for key, value in vars(values).items():
        src = sources[key]
        table.add_row(key, str(value), src if src in ("default", "--set") else Path(src).name)
    out.print(table)
    out.print("setup files, in order: " + ", ".join(str(p) + ("" if p.exists() else " (absent)")
                                                    for p in setup_files(car, track)))


@main_group.group()
def drill() -> None:
    """Practice drills for single controllers."""


@drill.command("stop")
@click.option("--track", default="e-track-2", show_default=True)
@click.option("--car", default="car1-trb1", show_default=True)
@click.option("--at", "at_m", required=True, help="Marker: distance from the start line (m) to stop at.")
@click.option("--grip-share", default=None, help="Stop deceleration as a share of the grip (default: the robot's).")
@click.option("--json", "json_file", type=click.Path(dir_okay=False, path_type=Path))
def drill_stop(track, car, at_m, grip_share, json_file) -> None:
    """Drive a lap and stop at a marker with the constant-deceleration stop controller."""
    from rich.table import Table

    from boxbox.robot.base import RaceOptions
    from boxbox.torcs import catalog, launch

    category = catalog.check_track(track)
    catalog.check_car(car)
    at = _parse_float("--at", at_m, 0.0)
    args = {"drill_at_m": at}
    if grip_share is not None:
        args["drill_grip_share"] = _parse_float("--grip-share", grip_share, 0.05)
    overlay = _ready()
    cfg = launch.RaceConfig(track=track, category=category, car=car, laps=1,
                            robots=["boxbox.robot.drill:StopDrill"], robot_names=["drill 1"],
                            options=RaceOptions(robot_args=args))
    result = _run_with_progress(cfg, overlay, quiet=False)
    if result.error:
        raise _race_error(result)
    report = result.drivers[0].report.get("drill", {})
    if json_file:
        json_file.write_text(json.dumps(report, indent=1))
    table = Table("measure", "value", title=f"stop drill: {track}, {car}, marker at {at:.1f} m")
    labels = [("stop_error_m", "stop error (m, + past the marker)"), ("stop_time_s", "time from latch to standstill (s)"),
              ("latch_speed_mps", "speed at the latch (m/s)"), ("latch_dist_m", "distance at the latch (m)"),
              ("latch_decel_mps2", "A at the latch (m/s^2)"), ("peak_decel_mps2", "peak deceleration (m/s^2)"),
              ("mean_decel_mps2", "mean deceleration (m/s^2)"), ("decel_sd_mps2", "deceleration s.d. (m/s^2)"),
              ("decel_cv", "steadiness: s.d. / mean")]
    for key, label in labels:
        table.add_row(label, str(report.get(key, "-")))
    out.print(table)
    if report.get("phase") != "done":
        from boxbox.errors import RaceError

        raise RaceError(f"the drill did not complete its stop (phase '{report.get('phase')}'); "
                        "try another marker, away from a turn")


@main_group.command()
def setup() -> None:
    """Install TORCS and its headers, build the bridge and the overlay (idempotent)."""
    overlay = _ready()
    out.print(f"bridge: {overlay.bridge}\noverlay: {overlay.lib_dir.parent}")


@main_group.command()
def doctor() -> None:
    """Say what is present and what is missing."""
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


@main_group.command()
def tracks() -> None:
    """List the installed tracks."""
    from boxbox.torcs import catalog

    for name, category in sorted(catalog.tracks().items(), key=lambda kv: (kv[1], kv[0])):
        out.print(f"{category:6} {name}")


@main_group.command()
def cars() -> None:
    """List the installed cars."""
    from boxbox.torcs import catalog

    for name in catalog.cars():
        out.print(name)


@main_group.command("robots")
def robots_cmd() -> None:
    """List boxbox's built-in robots and the installed TORCS robots."""
    from boxbox.robot.loader import BUILTIN
    from boxbox.torcs import catalog

    for name, target in BUILTIN.items():
        out.print(f"python  {name:10} {target}")
    for module in catalog.robot_modules():
        for idx, info in sorted(catalog.robot_indices(module).items()):
            out.print(f"torcs   {module}:{idx:<6} {info['name']} ({info['car']})")


def _register_report_commands() -> None:
    """The commands that live in report/ (benchmarks, the HTML report, sweep, soak)."""
    from boxbox.report.bench_cli import bench
    from boxbox.report.reliability_cli import soak, sweep
    from boxbox.report.report_cli import bench_telemetry, report_cmd

    for command in (bench, report_cmd, bench_telemetry, sweep, soak):
        main_group.add_command(command)


_register_report_commands()


def _sigterm_as_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt  # a race stops as on Ctrl-C: TORCS stopped, results so far written


def main() -> None:
    import signal

    signal.signal(signal.SIGTERM, _sigterm_as_interrupt)
    try:
        main_group.main(standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.exceptions.Abort:
        console.print("boxbox: aborted")
        sys.exit(130)
    except click.UsageError as exc:
        console.print(f"boxbox: error: {exc.format_message()} (see --help)", markup=False, highlight=False)
        sys.exit(2)
    except BoxboxError as exc:
        console.print(f"boxbox: error: {exc}", markup=False, highlight=False)
        sys.exit(exc.exit_code)


if __name__ == "__main__":
    main()
