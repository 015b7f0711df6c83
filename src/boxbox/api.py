"""`boxbox.race(...)`: one race from Python (a script, a test or a notebook), its typed result back.

    import boxbox

    result = boxbox.race(track="g-track-1", laps=3, robots=[MyRobot, "boxbox"], opponents=["bt:2"])
    print(result.drivers[0].best_lap)
    laps = result.telemetry()          # every drive step of the Python cars, a polars DataFrame

The same checks as `boxbox race` run first (a bad name or number raises boxbox.UsageError with a
one-line message), TORCS is set up when it is missing, and the race runs in its own run dir.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from boxbox import validate
from boxbox.model.skill import SkillLevel
from boxbox.options import LearningMode, PitMode
from boxbox.robot.base import Robot, race_options
from boxbox.torcs import results

if TYPE_CHECKING:
    import polars


@dataclass
class RaceResult(results.RaceResult):
    """What `boxbox race --json` writes (track, category, car, laps, skill_level, wall_s, drivers,
    run_dir, error), with the race's telemetry and report a call away."""

    def telemetry(self) -> polars.DataFrame:
        """Every drive step of the Python cars (RUN_DIR/telemetry.parquet; columns in docs/report.md)."""
        import polars

        path = Path(self.run_dir) / "telemetry.parquet"
        if not path.exists():
            raise FileNotFoundError(f"{path}: no telemetry (raced with telemetry=False, or no Python car)")
        return polars.read_parquet(path)

    def report(self, out_dir: str | Path | None = None) -> Path:
        """Write the HTML race report (default: RUN_DIR/report.html); returns its path."""
        from boxbox.report.race_report import write_report

        folder = Path(out_dir) if out_dir is not None else Path(self.run_dir)
        return Path(write_report(Path(self.run_dir), folder / "report.html"))


def race(track: str = "e-track-2", *, laps: int = 3, robots: str | type[Robot] | Sequence[str | type[Robot]] = (
        "boxbox",), opponents: str | Sequence[str] = (), car: str = "car1-trb1",
         skill_level: str | SkillLevel = "semi-pro", grid_position: int | str | None = None,
         learning: LearningMode = "fresh", pit_laps: str | Sequence[int] = (), fuel_laps: float | None = None,
         pit_mode: PitMode = "constant-decel", settings: dict | str | Sequence[str] | None = None,
         run_dir: str | Path | None = None, telemetry: bool = True, step_budget_ms: float = 200,
         setup_budget_s: float = 120, report: bool | str | Path = False,
         setup: str | Path | None = None) -> RaceResult:
    """Race the Python `robots` against TORCS's `opponents` on `track`, and return the result.

    robots: one robot or a list of them, each a class or a spec ('boxbox', 'path/file.py:Class',
    'module:Class'); a string is one robot, as one --robot is. opponents: 'bt:2,berniw:3' (as
    --opponents) or a list ['bt:2', 'berniw:3']. skill_level: one level for every car
    (docs/rules.md). grid_position: the Python cars' first slot, 1 (pole, the default) .. 40 or
    'last'. learning: 'fresh' (the default, as for `boxbox race`: the robots learn from nothing in
    this race, so the same call gives the same race), 'on' (the shared store, kept across races)
    or 'off'. pit_laps: '3,7' or [3, 7]. settings: robot parameters, a dict {'mu_scale': 0.9} or
    'KEY=VALUE' strings as --set; setup: a TOML setup file of them, as --setup (settings win over
    it). report: True writes RUN_DIR/report.html, a folder writes it there (one that fails is a
    warning). step_budget_ms, setup_budget_s: as --step-budget-ms and --setup-budget-s.

    Every argument is checked first, with the command line's checks (boxbox/validate.py): a bad
    one raises boxbox.UsageError (also a ValueError) with one line, before TORCS starts.
    """
    from boxbox.robot.loader import load_robot_class
    from boxbox.torcs import checks, launch
    from boxbox.torcs import setup as torcs_setup
    from boxbox.torcs.signals import restore_handlers

    args = _checked(track=track, laps=laps, robots=robots, opponents=opponents, car=car, skill_level=skill_level,
                    grid_position=grid_position, learning=learning, pit_laps=pit_laps, fuel_laps=fuel_laps,
                    pit_mode=pit_mode, settings=settings, run_dir=run_dir, telemetry=telemetry,
                    step_budget_ms=step_budget_ms, setup_budget_s=setup_budget_s, report=report, setup=setup)
    specs, values = args["specs"], args["settings"]
    if args["setup"] is not None:
        from boxbox.robot.tunable import check_setup_for, read_setup

        from_file = read_setup(args["setup"])
        check_setup_for([load_robot_class(s, args["setup_budget_s"]) for s in specs], from_file, str(args["setup"]))
        values = {**from_file, **values}
    options = race_options(values, fuel_laps=args["fuel_laps"], pit_laps=tuple(sorted(args["pit_laps"])),
                           pit_mode=args["pit_mode"])
    names = checks.check_robots(specs, options, args["track"], args["car"], args["setup_budget_s"])
    overlay = torcs_setup.ensure_ready()
    category, opp = checks.check_race(args["track"], args["car"], len(specs), args["opponents"], args["pit_laps"],
                                      args["laps"])
    cfg = launch.RaceConfig(
        track=args["track"], category=category, car=args["car"], laps=args["laps"], robots=specs, robot_names=names,
        opponents=opp, options=options, step_budget_ms=int(args["step_budget_ms"]),
        setup_budget_ms=int(args["setup_budget_s"] * 1000), telemetry=args["telemetry"], run_dir=args["run_dir"],
        skill_level=args["skill_level"], learning=args["learning"],
        grid_position=checks.check_grid_position(args["grid_position"], len(opp)))
    try:
        raced = launch.run_race(cfg, overlay)
    finally:
        restore_handlers()  # a race stopped by Ctrl-C leaves its own handler in place
    result = RaceResult(**{f.name: getattr(raced, f.name) for f in dataclasses.fields(raced)})
    if args["report"] is not False:
        _report(result, None if args["report"] is True else args["report"])
    return result


def _report(result: RaceResult, out_dir: Path | None) -> None:
    """The race's report; one that fails is a warning, as on the command line: the result stands."""
    try:
        result.report(out_dir)
    except Exception as exc:  # noqa: BLE001 (any report failure: the race's result is what matters)
        warnings.warn(f"the report was not written: {type(exc).__name__}: {exc}; try result.report()", stacklevel=3)


def _checked(**given: Any) -> dict[str, Any]:
    """Every argument of `race` checked as the command line checks its options (validate.py), each
    UsageError naming the argument; robot classes become specs."""
    from boxbox.robot.loader import spec_for_class

    out = {"track": validate.text(given["track"], "track name", "g-track-1", name="track"),
           "car": validate.text(given["car"], "car name", "car1-trb1", name="car"),
           "laps": validate.laps(given["laps"], name="laps"),
           "opponents": validate.opponent_list(given["opponents"], name="opponents"),
           "grid_position": validate.grid_position(given["grid_position"], name="grid_position"),
           "learning": validate.learning_mode(given["learning"], name="learning"),
           "pit_laps": validate.lap_list(given["pit_laps"], name="pit_laps"),
           "fuel_laps": validate.fuel_laps(given["fuel_laps"], name="fuel_laps"),
           "pit_mode": validate.pit_mode(given["pit_mode"], name="pit_mode"),
           "settings": validate.settings(given["settings"], name="settings"),
           "telemetry": validate.flag(given["telemetry"], name="telemetry"),
           "step_budget_ms": validate.step_budget_ms(given["step_budget_ms"], name="step_budget_ms"),
           "setup_budget_s": validate.setup_budget_s(given["setup_budget_s"], name="setup_budget_s"),
           "setup": None if given["setup"] is None else validate.input_file(given["setup"], name="setup")}
    level = given["skill_level"]
    out["skill_level"] = level if isinstance(level, SkillLevel) else SkillLevel.parse(
        validate.skill_level(level, name="skill_level"))
    out["run_dir"] = None if given["run_dir"] is None else validate.output_dir(given["run_dir"], name="run_dir")
    report = given["report"]  # False, True (into the run dir) or a folder
    out["report"] = report if isinstance(report, bool) else validate.output_dir(report, name="report")
    out["specs"] = [r if isinstance(r, str) else spec_for_class(r)
                    for r in validate.robot_list(given["robots"], name="robots")]
    return out

