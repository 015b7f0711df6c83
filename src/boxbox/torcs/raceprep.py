"""What a race needs before TORCS starts: its config, its robots' learning store, its local dir
with the race file and the driver files, and TORCS's command line (torcs/launch.py runs the race;
the Gymnasium env prepares its races the same way, gym/race.py).
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from boxbox.cache import cache_dir
from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.options import LearningMode
from boxbox.robot.base import RaceOptions
from boxbox.torcs.paths import ROBOT_MODULE
from boxbox.torcs.racefile import GRID_TO_START_M, grid, race_xml, robot_xml, with_skill_level
from boxbox.torcs.rundir import RunDir
from boxbox.torcs.setup import Overlay
from boxbox.torcs.timing import MIN_SPEED_MPS, TimeModel

MEMORY_LIMIT_GIB = 4.0  # the robots' allowance of memory, beyond what the host starts with


@dataclass
class RaceConfig:
    track: str
    category: str
    car: str = "car1-trb1"
    laps: int = 3
    robots: list[str] = field(default_factory=lambda: ["boxbox"])  # Python robot specs
    robot_names: list[str] = field(default_factory=list)
    opponents: list[tuple[str, int]] = field(default_factory=list)  # TORCS robots (module, idx)
    options: RaceOptions = field(default_factory=RaceOptions)
    # the time model (torcs/timing.py): budgets per robot call, the slowest average allowed, and
    # the wall limit (None: derived from the others and the race's length)
    step_budget_ms: int = 200
    # on_track and friends: the tutorial robot's first race on the 22 km spring computes its
    # racing line for ~30 s alone (longer with parallel races), so set-up gets room
    setup_budget_ms: int = 120_000
    min_speed_mps: float = MIN_SPEED_MPS
    wall_limit_s: float | None = None
    # address space the robots may map beyond what the host starts with (GiB; None: no limit): more
    # is a MemoryError in the robot, its fault, instead of the OOM killer's SIGKILL of anything
    memory_limit_gib: float | None = MEMORY_LIMIT_GIB
    cpu: int | None = None
    run_dir: Path | None = None  # None: a new folder under CACHE/runs (the oldest pruned, keep_runs kept)
    json_file: Path | None = None  # the result is also written here, after RUN_DIR/result.json
    telemetry: bool = True  # record every drive step of the Python cars in RUN_DIR/telemetry.parquet
    show_prints: bool = False  # show what the robots print (RUN_DIR/host.log) on stderr as the race runs
    keep_runs: int | None = None  # automatic run dirs kept (None: $BOXBOX_KEEP_RUNS or 50)
    skill_level: SkillLevel = DEFAULT_SKILL_LEVEL  # for every car in the race, boxbox's and TORCS's
    grid_position: int | None = None  # the Python cars' first grid slot (1 = pole, the default)
    # the starting grid: the pole's distance behind the start line and every car's speed when placed
    # (the Gymnasium env draws them per episode: a start anywhere along the track)
    grid_to_start_m: float = GRID_TO_START_M
    start_speed_mps: float = 0.0
    # the robots' learned data: on (the shared store), fresh (a new store in the run dir), off
    # (none); None: options.learning_dir as given. Kept per skill level either way.
    learning: LearningMode | None = None
    # litres added to each Python car's start fuel after its robot chose it (bench-field --repeats:
    # grams that change nothing of the car's pace but reorder a chaotic field race)
    fuel_offset_l: float = 0.0

    def __post_init__(self) -> None:
        # relative paths are the caller's: TORCS runs in another working directory
        if self.run_dir is not None:
            self.run_dir = RunDir(self.run_dir).path
        if self.json_file is not None:
            self.json_file = Path(os.path.abspath(self.json_file))

    @property
    def names(self) -> list[str]:
        return self.robot_names or [f"boxbox {i + 1}" for i in range(len(self.robots))]

    @property
    def time_model(self) -> TimeModel:
        return TimeModel(self.step_budget_ms, self.setup_budget_ms, self.min_speed_mps)

    def wall_limit(self, length_m: float | None) -> float:
        if self.wall_limit_s is not None:
            return self.wall_limit_s
        return self.time_model.wall_limit_s(self.laps, length_m, len(self.robots),
                                            len(self.robots) + len(self.opponents))


def learning_store(cfg: RaceConfig, run_dir: RunDir) -> str | None:
    """The folder robots keep what they learn in, one per skill level: what is learned at one level
    is not used at another (the tyres give different grip)."""
    if cfg.learning == "off" or (cfg.learning is None and not cfg.options.learning_dir):
        return None
    if cfg.learning == "on":
        base = cache_dir() / "learning"
    elif cfg.learning == "fresh":
        base = run_dir.path / "learning"  # goes with the run dir: nothing left in the temp dir
    else:
        base = Path(str(cfg.options.learning_dir))
    store = base / cfg.skill_level.torcs_name
    store.mkdir(parents=True, exist_ok=True)
    return str(store)


def prepare_local_dir(run_dir: RunDir, overlay: Overlay, cfg: RaceConfig) -> Path:
    local = run_dir.local
    (local / "config").mkdir(parents=True, exist_ok=True)
    shutil.copy(overlay.torcs.data_dir / "config" / "raceengine.xml", local / "config" / "raceengine.xml")
    drivers = local / "drivers" / ROBOT_MODULE
    drivers.mkdir(parents=True, exist_ok=True)
    (drivers / f"{ROBOT_MODULE}.xml").write_text(robot_xml([(n, cfg.car) for n in cfg.names], cfg.skill_level))
    write_driver_files(local, overlay.torcs.data_dir, cfg.opponents, cfg.skill_level)
    entries = grid(len(cfg.robots), cfg.opponents, cfg.grid_position)
    run_dir.race_file.write_text(race_xml(cfg.track, cfg.category, cfg.laps, entries, cfg.grid_to_start_m,
                                          cfg.start_speed_mps))
    return local


def torcs_command(overlay: Overlay, run_dir: RunDir) -> list[str]:
    """TORCS in console mode on a race's folder (also the Gymnasium env's, gym/race.py)."""
    return [str(overlay.torcs.binary), "-l", f"{run_dir.local}/", "-L", f"{overlay.lib_dir}/", "-D",
            f"{overlay.data_dir}/", "-r", str(run_dir.race_file)]


def write_driver_files(local: Path, data_dir: Path, opponents: list[tuple[str, int]], level: SkillLevel) -> None:
    """The race's own copy of each TORCS robot's driver file, with `skill level` set for the
    indices that race: TORCS reads LOCAL/drivers/NAME/NAME.xml before the installed one, so nothing
    installed changes and races side by side keep their own levels."""
    indices: dict[str, set[int]] = {}
    for module, idx in opponents:
        indices.setdefault(module, set()).add(idx)
    for module, wanted in indices.items():
        installed = data_dir / "drivers" / module / f"{module}.xml"
        copy = local / "drivers" / module / f"{module}.xml"
        copy.parent.mkdir(parents=True, exist_ok=True)
        copy.write_text(with_skill_level(installed.read_text(errors="replace"), wanted, level))
