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
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from boxbox.errors import UsageError
from boxbox.model.skill import SkillLevel
from boxbox.options import LEARNING_MODES, PIT_MODES, LearningMode, PitMode
from boxbox.robot.base import RaceOptions, Robot
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


def race(track: str = "e-track-2", *, laps: int = 3, robots: Sequence[str | type[Robot]] = ("boxbox",),
         opponents: Sequence[str] = (), car: str = "car1-trb1", skill_level: str | SkillLevel = "semi-pro",
         grid_position: int | str | None = None, learning: LearningMode = "fresh", pit_laps: Sequence[int] = (),
         fuel_laps: float | None = None, pit_mode: PitMode = "constant-decel", settings: dict | None = None,
         run_dir: str | Path | None = None, telemetry: bool = True, step_budget_ms: int = 200,
         report: bool | str | Path = False, setup: str | Path | None = None) -> RaceResult:
    """Race the Python `robots` (classes or specs: 'boxbox', 'path/file.py:Class', 'module:Class')
    against TORCS's `opponents` ('module:idx') on `track`, and return the result.

    skill_level: one level for every car (docs/rules.md). grid_position: the Python cars' first
    slot, 1 (pole, the default) or 'last'. learning: 'fresh' (default: nothing learned before
    counts), 'on' (the shared store) or 'off'. settings: robot parameters, as `--set`; setup: a
    TOML setup file of them, as `--setup` (settings win over it).
    report: True writes RUN_DIR/report.html, a folder writes it there.
    """
    from boxbox.robot.loader import load_robot_class, spec_for_class
    from boxbox.torcs import checks, launch
    from boxbox.torcs import setup as torcs_setup
    from boxbox.torcs.signals import restore_handlers

    level = skill_level if isinstance(skill_level, SkillLevel) else _parse_level(skill_level)
    _check_choices(laps, learning, pit_mode)
    specs = [r if isinstance(r, str) else spec_for_class(r) for r in robots]
    values = dict(settings or {})
    if setup is not None:
        from boxbox.robot.tunable import check_setup_for, read_setup

        from_file = read_setup(setup)
        check_setup_for([load_robot_class(s) for s in specs], from_file, str(setup))
        values = {**from_file, **values}
    options = RaceOptions(fuel_laps=fuel_laps, pit_laps=tuple(sorted(pit_laps)), pit_mode=pit_mode,
                          robot_args={"set": values} if values else {})
    names = []
    for i, spec in enumerate(specs):
        cls = load_robot_class(spec)
        cls.check_setup(options, track, car)
        names.append(f"{cls.name} {i + 1}")
    overlay = torcs_setup.ensure_ready()
    category, opp = checks.check_race(track, car, len(specs), list(opponents), list(pit_laps), laps)
    cfg = launch.RaceConfig(track=track, category=category, car=car, laps=laps, robots=specs, robot_names=names,
                            opponents=opp, options=options, step_budget_ms=step_budget_ms, telemetry=telemetry,
                            run_dir=Path(run_dir).resolve() if run_dir is not None else None, skill_level=level,
                            grid_position=checks.check_grid_position(grid_position, len(opp)), learning=learning)
    try:
        raced = launch.run_race(cfg, overlay)
    finally:
        restore_handlers()  # a race stopped by Ctrl-C leaves its own handler in place
    result = RaceResult(**{f.name: getattr(raced, f.name) for f in dataclasses.fields(raced)})
    if report:
        result.report(None if report is True else report)
    return result


def _parse_level(text: str) -> SkillLevel:
    try:
        return SkillLevel.parse(text)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _check_choices(laps: int, learning: str, pit_mode: str) -> None:
    if not isinstance(laps, int) or not 1 <= laps <= 10_000:
        raise UsageError(f"laps must be a whole number from 1 to 10000, got {laps!r}")
    if learning not in LEARNING_MODES:
        raise UsageError(f"learning must be one of {', '.join(LEARNING_MODES)}, got {learning!r}")
    if pit_mode not in PIT_MODES:
        raise UsageError(f"pit_mode must be one of {', '.join(PIT_MODES)}, got {pit_mode!r}")
