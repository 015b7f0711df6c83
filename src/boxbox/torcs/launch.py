"""Running one race: files, processes, supervision, results.

Each race gets its own run directory (TORCS local dir, race file, logs, socket), so races never
collide.  Two children: TORCS in console mode and, when Python cars race, the robot host.  Both
are pinned to one core (they strictly alternate, so this costs nothing and makes the socket round
trip ~15x cheaper), die with us (PR_SET_PDEATHSIG), and are killed by process group on the way out.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import fcntl
import json
import os
import re
import selectors
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from boxbox.errors import RaceError, UsageError
from boxbox.files import write_json_atomic
from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.options import LearningMode
from boxbox.robot.base import RaceOptions
from boxbox.torcs import catalog
from boxbox.torcs.paths import MAX_PYTHON_CARS, ROBOT_MODULE, cache_dir
from boxbox.torcs.racefile import grid, race_xml, robot_xml, with_skill_level
from boxbox.torcs.results import (
    DriverResult,
    RaceResult,
    driver_from_rank,
    find_results_file,
    leader_lap_times,
    parse_results_file,
)
from boxbox.torcs.setup import Overlay

PROGRESS_LINE = re.compile(r"Sim Time:\s*([\d.]+)\s*\[s\], Leader Laps:\s*(\d+)")
FAULT_LINE = re.compile(r"BOXBOX-FAULT (\S+) robot=(-?\d+) step=(\d+)(?: budget_ms=(\d+) answer=(\d+))?")
Progress = Callable[[int, float], None]  # (leader laps done, sim time)
INTERRUPTED = "the race was interrupted (Ctrl-C or SIGTERM); TORCS was stopped, the results so far are kept"


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
    step_budget_ms: int = 200
    # on_track and friends: the tutorial robot's first race on the 22 km spring computes its
    # racing line for ~30 s alone (longer with parallel races), so set-up gets room
    setup_budget_ms: int = 120_000
    wall_timeout_s: float | None = None  # default: generous, from the number of laps
    cpu: int | None = None
    run_dir: Path | None = None
    telemetry: bool = True  # record every drive step of the Python cars in RUN_DIR/telemetry.parquet
    telemetry_alternate: bool = False  # bench-telemetry: record odd laps only (step times per lap compared)
    skill_level: SkillLevel = DEFAULT_SKILL_LEVEL  # for every car in the race, boxbox's and TORCS's
    grid_position: int | None = None  # the Python cars' first grid slot (1 = pole, the default)
    # the robots' learned data: on (the shared store), fresh (a new store in the run dir), off
    # (none); None: options.learning_dir as given. Kept per skill level either way.
    learning: LearningMode | None = None


def _child_setup(cpu: int | None) -> Callable[[], None]:
    def setup() -> None:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG: never outlive the launcher
        if cpu is not None:
            os.sched_setaffinity(0, {cpu})
    return setup


class ForkedHost:
    """The robot host as a forked child of the launcher (a Popen look-alike).

    A fresh `python -m boxbox.torcs.host` spends about 0.4 s importing numpy and the robot before
    TORCS can start its race; a fork starts with what the launcher has imported already (it has
    loaded the robot class to check it). BOXBOX_HOST_EXEC=1 goes back to a fresh interpreter.
    """

    def __init__(self, spec_path: Path, log_path: Path, cpu: int | None) -> None:
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:  # the child: never returns into the launcher's code
            code = 1
            try:
                os.setsid()
                for sig in (signal.SIGINT, signal.SIGTERM):
                    signal.signal(sig, signal.SIG_DFL)
                _child_setup(cpu)()
                log = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
                null = os.open(os.devnull, os.O_RDONLY)
                os.dup2(null, 0)
                os.dup2(log, 1)
                os.dup2(log, 2)
                import atexit

                from boxbox.torcs import host

                atexit._clear()  # the launcher's exit handlers are not the host's to run
                try:
                    code = host.main([str(spec_path)])
                finally:
                    atexit._run_exitfuncs()  # a robot's own exit handlers run, as in a fresh interpreter
            except BaseException:  # noqa: BLE001  (anything here must end the child, reported)
                import traceback

                os.write(2, traceback.format_exc().encode(errors="replace"))
            finally:
                try:
                    sys.stdout.flush()
                    sys.stderr.flush()
                finally:
                    os._exit(code)
        self.pid = pid
        self.returncode: int | None = None
        self.args = ["fork", "boxbox.torcs.host", str(spec_path)]

    def poll(self) -> int | None:
        if self.returncode is None:
            try:
                pid, status = os.waitpid(self.pid, os.WNOHANG)
            except ChildProcessError:  # reaped elsewhere: it is gone, how is unknown
                self.returncode = -signal.SIGKILL
                return self.returncode
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if deadline is not None and time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(self.args, timeout)
            time.sleep(0.002)
        return self.returncode

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:
            os.kill(self.pid, sig)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


def _pick_cpu() -> int | None:
    cpus = sorted(os.sched_getaffinity(0))
    return cpus[os.getpid() % len(cpus)] if cpus else None


def new_run_dir() -> Path:
    root = cache_dir() / "runs"
    root.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix=time.strftime("%Y%m%d-%H%M%S-"), dir=root))


def prepare_local_dir(run_dir: Path, overlay: Overlay, cfg: RaceConfig) -> Path:
    local = run_dir / "local"
    (local / "config").mkdir(parents=True, exist_ok=True)
    shutil.copy(overlay.torcs.data_dir / "config" / "raceengine.xml", local / "config" / "raceengine.xml")
    drivers = local / "drivers" / ROBOT_MODULE
    drivers.mkdir(parents=True, exist_ok=True)
    names = cfg.robot_names or [f"boxbox {i + 1}" for i in range(len(cfg.robots))]
    (drivers / f"{ROBOT_MODULE}.xml").write_text(robot_xml([(n, cfg.car) for n in names], cfg.skill_level))
    write_driver_files(local, overlay.torcs.data_dir, cfg.opponents, cfg.skill_level)
    entries = grid(len(cfg.robots), cfg.opponents, cfg.grid_position)
    race_file = run_dir / "race.xml"
    race_file.write_text(race_xml(cfg.track, cfg.category, cfg.laps, entries))
    return local


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


def _kill_group(proc: subprocess.Popen | None) -> None:
    if proc is None:
        return
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        pass


def run_race(cfg: RaceConfig, overlay: Overlay, progress: Progress | None = None) -> RaceResult:
    if len(cfg.robots) > MAX_PYTHON_CARS:
        raise RaceError(f"at most {MAX_PYTHON_CARS} Python cars per race")
    cfg.options.laps = cfg.laps
    run_dir = cfg.run_dir or new_run_dir()
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"run dir {run_dir} cannot be made: {exc.strerror or exc}") from None
    # a copy: the caller's config stays as given (benches race one config several times)
    cfg = dataclasses.replace(cfg, options=dataclasses.replace(cfg.options, learning_dir=learning_store(cfg, run_dir)))
    with run_dir_lock(run_dir):
        return _run_race(cfg, overlay, progress, run_dir)


def learning_store(cfg: RaceConfig, run_dir: Path) -> str | None:
    """The folder robots keep what they learn in, one per skill level: what is learned at one level
    is not used at another (the tyres give different grip)."""
    if cfg.learning == "off" or (cfg.learning is None and not cfg.options.learning_dir):
        return None
    if cfg.learning == "on":
        base = cache_dir() / "learning"
    elif cfg.learning == "fresh":
        base = run_dir / "learning"  # goes with the run dir: nothing left in the temp dir
    else:
        base = Path(str(cfg.options.learning_dir))
    store = base / cfg.skill_level.torcs_name
    store.mkdir(parents=True, exist_ok=True)
    return str(store)


@contextlib.contextmanager
def run_dir_lock(run_dir: Path):
    """Hold <run_dir>/.lock for the race: a second race in the same folder is refused (exit 2).

    An flock, so it goes with the process: a launcher killed outright leaves no stale lock."""
    fd = os.open(run_dir / ".lock", os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
            raise UsageError(f"run dir {run_dir} is in use by another race"
                             + (f" (pid {holder})" if holder else "") + "; give each race its own --run-dir") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield
    finally:
        os.close(fd)


def _run_race(cfg: RaceConfig, overlay: Overlay, progress: Progress | None, run_dir: Path) -> RaceResult:
    for stale in ("fault.json", "host.json", "host-progress.json", "host-connected", "hang-traceback.txt",
                  "telemetry.parquet"):
        (run_dir / stale).unlink(missing_ok=True)
    local = prepare_local_dir(run_dir, overlay, cfg)
    cpu = cfg.cpu if cfg.cpu is not None else _pick_cpu()
    wall_limit = cfg.wall_timeout_s or cfg.setup_budget_ms / 1000 + 60.0 + 10.0 * cfg.laps * (
        1 + len(cfg.opponents) + len(cfg.robots))
    names = cfg.robot_names or [f"boxbox {i + 1}" for i in range(len(cfg.robots))]

    env = dict(os.environ)
    env["LD_LIBRARY_PATH"] = str(overlay.torcs.shared_lib_dir)
    env["BOXBOX_STEP_BUDGET_MS"] = str(cfg.step_budget_ms)
    env["BOXBOX_SETUP_BUDGET_MS"] = str(cfg.setup_budget_ms)
    host = torcs = listener = None
    sock_dir = None
    started = time.perf_counter()
    laps_seen: list[tuple[int, float]] = []
    timed_out = interrupted = False
    try:
        if cfg.robots:
            sock_dir = tempfile.mkdtemp(prefix="boxbox-sock-")  # short path: sun_path is 108 bytes
            sock_path = os.path.join(sock_dir, "bridge.sock")
            listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
            listener.bind(sock_path)
            listener.listen(1)
            env["BOXBOX_SOCKET"] = sock_path
            spec = {"run_dir": str(run_dir), "listen_fd": listener.fileno(), "track": cfg.track,
                    "category": cfg.category, "car": cfg.car,
                    "robots": [{"spec": s, "name": n} for s, n in zip(cfg.robots, names)],
                    "options": dataclasses.asdict(cfg.options),
                    "connect_timeout_s": wall_limit, "telemetry": cfg.telemetry,
                    "telemetry_alternate": cfg.telemetry_alternate}
            (run_dir / "host-spec.json").write_text(json.dumps(spec))
            if os.environ.get("BOXBOX_HOST_EXEC") or not hasattr(os, "fork"):
                with open(run_dir / "host.log", "wb") as log:
                    host = subprocess.Popen([sys.executable, "-m", "boxbox.torcs.host",
                                             str(run_dir / "host-spec.json")],
                                            stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                            pass_fds=[listener.fileno()], preexec_fn=_child_setup(cpu),
                                            start_new_session=True)
            else:
                host = ForkedHost(run_dir / "host-spec.json", run_dir / "host.log", cpu)
            listener.close()
            listener = None
        cmd = [str(overlay.torcs.binary), "-l", f"{local}/", "-L", f"{overlay.lib_dir}/", "-D",
               f"{overlay.data_dir}/", "-r", str(run_dir / "race.xml")]
        if wrapper := os.environ.get("BOXBOX_TORCS_WRAPPER"):  # e.g. "gdb -batch -ex run -ex bt --args"
            cmd = [*wrapper.split(), *cmd]
        if shutil.which("stdbuf"):
            cmd = ["stdbuf", "-oL", *cmd]  # progress lines as they happen, not at exit
        if not overlay.torcs.binary.exists():
            raise RaceError(f"TORCS binary missing: {overlay.torcs.binary}; run `boxbox setup`")
        with open(run_dir / "torcs.err", "wb") as err:
            try:
                torcs = subprocess.Popen(cmd, cwd=overlay.data_dir, env=env, stdout=subprocess.PIPE, stderr=err,
                                         stdin=subprocess.DEVNULL, preexec_fn=_child_setup(cpu),
                                         start_new_session=True)
            except OSError as exc:
                raise RaceError(f"TORCS could not be started ({cmd[0]}): {exc.strerror or exc}") from None
        try:
            timed_out = _follow(torcs, started + wall_limit, laps_seen, progress, run_dir)
        except KeyboardInterrupt:  # Ctrl-C (or SIGTERM, see cli): stop TORCS, keep what the race has
            interrupted = True
            _kill_group(torcs)
        if timed_out:
            _dump_hang(host)
            _kill_group(torcs)
        torcs.wait()
        err_file = run_dir / "torcs.err"
        hung = host is not None and err_file.exists() and b"BOXBOX-FAULT timeout" in err_file.read_bytes()
        if hung:
            _dump_hang(host)  # now, while the robot is still stuck where it hung
        if host is not None:
            try:
                # a host that is not stuck writes host.json and the telemetry file, then exits
                # (one that never got a connection waits in accept: no reason to wait for it)
                connected = (run_dir / "host-connected").exists()
                host.wait(timeout=1.0 if not connected or hung or timed_out else 3.0 if not cfg.telemetry else 30.0)
            except subprocess.TimeoutExpired:
                _dump_hang(host)
    finally:
        if listener is not None:
            listener.close()
        _kill_group(torcs)
        _kill_group(host)
        if torcs is not None and torcs.stdout is not None:
            torcs.stdout.close()
        if sock_dir:
            shutil.rmtree(sock_dir, ignore_errors=True)
    wall = time.perf_counter() - started
    result = _collect(cfg, run_dir, local, names, laps_seen, wall)
    error = INTERRUPTED if interrupted else _diagnose(cfg, run_dir, torcs, host, names, timed_out, wall_limit, result)
    if error:
        result.error = error
    write_json_atomic(run_dir / "result.json", result.to_json(), indent=1)
    return result


def _follow(torcs: subprocess.Popen, deadline: float, laps_seen, progress, run_dir: Path) -> bool:
    """Read TORCS's console until it exits; True when the wall-time limit was hit."""
    with selectors.DefaultSelector() as sel, open(run_dir / "torcs.out", "wb") as out:  # no fd outlives a race
        sel.register(torcs.stdout, selectors.EVENT_READ)
        pending = b""
        while True:
            remaining = deadline - time.perf_counter()
            if remaining <= 0:
                return True
            if not sel.select(timeout=min(remaining, 1.0)):
                continue
            chunk = os.read(torcs.stdout.fileno(), 65536)
            if not chunk:
                return False
            out.write(chunk)
            pending += chunk
            *lines, pending = pending.split(b"\n")
            for line in lines:
                m = PROGRESS_LINE.search(line.decode(errors="replace"))
                if m:
                    laps_seen.append((int(m.group(2)), float(m.group(1))))
                    if progress:
                        progress(int(m.group(2)), float(m.group(1)))


def _dump_hang(host: subprocess.Popen | None) -> None:
    """Ask a live host to write where it is stuck (faulthandler on SIGUSR1)."""
    if host is not None and host.poll() is None:
        try:
            host.send_signal(signal.SIGUSR1)
            time.sleep(0.3)
        except ProcessLookupError:
            pass


def _collect(cfg, run_dir: Path, local: Path, names, laps_seen, wall: float) -> RaceResult:
    result = RaceResult(track=cfg.track, category=cfg.category, car=cfg.car, laps=cfg.laps,
                        skill_level=cfg.skill_level.torcs_name, wall_s=round(wall, 3),
                        run_dir=str(run_dir))
    host_info = _host_info(run_dir)
    ours = {c["robot_index"]: c for c in host_info.get("cars", [])}
    others = {int(k): v for k, v in host_info.get("other_lap_times", {}).items()}
    results_file = find_results_file(local)
    entries = parse_results_file(results_file) if results_file else []
    if entries:
        drivers = [driver_from_rank(i, e) for i, e in enumerate(entries, start=1)]
    else:  # no results file (the race was cut short): list every car with what we know
        drivers = [DriverResult(name=n, module=ROBOT_MODULE, idx=i, car=cfg.car) for i, n in enumerate(names)]
        for m, idx in cfg.opponents:
            info = catalog.robot_indices(m).get(idx, {})
            drivers.append(DriverResult(name=info.get("name", f"{m} {idx}"), module=m, idx=idx, car=info.get("car", "")))
    for d in drivers:
        if d.module == ROBOT_MODULE and d.idx in ours:
            mine = ours[d.idx]
            d.lap_times = [round(t, 3) for t in mine["lap_times"]]
            d.step_us_median, d.step_us_p99 = mine["step_us_median"], mine["step_us_p99"]
            d.start_fuel_l = mine.get("start_fuel_l")
            d.stuck_s, d.longest_stuck_s, d.off_track_s = (mine.get(k) for k in ("stuck_s", "longest_stuck_s",
                                                                                   "off_track_s"))
            report = dict(mine.get("report", {}))
            d.pit_events = report.pop("pit_events", [])
            d.report = report
            if d.car_index < 0 and mine.get("car_index") is not None:
                d.car_index = mine["car_index"]
        elif d.car_index in others:
            d.lap_times = [round(t, 3) for t in others[d.car_index]]
        elif len(drivers) == 1:
            d.lap_times = leader_lap_times(laps_seen)
        if entries and d.laps == len(d.lap_times) + 1:
            _add_final_lap(d)
        if not entries:
            d.laps = len(d.lap_times)
        if d.lap_times and not d.best_lap:
            d.best_lap = min(d.lap_times)
    result.drivers = drivers
    return result


def _add_final_lap(d: DriverResult) -> None:
    """TORCS ends the race in the simulation step the line is crossed, often before the robot's
    next drive call, so the host may never see the last lap's time: it is the race time less the
    laps before it (checked against TORCS's best lap, which counts it)."""
    last = round(d.time - sum(d.lap_times), 3)
    if d.time > 0 and d.best_lap and last >= d.best_lap - 0.005:
        d.lap_times.append(last)


def _host_info(run_dir: Path) -> dict:
    """host.json, or when the host could not write it (killed, hung) its copy saved at each lap."""
    for name in ("host.json", "host-progress.json"):
        try:
            return json.loads((run_dir / name).read_text())
        except (OSError, ValueError):
            continue
    return {}


def _diagnose(cfg, run_dir: Path, torcs, host, names, timed_out: bool, wall_limit: float,
              result: RaceResult) -> str | None:
    """One line saying why the race did not end properly (plus a traceback where there is one)."""
    err_text = (run_dir / "torcs.err").read_text(errors="replace") if (run_dir / "torcs.err").exists() else ""
    fault_file = run_dir / "fault.json"
    hang_tb = (run_dir / "hang-traceback.txt").read_text(errors="replace").strip() \
        if (run_dir / "hang-traceback.txt").exists() else ""
    marker = FAULT_LINE.search(err_text)
    if fault_file.exists():
        fault = json.loads(fault_file.read_text())
        who = f"robot '{fault['robot'] or cfg.robots[0]}'" + (f" ({fault['name']})" if fault["name"] else "")
        line = f"{who} failed: {fault['message']}"
        return line + ("\n" + fault["traceback"].rstrip() if fault.get("traceback") else "")
    if marker:
        kind, robot, step = marker.group(1), int(marker.group(2)), int(marker.group(3))
        who = f"robot '{cfg.robots[robot]}' ({names[robot]})" if 0 <= robot < len(cfg.robots) else "the robot host"
        if kind == "timeout":
            line = _timeout_line(who, cfg, step, marker)
            return line + (f"\nwhere the robot was stuck:\n{hang_tb}" if hang_tb else "")
        if kind in ("host-gone", "connect"):
            how = _exit_text(host.returncode) if host is not None and host.returncode is not None else "ended"
            log = (run_dir / "host.log").read_text(errors="replace").strip()
            return f"the robot process {how} during the race (step {step}) while driving {who}" + \
                (f"\n{log[-2000:]}" if log else "")
        return f"bridge fault '{kind}' for {who} at step {step}"
    if timed_out:
        return f"the race did not finish within {wall_limit:.0f} s of wall time; TORCS was stopped" + \
            ("\n" + hang_tb if hang_tb else "")
    if torcs is not None and torcs.returncode not in (0, None):
        tail = _torcs_words(run_dir, err_text)
        if torcs.returncode in (126, 127) and "failed to run command" in tail:  # stdbuf could not exec it
            return f"TORCS could not be started: {tail}"
        return f"TORCS {_exit_text(torcs.returncode)}" + (f": {tail}" if tail else "") + \
            f" (log {run_dir / 'torcs.err'})"
    if not find_results_file(run_dir / "local"):
        tail = _torcs_words(run_dir, err_text)
        return "TORCS wrote no results file" + (f": {tail}" if tail else "") + f" (logs {run_dir}/torcs.*)"
    if host is not None and host.returncode not in (0, None):
        log = (run_dir / "host.log").read_text(errors="replace").strip()
        return f"the robot process {_exit_text(host.returncode)}" + (f"\n{log[-2000:]}" if log else "")
    return None


def _torcs_words(run_dir: Path, err_text: str) -> str:
    """TORCS's last complaint: its stderr, else its console lines other than progress; a module it
    could not load (linuxModLoad) is named first."""
    lines = [ln.strip() for ln in err_text.splitlines() if ln.strip()]
    if not lines and (run_dir / "torcs.out").exists():
        out = (run_dir / "torcs.out").read_text(errors="replace")
        lines = [ln.strip() for ln in out.splitlines() if ln.strip() and not PROGRESS_LINE.search(ln)]
    load = next((ln for ln in lines if ln.startswith("linuxModLoad:")), None)
    if load:
        return "could not load " + load.partition("...")[2].strip()
    return " | ".join(lines[-3:])


def _timeout_line(who: str, cfg, step: int, marker: re.Match) -> str:
    """Which call did not answer in time: a drive step (step budget) or a set-up call (set-up budget)."""
    from boxbox.torcs import wire

    answer = int(marker.group(5)) if marker.group(5) else wire.CONTROLS
    if answer == wire.CONTROLS:
        return f"{who} did not answer within its step budget of {cfg.step_budget_ms} ms (step {step})"
    call = {wire.FUEL: "initial_fuel_l", wire.PIT_ORDER: "pit_stop", wire.HELLO: "start-up",
            wire.ACK: "on_track" if step == 0 else "on_race_end"}.get(answer, f"answer kind {answer}")
    budget_s = int(marker.group(4)) / 1000 if marker.group(4) else cfg.setup_budget_ms / 1000
    when = f", step {step}" if answer in (wire.PIT_ORDER, wire.ACK) and step else ""
    return f"{who} did not answer within its set-up budget of {budget_s:g} s (in {call}{when})"


def _exit_text(code: int) -> str:
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with status {code}"
