"""`boxbox race`, `boxbox params` and `boxbox drill stop`."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from boxbox.cli.common import err, out, race_error, ready, run_with_progress
from boxbox.cli.types import (
    FUEL_LAPS,
    LAP_LIST,
    LAPS,
    LEARNING,
    PIT_MODE,
    SETUP_BUDGET_S,
    CommaList,
    FiniteFloatRange,
    GridPosition,
    InputFile,
    OutputDir,
    OutputFile,
    skill_level_option,
    step_budget_option,
)
from boxbox.errors import Interrupted, UsageError

if TYPE_CHECKING:
    from boxbox.torcs.signals import StopSignals

SET_HELP = ("Set a parameter of the robots that declare it (see `boxbox params --robot SPEC`), "
            "e.g. --set mu_scale=0.9. Repeatable.")


@click.command()
@click.option("--track", default="e-track-2", show_default=True,
              help="Track name, e.g. g-track-1 (`boxbox tracks` lists them; the category is found for you).")
@click.option("--car", default="car1-trb1", show_default=True, help="Car of the Python robots (`boxbox cars`).")
@click.option("--laps", type=LAPS, default=3, show_default=True, help="Race length in laps.")
@click.option("--robot", "robots", multiple=True, metavar="SPEC",
              help="Python robot: NAME (boxbox, middle), path/file.py:Class or module:Class. "
                   "Repeat for more cars, e.g. --robot my_robot.py:MyRobot --robot boxbox.")
@click.option("--opponents", type=CommaList("MODULE:IDX,...", unique=False), default="",
              help="TORCS robots, e.g. bt:2,berniw:3 (`boxbox robots` lists them; each at most once).")
@click.option("--fuel-laps", type=FUEL_LAPS, help="Start with fuel for this many laps, e.g. 5.")
@click.option("--pit-laps", type=LAP_LIST, default="", help="Ask for pit stops on these laps, e.g. 3,7.")
@click.option("--pit-mode", type=PIT_MODE, default="constant-decel", show_default=True,
              help="How the robot brakes into its pit box.")
@click.option("--json", "json_file", type=OutputFile(), help="Write the results as JSON, e.g. --json r.json.")
@step_budget_option
@click.option("--setup-budget-s", type=SETUP_BUDGET_S, default=120, show_default=True,
              help="Wall time a robot may take in initial_fuel_l, on_track, pit_stop or on_race_end.")
@click.option("--memory-limit", "memory_limit_gib", type=FiniteFloatRange(0.1, 1024), default=4, show_default=True,
              help="Memory (GiB of address space) the robots may take beyond what their process starts with; "
                   "more is the robot's fault, said in one line, e.g. --memory-limit 8.")
@click.option("--set", "settings", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
@click.option("--setup", "setup_file", type=InputFile(),
              help="Robot parameters from a TOML setup file (`name = value` lines, as `boxbox tune` writes); "
                   "--set wins over it.")
@click.option("--learning", type=LEARNING, default="fresh", show_default=True,
              help="Robots' learned data: the shared store (kept and used: on), none (off), or from nothing "
                   "in this race (fresh, the default: the same race gives the same result).")
@click.option("--run-dir", type=OutputDir(), help="Keep this race's files here, e.g. out/r1 "
                                                  "(default: a new folder under the cache).")
@click.option("--no-telemetry", is_flag=True,
              help="Do not record telemetry (RUN_DIR/telemetry.parquet: every drive step of the Python cars) "
                   "nor the race for `boxbox replay`.")
@click.option("--report", "report_dir", type=OutputDir(),
              help="Write the race report (report.html, see `boxbox report`) into this folder, e.g. out/.")
@click.option("--grid-position", type=GridPosition(), default=None,
              help="Where the Python cars start: 1 (pole, the default) .. or 'last'; the TORCS robots fill the "
                   "other slots in the order given, e.g. --grid-position last.")
@skill_level_option
@click.option("--quiet", is_flag=True,
              help="No progress bar, and what the robots print not shown (it is always kept in RUN_DIR/host.log).")
def race(track, car, laps, robots, opponents, fuel_laps, pit_laps, pit_mode, json_file, step_budget_ms, settings,
         setup_file, setup_budget_s, memory_limit_gib, learning, run_dir, no_telemetry, report_dir, grid_position,
         skill_level, quiet) -> None:
    """Run one race in TORCS (console mode) and print the results.

    \b
    Examples:
      boxbox race --track g-track-1 --laps 2 --json r.json
      boxbox race --robot my_robot.py:MyRobot --opponents bt:2,berniw:3
      boxbox race --laps 5 --fuel-laps 3 --pit-laps 2 --report out/
      boxbox race --opponents inferno:3,bt:2 --grid-position last --skill-level pro
    """
    from boxbox.robot.base import race_options
    from boxbox.robot.loader import DEFAULT_ROBOT
    from boxbox.robot.params import parse_set
    from boxbox.torcs import checks, launch
    from boxbox.torcs.signals import StopSignals

    specs = list(robots) or [DEFAULT_ROBOT]
    values = {**_setup_values(setup_file, specs, setup_budget_s), **parse_set(settings)}
    options = race_options(values, fuel_laps=fuel_laps, pit_laps=tuple(sorted(pit_laps)), pit_mode=pit_mode)
    names = checks.check_robots(specs, options, track, car, setup_budget_s)
    overlay = ready()  # first: on a fresh machine the names below can only be checked once TORCS is there
    category, opp = checks.check_race(track, car, len(specs), opponents, pit_laps, laps)
    grid_slot = checks.check_grid_position(grid_position, len(opp))
    cfg = launch.RaceConfig(track=track, category=category, car=car, laps=laps, robots=specs, robot_names=names,
                            opponents=opp, options=options, step_budget_ms=int(step_budget_ms), run_dir=run_dir,
                            setup_budget_ms=int(setup_budget_s * 1000), telemetry=not no_telemetry,
                            skill_level=skill_level, grid_position=grid_slot, learning=learning,
                            json_file=json_file, show_prints=not quiet,
                            memory_limit_gib=memory_limit_gib)  # the race writes RUN_DIR/result.json, then this
    with StopSignals() as stop:  # a Ctrl-C after the finish: the table and report first, then exit 130
        _finish(run_with_progress(cfg, overlay, quiet), laps, report_dir, stop)


def _setup_values(setup_file: Path | None, specs: list[str], budget_s: float) -> dict:
    """--setup FILE's values, checked against the robots that declare parameters."""
    if setup_file is None:
        return {}
    from boxbox.robot.loader import load_robot_class
    from boxbox.robot.tunable import check_setup_for, read_setup

    values = read_setup(setup_file)
    check_setup_for([load_robot_class(s, budget_s) for s in specs], values, str(setup_file))
    return values



def _finish(result, laps: int, report_dir: Path | None, stop: StopSignals) -> None:
    """The table and the report (also for a race stopped by a fault), then the verdict (the race has
    written its JSON: RUN_DIR/result.json, then --json); a stop signal that came after the race's
    result was made is said last, as Interrupted (130)."""
    from boxbox.report.tables import results_table
    from boxbox.torcs.pitwatch import NOT_ASKED

    out.print(results_table(result))
    for d in result.drivers:
        for miss in d.missed_pit_stops:
            if miss["reason"] == NOT_ASKED:
                err.print(f"[yellow]warning:[/] {d.name} never asked for the pit stop --pit-laps asked for on lap "
                          f"{miss['lap']}: {miss['detail']}")
            else:
                err.print(f"[yellow]warning:[/] {d.name} asked for a pit stop on lap {miss['lap']} that was not "
                          f"made: {miss['reason']} ({miss['detail']})")
    if report_dir is not None:  # a faulted race's partial telemetry is the point of its report
        _write_report(Path(result.run_dir), report_dir)
    if result.error:
        raise race_error(result)
    for d in result.drivers:
        if d.is_python and d.laps < laps:
            err.print(f"[yellow]warning:[/] {d.name} did not finish: {d.laps} of {laps} laps "
                      f"(damage {d.damage}, penalty {d.penalty_time:.1f} s)")
        if d.step_us_median is not None:
            err.print(f"[dim]{d.name}: drive step median {d.step_us_median:.1f} us, "
                      f"p99 {d.step_us_p99:.1f} us; run dir {result.run_dir}[/]")
    if stop.stopped:
        raise Interrupted(f"interrupted ({stop.names()}) after the race ended; its results are kept, "
                          f"shown above (run dir {result.run_dir})")


def _write_report(run_dir: Path, report_dir: Path) -> None:
    """The race's report; one that fails is a warning: the race's own outcome and exit status stand."""
    from rich.markup import escape

    from boxbox.report.race_report import write_report

    try:
        err.print(f"report: {write_report(run_dir, report_dir / 'report.html')}")
    except Exception as exc:  # noqa: BLE001  (whatever it was, the race's result comes first)
        err.print(f"[yellow]warning:[/] the report was not written: {escape(f'{type(exc).__name__}: {exc}')} "
                  f"(try `boxbox report {escape(str(run_dir))}`)", highlight=False)


@click.command()
@click.option("--track", default="e-track-2", show_default=True, help="Track name, e.g. g-track-1.")
@click.option("--car", default="car1-trb1", show_default=True, help="Car name, e.g. car1-trb1.")
@click.option("--robot", "robot_spec", default="boxbox", show_default=True, metavar="SPEC",
              help="The robot: NAME (boxbox, middle), path/file.py:Class or module:Class, "
                   "e.g. --robot my_robot.py:MyRobot.")
@click.option("--set", "settings", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
def params(track, car, robot_spec, settings) -> None:
    """Print a robot's effective parameters and the car's setup for a track and car: each value,
    where it comes from, and the range a study searches.

    \b
    Examples:
      boxbox params --track aalborg --set mu_scale=0.9
      boxbox params --robot my_robot.py:MyRobot --car car1-trb3 --set gear_ratio_2=2.1
    """
    from boxbox.robot.base import race_options
    from boxbox.robot.loader import load_robot_class
    from boxbox.robot.params import parse_set
    from boxbox.torcs import checks

    cls = load_robot_class(robot_spec)
    options = race_options(parse_set(settings))  # the car setup's settings apart from the robot's
    checks.check_car_setup(options.car_setup, car)
    _robot_params(cls, track, car, options.robot_args.get("set") or {})
    _car_setup(car, options.car_setup)


def _robot_params(cls, track: str, car: str, overrides: dict) -> None:
    """The robot's parameters: value, where it comes from, the range a study searches."""
    from rich.table import Table

    from boxbox.robot.params import TutorialParams, load_params, setup_files
    from boxbox.robot.tunable import declares_params, param_space

    if cls.param_class is TutorialParams:  # the boxbox robot: its setup files, then --set
        values, sources = load_params(car, track, overrides)
        rows = [(k, v, sources[k]) for k, v in vars(values).items()]
        files = setup_files(car, track)
    elif declares_params(cls):  # any other robot: its declared defaults, then --set
        space = param_space(cls)
        given = space.check(overrides, "--set")
        rows = [(k, given.get(k, v), "--set" if k in given else "default") for k, v in space.defaults.items()]
        files = []
    else:
        if overrides:
            raise UsageError(f"--set: robot {cls.name} declares no parameters to set (see docs/tuning.md)")
        out.print(f"robot {cls.name} declares no parameters (a robot declares them with `param_class`, "
                  "see docs/tuning.md)")
        return
    space = param_space(cls)
    table = Table("parameter", "value", "range", "from", title=f"{cls.name} robot parameters: {track}, {car}")
    for key, value, src in rows:
        table.add_row(key, str(value), space.range_text(key), src if src in ("default", "--set") else Path(src).name)
    out.print(table)
    if files:
        out.print("setup files, in order: " + ", ".join(str(p) + ("" if p.exists() else " (absent)") for p in files))


def _car_setup(car: str, given: dict) -> None:
    """The car's setup settings, by group: the value the race gives the car, its unit and range."""
    from rich.table import Table

    from boxbox.torcs import catalog
    from boxbox.torcs.car_setup import setting_rows

    if not catalog.cars():  # only a race sets TORCS up: its cars are not there to read yet
        out.print(f"car setup: {car}'s settings are read from TORCS, which is not set up yet (`boxbox setup`)")
        return
    table = Table("part", "setting", "value", "unit", "range", "from", title=f"car setup: {car}, SI units",
                  caption="set them with --set or a setup file (gear_ratios=3.0,2.1,... sets the gears from first "
                          "on); they win over the robot's car_setup(), which may set others per track")
    group = None
    for row in setting_rows(car, given):
        fixed = row.car is not None and row.car.lo == row.car.hi
        span = "not in the car's files" if row.car is None else "fixed" if fixed else \
            f"{row.car.lo:.6g} to {row.car.hi:.6g}"
        table.add_row(row.group if row.group != group else "", row.name,
                      "-" if row.value is None else f"{row.value:.6g}", row.unit, span,
                      row.source if row.value is not None else "")
        group = row.group
    out.print(table)


@click.group()
def drill() -> None:
    """Practice drills for single controllers."""


DRILL_LABELS = [("stop_error_m", "stop error (m, + past the marker)"),
                ("stop_time_s", "time from latch to standstill (s)"),
                ("latch_speed_mps", "speed at the latch (m/s)"), ("latch_dist_m", "distance at the latch (m)"),
                ("latch_decel_mps2", "A at the latch (m/s^2)"), ("peak_decel_mps2", "peak deceleration (m/s^2)"),
                ("mean_decel_mps2", "mean deceleration (m/s^2)"), ("decel_sd_mps2", "deceleration s.d. (m/s^2)"),
                ("decel_cv", "steadiness: s.d. / mean")]


@drill.command("stop")
@click.option("--track", default="e-track-2", show_default=True, help="Track name, e.g. g-track-1.")
@click.option("--car", default="car1-trb1", show_default=True, help="Car name, e.g. car1-trb1.")
@click.option("--at", "at_m", type=FiniteFloatRange(0, 100_000), required=True,
              help="Marker: distance from the start line (m) to stop at, e.g. 1500.")
@click.option("--grip-share", type=FiniteFloatRange(0.05, 2), default=None,
              help="Stop deceleration as a share of the grip, e.g. 0.8 (default: the robot's).")
@click.option("--json", "json_file", type=OutputFile(), help="Write the measures as JSON.")
def drill_stop(track, car, at_m, grip_share, json_file) -> None:
    """Drive a lap and stop at a marker with the constant-deceleration stop controller.

    Example: boxbox drill stop --track e-track-2 --at 1500
    """
    from rich.table import Table

    from boxbox.errors import RaceError
    from boxbox.files import write_json_atomic
    from boxbox.robot.base import RaceOptions
    from boxbox.torcs import checks, launch

    args = {"drill_at_m": at_m} if grip_share is None else {"drill_at_m": at_m, "drill_grip_share": grip_share}
    overlay = ready()
    category, _ = checks.check_race(track, car, 1)
    cfg = launch.RaceConfig(track=track, category=category, car=car, laps=1,
                            robots=["boxbox.robot.drill:StopDrill"], robot_names=["drill 1"],
                            options=RaceOptions(robot_args=args))
    result = run_with_progress(cfg, overlay)
    if result.error:
        raise race_error(result)
    report = result.drivers[0].report.get("drill", {})
    if json_file:
        write_json_atomic(json_file, report, indent=1)
    table = Table("measure", "value", title=f"stop drill: {track}, {car}, marker at {at_m:.1f} m")
    for key, label in DRILL_LABELS:
        table.add_row(label, str(report.get(key, "-")))
    out.print(table)
    if report.get("phase") != "done":
        raise RaceError(f"the drill did not complete its stop (phase '{report.get('phase')}'); "
                        "try another marker, away from a turn")
