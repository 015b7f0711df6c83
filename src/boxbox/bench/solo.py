"""`boxbox bench`: robots x tracks x cars, raced in parallel, cached, compared in one table.

Each robot races alone (one car on the track) unless `together`, when each track x car is one
race with every robot in it.  A TORCS robot's index fixes its car (drivers/NAME/NAME.xml), so
with `match_cars` (`boxbox bench`) for each car the bench races every TORCS robot module listed
by its index that drives that car (bt:2 drives car1-trb1, bt:0 car1-stock1), beside the Python
robots in the same car; a module with no index in a car sits that car out.  Results are cached
(bench/cache.py); races that did not end properly are never cached.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import multiprocessing
import os
import queue
import shutil
import signal
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TaskID, TextColumn, TimeElapsedColumn

from boxbox.bench.cache import cache_key, load_cached, package_version, python_robot_version, store, torcs_robot_version
from boxbox.bench.solo_result import BenchResult, set_gaps
from boxbox.errors import BoxboxError, Interrupted, UsageError
from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.options import LEARNING_MODES, LearningMode
from boxbox.robot.base import RaceOptions, race_options
from boxbox.robot.loader import BUILTIN, load_robot_class
from boxbox.torcs import catalog, checks, launch
from boxbox.torcs.results import DriverResult, RaceResult
from boxbox.torcs.setup import Overlay

# --- inputs ------------------------------------------------------------------------------------

@dataclass
class BenchSpec:
    tracks: list[str]
    cars: list[str]
    robots: list[str]  # Python robot specs and TORCS robots 'module:idx'
    laps: int
    together: bool = False
    jobs: int = field(default_factory=lambda: os.cpu_count() or 1)
    use_cache: bool = True  # False: race everything again (and refresh the cache)
    learning: LearningMode = "fresh"  # for Python robots
    settings: dict | None = None  # --set values for Python robots (RaceOptions.robot_args["set"])
    skill_level: SkillLevel = DEFAULT_SKILL_LEVEL  # every car's, boxbox's and TORCS's robots alike
    grid_position: int | None = None  # the Python cars' grid slot in races --together (None: pole)
    limit: bool = True  # compute each track's limit lap (bench/limit.py) and every robot's gap to it
    fuel_offset_l: float = 0.0  # litres added to the Python cars' start fuel (launch.RaceConfig)
    # each TORCS robot module by its index that drives the car of the race (robots_in_car; `boxbox
    # bench`); False: the indices as given, each in its own car (bench-field's mixed field)
    match_cars: bool = False
    step_budget_ms: int = 200  # wall time a Python robot may take per drive step (--step-budget-ms)
    cluster: str | None = None  # a Ray cluster's address: the races run there (bench/cluster.py), not `jobs` here


def expand_all(names: list[str], all_names: list[str]) -> list[str]:
    """['all'] -> every installed name; other lists as they are."""
    return list(all_names) if names == ["all"] else list(names)


def classify_robot(entry: str) -> tuple[str, str | tuple[str, int]]:
    """('torcs', (module, idx)) for an installed TORCS robot 'module:idx', else ('python', spec)."""
    entry = entry.strip()
    if entry in BUILTIN:
        return "python", entry
    if ":" not in entry:
        if entry in catalog.robot_modules():
            catalog.parse_opponent(entry)  # raises: a TORCS robot needs its index
        return "python", entry
    before, _, after = entry.partition(":")
    if before in catalog.robot_modules():
        try:
            int(after)
        except ValueError:
            catalog.parse_opponent(entry)  # raises the UsageError saying what is wrong
            raise
        return "torcs", catalog.parse_opponent(entry)  # checks that the index exists
    return "python", entry


# --- races -------------------------------------------------------------------------------------

@dataclass
class RaceJob:
    """One race to run; picklable, for the worker processes."""

    key: str
    track: str
    category: str
    car: str
    laps: int
    entries: list[str]  # bench robot entries in this race, Python ones first (their race order)
    python_specs: list[str]
    python_names: list[str]
    opponents: list[tuple[str, int]]
    options: RaceOptions
    learning: LearningMode
    inputs: dict
    skill_level: SkillLevel = DEFAULT_SKILL_LEVEL
    grid_position: int | None = None
    fuel_offset_l: float = 0.0
    run_dir: str = ""  # where to race (made afresh; "": a new automatic run dir, pruned with the oldest)
    step_budget_ms: int = 200  # not in the key: a race it stops is not cached

    @property
    def label(self) -> str:
        who = ", ".join(self.entries) if len(self.entries) <= 3 else f"{len(self.entries)} robots"
        return f"{self.track} {who}"


RaceOutcomes = dict[str, tuple[RaceResult | None, str | None, bool]]  # by job key: (result, error, cached)


_worker: dict = {}
STOPPED = "not raced: the bench was stopped (Ctrl-C, SIGTERM or SIGHUP)"


def _note_stop(signum, frame) -> None:
    """A worker between races was asked to stop: it starts no more (a race that runs stops itself)."""
    _worker["stopped"] = True


def _init_worker(counter, progress_queue) -> None:
    with counter.get_lock():
        index = counter.value
        counter.value += 1
    cpus = sorted(os.sched_getaffinity(0))
    _worker.update(cpu=cpus[index % len(cpus)] if cpus else None, queue=progress_queue)
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _note_stop)


def _run_job(job: RaceJob, overlay: Overlay) -> dict:
    """In a worker: race, never raise; {"result": json or None, "error": text or None}."""
    q = _worker.get("queue")
    if _worker.get("stopped"):
        return {"result": None, "error": STOPPED}
    result, error = race_job(job, overlay, _worker.get("cpu"), q.put if q is not None else lambda message: None)
    if result is not None and not error:
        store(job.key, job.inputs, result)
    elif error and error.startswith(launch.INTERRUPTED):
        _worker["stopped"] = True
    return {"result": result.to_json() if result else None, "error": error}


def race_job(job: RaceJob, overlay: Overlay, cpu: int | None, send) -> tuple[RaceResult | None, str | None]:
    """Race one job (in a worker here, or a Ray task on a node: bench/cluster.py), never raising:
    (result, its error) or (None, what went wrong); send(message) tells the bar of its laps."""
    try:
        send(("start", job.key, 0, 0.0))
        if job.run_dir:
            shutil.rmtree(job.run_dir, ignore_errors=True)  # a race again: nothing of the last one stays
        run_dir = Path(job.run_dir) if job.run_dir else launch.new_run_dir()
        cfg = launch.RaceConfig(track=job.track, category=job.category, car=job.car, laps=job.laps,
                                robots=list(job.python_specs), robot_names=list(job.python_names),
                                opponents=list(job.opponents), options=job.options, cpu=cpu,
                                learning=job.learning,
                                run_dir=run_dir, skill_level=job.skill_level, grid_position=job.grid_position,
                                fuel_offset_l=job.fuel_offset_l, step_budget_ms=job.step_budget_ms)

        def progress(lap: int, sim: float) -> None:
            send(("lap", job.key, lap, sim))

        result = launch.run_race(cfg, overlay, progress)
        return result, result.error
    except Exception as exc:  # anything at all: recorded, the bench goes on
        return None, f"{type(exc).__name__}: {exc}"


# --- the bench ---------------------------------------------------------------------------------

@dataclass
class _Robot:
    entry: str
    kind: str  # python | torcs
    spec: str = ""  # python
    name: str = ""  # python: the class's name
    module: str = ""  # torcs
    idx: int = 0
    version: str = ""


def _check(spec: BenchSpec) -> tuple[dict[str, str], list[_Robot], RaceOptions]:
    """Everything checked before anything races: tracks, cars, robots, laps, settings."""
    if spec.laps < 1:
        raise UsageError(f"laps must be >= 1, got {spec.laps}")
    if spec.jobs < 1:
        raise UsageError(f"jobs must be >= 1, got {spec.jobs}")
    if spec.learning not in LEARNING_MODES:
        raise UsageError(f"learning must be one of {', '.join(LEARNING_MODES)}, got '{spec.learning}'")
    if not spec.tracks or not spec.cars or not spec.robots:
        raise UsageError("a bench needs at least one track, one car and one robot")
    categories = {t: catalog.check_track(t) for t in spec.tracks}
    for car in spec.cars:
        catalog.check_car(car)
    options = race_options(spec.settings)
    for car in spec.cars:
        checks.check_car_setup(options.car_setup, car)
    package = package_version()
    robots = [_bench_robot(entry, spec, options, package) for entry in dict.fromkeys(spec.robots)]
    if spec.together:
        n_python = sum(r.kind == "python" for r in robots)
        checks.check_field(n_python, len(robots) - n_python)
    return categories, robots, options


def _bench_robot(entry: str, spec: BenchSpec, options: RaceOptions, package: str) -> _Robot:
    """A TORCS robot with its files' version, or a Python robot loaded and checked on every track and car."""
    kind, what = classify_robot(entry)
    if isinstance(what, tuple):
        module, idx = what
        return _Robot(entry, kind, module=module, idx=idx, version=torcs_robot_version(module))
    cls = load_robot_class(what)
    for track in spec.tracks:
        for car in spec.cars:
            cls.check_setup(options, track, car)
    return _Robot(entry, kind, spec=what, name=cls.name, version=python_robot_version(what, package))


def plan(spec: BenchSpec) -> tuple[list[tuple[str, str, _Robot, RaceJob]], list[_Robot]]:
    """(track, car, robot, job) per row, in table order; rows may share a job (same key)."""
    categories, robots, options = _check(spec)
    jobs: dict[str, RaceJob] = {}
    rows = []
    for track in spec.tracks:
        for car in spec.cars:
            in_car = robots_in_car(robots, car) if spec.match_cars else robots
            groups = [in_car] if spec.together else [[r] for r in in_car]
            for group in groups:
                py = [r for r in group if r.kind == "python"]
                tc = [r for r in group if r.kind == "torcs"]
                ordered = py + tc
                described = [{"entry": r.entry, "kind": r.kind, "version": r.version} for r in ordered]
                grid = spec.grid_position if spec.together and py else None
                offset = spec.fuel_offset_l if py else 0.0
                key = cache_key(track, car, spec.laps, described, spec.settings, spec.learning,
                                spec.skill_level.torcs_name, grid, offset)
                if key not in jobs:
                    inputs: dict[str, Any] = {
                        "track": track, "car": car if py else None, "laps": spec.laps, "robots": described,
                        "settings": spec.settings or {}, "learning": spec.learning,
                        "skill_level": spec.skill_level.torcs_name, "grid_position": grid}
                    if offset:
                        inputs["fuel_offset_l"] = offset
                    jobs[key] = RaceJob(key=key, track=track, category=categories[track], car=car, laps=spec.laps,
                                        entries=[r.entry for r in ordered], python_specs=[r.spec for r in py],
                                        python_names=[f"{r.name} {i + 1}" for i, r in enumerate(py)],
                                        opponents=[(r.module, r.idx) for r in tc], options=options,
                                        learning=spec.learning, inputs=inputs, skill_level=spec.skill_level,
                                        grid_position=grid, fuel_offset_l=offset, step_budget_ms=spec.step_budget_ms)
                for r in group:
                    rows.append((track, car, r, jobs[key]))
    return rows, robots


def robots_in_car(robots: list[_Robot], car: str) -> list[_Robot]:
    """The bench's robots for one car: the Python robots as they are, and each TORCS robot module by
    its index that drives `car` (drivers/NAME/NAME.xml; the index given where it does, else the
    lowest that does); a module with no index in that car is left out of that car's races."""
    out: list[_Robot] = []
    for r in robots:
        if r.kind == "torcs":
            cars = {i: d.get("car", "") for i, d in catalog.robot_indices(r.module).items()}
            idx = r.idx if cars.get(r.idx) == car else min((i for i, c in cars.items() if c == car), default=None)
            if idx is None:
                continue
            r = r if idx == r.idx else dataclasses.replace(r, entry=f"{r.module}:{idx}", idx=idx)
        if all(o.entry != r.entry for o in out):
            out.append(r)
    return out


def _driver_for(result: RaceResult, job: RaceJob, robot: _Robot) -> DriverResult | None:
    if robot.kind == "python":
        idx = job.entries.index(robot.entry)
        return next((d for d in result.drivers if d.is_python and d.idx == idx), None)
    return next((d for d in result.drivers if d.module == robot.module and d.idx == robot.idx), None)


def row_of(track: str, car: str, robot: _Robot, job: RaceJob, result: RaceResult | None, error: str | None,
         cached: bool) -> dict:
    d = _driver_for(result, job, robot) if result is not None else None
    if robot.kind == "torcs":
        car_driven = (d.car if d and d.car else catalog.robot_indices(robot.module).get(robot.idx, {}).get("car", ""))
        name = d.name if d else catalog.robot_indices(robot.module).get(robot.idx, {}).get("name", robot.entry)
    else:
        car_driven = car
        name = d.name if d else robot.name
    return {"track": track, "car": car, "robot": robot.entry, "name": name,
            "laps": d.laps if d else 0, "time": round(d.time, 3) if d else 0.0,
            "best_lap": round(d.best_lap, 3) if d else 0.0, "damage": d.damage if d else 0,
            "pit_stops": d.pit_stops if d else 0, "penalty": d.penalty_time if d else 0.0,
            "wall_s": result.wall_s if result else 0.0, "error": error, "cached": cached, "gap_to_best_s": None,
            "category": job.category, "car_driven": car_driven, "rank": d.rank if d else 0,
            "run_dir": result.run_dir if result else "",
            "stuck_s": d.stuck_s if d else None, "longest_stuck_s": d.longest_stuck_s if d else None,
            "off_track_s": d.off_track_s if d else None, "lap_times": list(d.lap_times) if d else []}


def race_or_recall(unique: list, overlay: Overlay, jobs: int, use_cache: bool, console: Console,
                   cluster: str | None = None):
    """Outcomes of every distinct race (cached ones recalled, the rest raced in parallel: `jobs` at a
    time here, or as Ray tasks on the cluster at `cluster`, bench/cluster.py) and the raced list."""
    outcomes: RaceOutcomes = {}
    if use_cache:
        for job in unique:
            hit = load_cached(job.key)
            if hit is not None:
                outcomes[job.key] = (hit, None, True)
    todo = [job for job in unique if job.key not in outcomes]
    if todo and cluster:
        from boxbox.bench.cluster import race_on_cluster

        outcomes.update(race_on_cluster(todo, cluster, len(unique) - len(todo), console))
    elif todo:
        outcomes.update(_race_all(todo, overlay, min(jobs, len(todo)), len(unique) - len(todo), console))
    return outcomes, todo


def run_bench(spec: BenchSpec, overlay: Overlay, console: Console) -> BenchResult:
    """Check everything, take what the cache has, race the rest in parallel, compare."""
    started = time.perf_counter()
    planned, robots = plan(spec)
    unique = list({job.key: job for *_, job in planned}.values())
    outcomes, todo = race_or_recall(unique, overlay, spec.jobs, spec.use_cache, console, spec.cluster)
    rows = [row_of(track, car, robot, job, *outcomes[job.key]) for track, car, robot, job in planned]
    set_gaps(rows, spec.laps)
    if spec.limit:
        _set_limits(rows, spec.skill_level, console)
    return BenchResult(laps=spec.laps, tracks=list(spec.tracks), cars=list(spec.cars), robots=[r.entry for r in robots],
                       skill_level=spec.skill_level.torcs_name,
                       rows=rows, together=spec.together, learning=spec.learning, settings=spec.settings,
                       wall_s=time.perf_counter() - started, raced=len(todo), cached=len(unique) - len(todo))


def _set_limits(rows: list[dict], skill_level: SkillLevel, console: Console) -> None:
    """Each row's fastest lap, its track's limit lap (bench/limit.py, for the car the robot drove)
    and the gap between them in % (negative: the lap beat the limit, so the model is wrong there)."""
    from boxbox.bench.limit import gap_percent, limit_for

    limits: dict[tuple[str, str], float | None] = {}
    for r in rows:
        laps = [t for t in r.get("lap_times") or [] if t and t > 0]
        r["fastest_lap"] = min(laps) if laps else (r["best_lap"] or None)
        key = (r["track"], r["car_driven"] or r["car"])
        if key not in limits:
            try:
                with console.status(f"limit lap: {key[0]}, {key[1]}"):
                    limits[key] = round(limit_for(key[0], key[1], skill_level).lap_time_s, 3)
            except (BoxboxError, ValueError) as exc:
                console.print(f"[yellow]no limit lap for {key[0]} with {key[1]}: {exc}[/]")
                limits[key] = None
        limit_s = r["limit_lap"] = limits[key]
        gap = gap_percent(r["fastest_lap"], limit_s) if r["fastest_lap"] and limit_s else None
        r["limit_gap_pct"] = round(gap, 2) if gap is not None else None


def _race_all(todo: list[RaceJob], overlay: Overlay, workers: int, n_cached: int, console: Console) -> RaceOutcomes:
    ctx = multiprocessing.get_context("fork")
    counter = ctx.Value("i", 0)
    progress_queue = ctx.Queue()
    by_key = {job.key: job for job in todo}
    outcomes: RaceOutcomes = {}
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                                  initargs=(counter, progress_queue))
    try:
        # all submitted (so all workers forked) before the progress bar starts its thread
        futures = {pool.submit(_run_job, job, overlay): job.key for job in todo}
        with BenchBar(console, f"bench: {len(todo)} races on {workers} workers", len(todo), n_cached) as bar:
            pending = set(futures)
            while pending:
                done, pending = cf.wait(pending, timeout=0.2, return_when=cf.FIRST_COMPLETED)
                bar.show_laps(progress_queue, by_key, outcomes)
                for fut in done:
                    try:
                        out = fut.result()
                    except Exception as exc:  # the worker itself died
                        out = {"result": None, "error": f"worker failed: {type(exc).__name__}: {exc}"}
                    bar.record(by_key[futures[fut]], out, outcomes)
    except KeyboardInterrupt:  # Ctrl-C reaches the workers too, SIGTERM sent to this process only
        _stop_workers(pool)
        pool.shutdown(wait=True, cancel_futures=True)
        raise stopped_error(outcomes) from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        progress_queue.close()
    return outcomes


class BenchBar:
    """The bench's progress bar: the races done of all, then a line per race running with its lap."""

    def __init__(self, console: Console, description: str, total: int, n_cached: int) -> None:
        self.progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                                 TextColumn("{task.fields[info]}"), TimeElapsedColumn(), console=console,
                                 transient=True)
        cached_note = f", {n_cached} cached" if n_cached else ""
        self.overall = self.progress.add_task(description + cached_note, total=total, info="")
        self.running: dict[str, TaskID] = {}

    def __enter__(self) -> BenchBar:
        self.progress.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.progress.__exit__(*exc)

    def show_laps(self, progress_queue, by_key: dict[str, RaceJob], finished: RaceOutcomes) -> None:
        """The lap messages waiting in the queue onto the bar (a late one from a race done is dropped)."""
        while True:
            try:
                what, key, lap, sim = progress_queue.get_nowait()
            except (queue.Empty, OSError, ValueError):
                return
            job = by_key.get(key)
            if job is None or key in finished:
                continue
            if key not in self.running:
                self.running[key] = self.progress.add_task(f"  {job.label}", total=job.laps, info="")
            if what == "lap":
                self.progress.update(self.running[key], completed=lap, info=f"sim {sim:.0f} s")

    def record(self, job: RaceJob, out: dict, outcomes: RaceOutcomes, store_it: bool = False) -> None:
        """A race's answer into `outcomes` (into the cache too with `store_it`, when the race ended
        properly), a line for a failure, and the bar moved on."""
        result = RaceResult.from_json(out["result"]) if out["result"] else None
        outcomes[job.key] = (result, out["error"], False)
        if store_it and result is not None and not out["error"]:
            store(job.key, job.inputs, result)
        if out["error"]:
            self.progress.console.print(f"[red]race failed[/] {escape(job.label)}, {job.car}: "
                                        f"{escape(out['error'].splitlines()[0])}", highlight=False)
        if job.key in self.running:
            self.progress.remove_task(self.running.pop(job.key))
        self.progress.advance(self.overall)


def stopped_error(outcomes: RaceOutcomes) -> Interrupted:
    done = sum(1 for r, e, _ in outcomes.values() if r and not e)
    return Interrupted(f"the bench was stopped; {done} races finished and are cached: the same command goes on "
                       "from them")


def _stop_workers(pool: cf.ProcessPoolExecutor) -> None:
    """SIGTERM to each worker: its race stops and keeps its results so far, and it starts no more."""
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        try:
            os.kill(proc.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
