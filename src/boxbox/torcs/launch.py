"""Running one race: its run dir, its processes, following it, its result.

Each race gets its own run directory (torcs/rundir.py: TORCS local dir, race file, logs), so races
never collide.  Two children: TORCS in console mode and, when Python cars race, the robot host
(torcs/processes.py).  The host tells the launcher what it sees over a pipe (torcs/hostlink.py),
so the result never depends on a file the host could not write.  Stop signals are noted, not
raised (torcs/signals.py), and the limits come from one time model (torcs/timing.py).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import selectors
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import psutil

from boxbox.errors import RaceError
from boxbox.torcs import catalog
from boxbox.torcs.diagnosis import PROGRESS_LINE, Ending, diagnose
from boxbox.torcs.hostlink import HostReports
from boxbox.torcs.logcap import CappedLog, LogPump
from boxbox.torcs.paths import MAX_PYTHON_CARS, ROBOT_MODULE
from boxbox.torcs.processes import ChildSweep, ForkedHost, child_setup, host_address_space, kill_group, pick_cpu
from boxbox.torcs.racefile import grid
from boxbox.torcs.raceprep import RaceConfig, learning_store, prepare_local_dir, torcs_command
from boxbox.torcs.results import DriverResult, RaceResult, merge_drivers, parse_results_file, save_result
from boxbox.torcs.rundir import RunDir
from boxbox.torcs.setup import Overlay
from boxbox.torcs.signals import StopSignals

Progress = Callable[[int, float], None]  # (leader laps done, sim time)
INTERRUPTED = "the race was interrupted (Ctrl-C, SIGTERM or SIGHUP); TORCS was stopped, the results so far are kept"
# the host dead of SIGKILL with no fault said and nobody in the race sending it: the kernel's OOM
# killer, or an operator's kill -9 (a robot's own excess of memory is a MemoryError: memory_limit_gib)
HOST_KILLED = ("the robot host was killed by SIGKILL with no fault of its robot said "
               "(the kernel's OOM killer, or kill -9)")
SOCK_PREFIX = "boxbox-sock-"
# a socket's path has at most 107 bytes: the longest boxbox makes below its folder's root
# ("/boxbox-gym-<pid>-XXXXXXXX/r123/bridge.sock") takes 45 of them
SOCKET_ROOT_MAX_LEN = 50
HOST_EXIT_WAIT_S = 1.0  # a SIGKILLed host is reaped within ms idle; 1 s covers a loaded machine
GDB_TIMEOUT_S = 20.0  # a backtrace of a stalled TORCS (gdb attaching and reading symbols takes 1-3 s)


def new_run_dir(keep: int | None = None) -> Path:
    """A new run dir under CACHE/runs (the oldest automatic ones pruned)."""
    return RunDir.new(keep).path


def run_race(cfg: RaceConfig, overlay: Overlay, progress: Progress | None = None) -> RaceResult:
    if len(cfg.robots) > MAX_PYTHON_CARS:
        raise RaceError(f"at most {MAX_PYTHON_CARS} Python cars per race")
    cfg.options.laps = cfg.laps
    cfg.options.cars = len(cfg.robots) + len(cfg.opponents)
    run_dir = RunDir(cfg.run_dir) if cfg.run_dir is not None else RunDir.new(cfg.keep_runs)
    run_dir.make()
    # a copy: the caller's config stays as given (benches race one config several times)
    cfg = dataclasses.replace(cfg, options=dataclasses.replace(cfg.options, learning_dir=learning_store(cfg, run_dir)))
    with run_dir.locked(), StopSignals() as stop:
        return RaceLaunch(cfg, overlay, run_dir, stop, progress).run()


class RaceLaunch:
    """One race from start to result, in named stages (`run`)."""

    def __init__(self, cfg: RaceConfig, overlay: Overlay, run_dir: RunDir, stop: StopSignals,
                 progress: Progress | None) -> None:
        self.cfg, self.overlay, self.run_dir, self.stop, self.progress = cfg, overlay, run_dir, stop, progress
        self.cpu = cfg.cpu if cfg.cpu is not None else pick_cpu()
        self.host: ForkedHost | subprocess.Popen | None = None
        self.torcs: subprocess.Popen | None = None
        self.reports: HostReports | None = None
        self.sock_dir: str | None = None
        self.laps_seen: list[tuple[int, float]] = []
        self.timed_out = False
        self.hang_dumped = False  # the host was asked for its stack (once: the diagnosis prints it)
        self.stalled = False  # timed out by the stall limit: TORCS stopped calling the robots
        self.host_ended: int | None = None  # how the host ended by itself, before the launcher killed it
        # what the robot host and TORCS print, bounded (torcs/logcap.py); the host's shown with show_prints
        self.host_pump: LogPump | None = None
        self.err_pump: LogPump | None = None
        self.started = time.perf_counter()
        self.env = dict(os.environ, LD_LIBRARY_PATH=str(overlay.torcs.shared_lib_dir),
                        BOXBOX_STEP_BUDGET_MS=str(cfg.step_budget_ms), BOXBOX_SETUP_BUDGET_MS=str(cfg.setup_budget_ms),
                        BOXBOX_RUN_DIR=str(run_dir.path))

    def run(self) -> RaceResult:
        self._prepare()
        self.started = time.perf_counter()
        try:
            with ChildSweep(self.run_dir.path):
                try:
                    self._start_host()
                    self._start_torcs()
                    self._follow()
                    self._wind_down()
                finally:
                    self._stop_processes()
        finally:
            for pump in (self.host_pump, self.err_pump):
                if pump is not None:
                    pump.finish()  # every process of the race is gone: the logs are whole
        return self._result(time.perf_counter() - self.started)

    # --- stages ------------------------------------------------------------------------------
    def _prepare(self) -> None:
        remove_stale_sockets()
        self.run_dir.clear_stale()
        try:
            prepare_local_dir(self.run_dir, self.overlay, self.cfg)
        except OSError as exc:
            raise RaceError(f"the race's files cannot be written in {self.run_dir}: {exc.strerror or exc}") from None

    def _start_host(self) -> None:
        """The robot host, with the listening socket the bridge connects to and its report pipe."""
        if not self.cfg.robots:
            return
        self.sock_dir = tempfile.mkdtemp(prefix=f"{SOCK_PREFIX}{os.getpid()}-", dir=socket_root())
        sock_path = os.path.join(self.sock_dir, "bridge.sock")
        with socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as listener:
            listener.bind(sock_path)
            listener.listen(1)
            read_fd, write_fd = os.pipe()
            self.reports = HostReports(read_fd)
            self.host_pump = LogPump(self.run_dir.host_log, echo=self.cfg.show_prints)
            try:
                self.run_dir.host_spec.write_text(json.dumps(self._host_spec(listener.fileno(), write_fd)))
                self.host = self._spawn_host(listener.fileno(), write_fd, self.host_pump.write_fd)
            except OSError as exc:
                raise RaceError(f"the robot host cannot be started in {self.run_dir}: {exc.strerror or exc}") from None
            finally:
                os.close(write_fd)  # the host's copy is the only one: its end closes when it exits
                self.host_pump.child_started()
        self.env["BOXBOX_SOCKET"] = sock_path

    def _host_spec(self, listen_fd: int, link_fd: int) -> dict:
        cfg = self.cfg
        return {"run_dir": str(self.run_dir.path), "listen_fd": listen_fd, "link_fd": link_fd, "track": cfg.track,
                "category": cfg.category, "car": cfg.car,
                "robots": [{"spec": s, "name": n} for s, n in zip(cfg.robots, cfg.names, strict=True)],
                "options": dataclasses.asdict(cfg.options), "telemetry": cfg.telemetry,
                "connect_timeout_s": cfg.time_model.start_limit_s(len(cfg.robots)),
                "memory_limit_gib": cfg.memory_limit_gib,
                "limits": {"laps": cfg.laps, "min_speed_mps": cfg.min_speed_mps},
                "skill_level": int(cfg.skill_level), "fuel_offset_l": cfg.fuel_offset_l}

    def _spawn_host(self, listen_fd: int, link_fd: int, log_fd: int) -> ForkedHost | subprocess.Popen:
        if not os.environ.get("BOXBOX_HOST_EXEC") and hasattr(os, "fork"):
            if self.cfg.telemetry:
                # the host writes telemetry.parquet as the race ends: imported here, once per launcher
                # process, every forked host has it (a bench, a study or a notebook races many times)
                import pyarrow.parquet  # noqa: F401
            return ForkedHost(self.run_dir.host_spec, log_fd, self.cpu, host_address_space(self.cfg.memory_limit_gib))
        return subprocess.Popen([sys.executable, "-m", "boxbox.torcs.host_process", str(self.run_dir.host_spec)],
                                stdout=log_fd, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                pass_fds=[listen_fd, link_fd],
                                preexec_fn=child_setup(self.cpu, host_address_space(self.cfg.memory_limit_gib)),
                                start_new_session=True, env=self.env)

    def _start_torcs(self) -> None:
        overlay, run_dir = self.overlay, self.run_dir
        cmd = torcs_command(overlay, run_dir)
        if wrapper := os.environ.get("BOXBOX_TORCS_WRAPPER"):  # e.g. "gdb -batch -ex run -ex bt --args"
            cmd = [*wrapper.split(), *cmd]
        if shutil.which("stdbuf"):
            cmd = ["stdbuf", "-oL", *cmd]  # progress lines as they happen, not at exit
        if not overlay.torcs.binary.exists():
            raise RaceError(f"TORCS binary missing: {overlay.torcs.binary}; run `boxbox setup`")
        self.err_pump = LogPump(run_dir.torcs_err)
        try:
            self.torcs = subprocess.Popen(cmd, cwd=overlay.data_dir, env=self.env, stdout=subprocess.PIPE,
                                          stderr=self.err_pump.write_fd, stdin=subprocess.DEVNULL,
                                          preexec_fn=child_setup(self.cpu), start_new_session=True)
        except OSError as exc:
            raise RaceError(f"TORCS could not be started ({cmd[0]}): {exc.strerror or exc}") from None
        finally:
            self.err_pump.child_started()

    def _follow(self) -> None:
        """Read TORCS's console and the host's reports until TORCS exits, the wall limit passes
        (timed_out) or a stop signal arrives."""
        assert self.torcs is not None and self.torcs.stdout is not None
        torcs_out = self.torcs.stdout.fileno()
        with selectors.DefaultSelector() as sel, CappedLog(self.run_dir.torcs_out) as console:
            sel.register(torcs_out, selectors.EVENT_READ, "torcs")
            if self.reports is not None:
                sel.register(self.reports.fd, selectors.EVENT_READ, "host")
            if self.stop.wakeup_fd is not None:
                sel.register(self.stop.wakeup_fd, selectors.EVENT_READ, "stop")
            pending = b""
            while not self.stop.stopped:
                now = time.perf_counter()
                remaining = self._deadline() - now
                if remaining <= 0:
                    self.timed_out = True
                    self.stalled = now >= self._stall_deadline()
                    return
                events = sel.select(timeout=min(remaining, 1.0))
                for key, _ in events:
                    if key.data == "stop":
                        self.stop.drain()
                    elif key.data == "host":
                        self._read_reports(sel)
                    elif not (chunk := os.read(torcs_out, 65536)):
                        return
                    else:
                        console.write(chunk)
                        *lines, pending = (pending + chunk).split(b"\n")
                        self._progress_lines(lines)

    def _read_reports(self, sel: selectors.BaseSelector) -> None:
        assert self.reports is not None
        fd = self.reports.fd
        self.reports.read()
        if self.reports.closed:
            sel.unregister(fd)

    def _progress_lines(self, lines: list[bytes]) -> None:
        for line in lines:
            if m := PROGRESS_LINE.search(line.decode(errors="replace")):
                lap, sim_s = int(m.group(2)), float(m.group(1))
                self.laps_seen.append((lap, sim_s))
                if self.progress:
                    self.progress(lap, sim_s)

    def _deadline(self) -> float:
        """Until the host knows the track, the start-up allowance; then the whole race's wall limit,
        or sooner the stall limit after the host's last heartbeat (torcs/timing.py)."""
        cfg = self.cfg
        length = self.reports.track_length_m if self.reports is not None else None
        if cfg.wall_limit_s is None and cfg.robots and length is None:
            return self.started + cfg.time_model.start_limit_s(len(cfg.robots))
        return min(self.started + cfg.wall_limit(length), self._stall_deadline())

    def _stall_deadline(self) -> float:
        """When the host's silence means TORCS stopped calling the robots (inf before its first heartbeat)."""
        alive = self.reports.alive_at if self.reports is not None else None
        return math.inf if alive is None else alive + self.cfg.time_model.stall_limit_s()

    def _wind_down(self) -> None:
        """TORCS stopped (or stopping): let a host that is not stuck send its summary and exit."""
        assert self.torcs is not None
        if self.stop.stopped or self.timed_out:
            if self.timed_out:
                self._dump_hang()
            if self.stalled:
                self._dump_torcs_stack()
            kill_group(self.torcs)
        self.torcs.wait()
        if self.err_pump is not None:
            self.err_pump.finish(1.0)  # torcs.err whole before it is read
        hung = self.host is not None and "BOXBOX-FAULT timeout" in self.run_dir.read_text(self.run_dir.torcs_err)
        if hung:
            self._dump_hang()  # now, while the robot is still stuck where it hung
        if self.reports is None:
            return
        if not self.reports.connected:  # a host that never got a connection waits in accept
            self.reports.drain(1.0)
        elif hung or self.timed_out:  # the host leaves the call it is stuck in, then calls on_race_end
            self._abandon_call()
            self.reports.drain(self.cfg.setup_budget_ms / 1000 + 1.0)
        elif not self.reports.drain(30.0 if self.cfg.telemetry else 3.0):
            self._dump_hang()

    def _abandon_call(self) -> None:
        """Tell a live host to leave the robot call it is stuck in (SIGUSR2: torcs/host.py), so
        that it ends the race with each robot's on_race_end, as in every other ending."""
        if self.host is not None and self.host.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                self.host.send_signal(signal.SIGUSR2)

    def _dump_hang(self) -> None:
        """Ask a live host to write where it is stuck (faulthandler on SIGUSR1), once: asked again
        (still stuck as the race winds down) it would write the same stack a second time."""
        if self.host is not None and self.host.poll() is None and not self.hang_dumped:
            self.hang_dumped = True
            with contextlib.suppress(ProcessLookupError):
                self.host.send_signal(signal.SIGUSR1)
                time.sleep(0.3)

    def _dump_torcs_stack(self) -> None:
        """Where a TORCS that stopped calling the robots is, when gdb is installed: its backtrace
        into RUN_DIR/torcs-stack.txt, which the diagnosis reads (a TORCS robot looping in its own
        drive, docs/reliability.md).  Nothing without gdb, or when gdb cannot attach."""
        gdb = shutil.which("gdb")
        if gdb is None or self.torcs is None or self.torcs.poll() is not None:
            return
        cmd = [gdb, "-p", str(self.torcs.pid), "-batch", "-nx", "-ex", "bt 40"]
        with contextlib.suppress(OSError, subprocess.SubprocessError):
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=GDB_TIMEOUT_S,
                                  stdin=subprocess.DEVNULL, start_new_session=True)
            self.run_dir.torcs_stack.write_text(done.stdout)

    def _stop_processes(self) -> None:
        kill_group(self.torcs)
        self.host_ended = self._host_end_code()
        kill_group(self.host, tree=True)
        if self.torcs is not None and self.torcs.stdout is not None:
            self.torcs.stdout.close()
        if self.reports is not None:
            self.reports.read()  # what the host sent before it ended
            self.reports.close()
        if self.sock_dir:
            shutil.rmtree(self.sock_dir, ignore_errors=True)

    # --- the result ---------------------------------------------------------------------------
    def _result(self, wall_s: float) -> RaceResult:
        cfg = self.cfg
        self.run_dir.remove_temporaries()
        result = RaceResult(track=cfg.track, category=cfg.category, car=cfg.car, laps=cfg.laps,
                            skill_level=cfg.skill_level.torcs_name, wall_s=round(wall_s, 3),
                            run_dir=str(self.run_dir.path))
        host = self.reports.cars() if self.reports is not None else {}
        result.drivers = merge_drivers(self._torcs_entries(), host, cfg.names, cfg.car, self._opponent_drivers(),
                                       self.laps_seen)
        result.limits = self._limits()
        result.error = self._stopped_by() if self.stop.stopped else self._diagnosis()
        if self._killed_from_outside() and result.error:
            first, nl, rest = result.error.partition("\n")
            result.error = f"{HOST_KILLED}; race again: {first}" + nl + rest
        self._save(result)
        return result

    def _stopped_by(self) -> str:
        """Why a stop signal ended the race: an interruption, or a robot that signalled its parent."""
        pids = {p.pid for p in (self.host, self.torcs) if p is not None}
        if self.stop.from_race(pids):
            return (f"a robot sent {self.stop.names()} to boxbox (the robot host's parent process), which stops "
                    f"a race: a robot may not signal boxbox; the results so far are kept (run dir {self.run_dir})")
        return f"{INTERRUPTED} (run dir {self.run_dir})"

    def _host_end_code(self) -> int | None:
        """The host's exit status when the race ended, None while it still ran. A host whose
        connection TORCS saw drop may be dying still: the kernel closes a killed process's sockets
        before its parent can reap it, and on a busy machine that gap outlasted TORCS's own ending (a
        SIGKILLed host read as alive, "though it still ran"). So up to HOST_EXIT_WAIT_S for a death by
        a signal, only in that ending; a host that cut its own socket (os.closerange) and exited on
        its own after (status 1) still ran when the connection dropped."""
        if self.host is None:
            return None
        code = self.host.poll()
        if code is not None or "BOXBOX-FAULT host-gone" not in self.run_dir.read_text(self.run_dir.torcs_err):
            return code
        try:
            code = self.host.wait(timeout=HOST_EXIT_WAIT_S)
        except subprocess.TimeoutExpired:
            return None
        return code if code < 0 else None

    def _host_stopped(self) -> bool:
        """The host still ran when the race was over: the launcher killed it (diagnosis.Ending)."""
        return self.host is not None and self.host_ended is None

    def _killed_from_outside(self) -> bool:
        """The host died of SIGKILL by itself (the launcher had not killed it), with no fault said,
        in a race nobody stopped: from outside (a robot's own excess of memory is a MemoryError)."""
        return self.host_ended == -signal.SIGKILL and not self.stop.stopped and \
            (self.reports is None or self.reports.fault is None)

    def _limits(self) -> dict:
        cfg = self.cfg
        length = self.reports.track_length_m if self.reports is not None else None
        return {"step_budget_ms": cfg.step_budget_ms, "setup_budget_ms": cfg.setup_budget_ms,
                "min_speed_mps": cfg.min_speed_mps,
                "sim_limit_s": round(cfg.time_model.sim_limit_s(cfg.laps, length), 1) if length else None,
                "wall_limit_s": round(cfg.wall_limit(length), 1)}

    def _torcs_entries(self) -> list[dict[str, str]]:
        path = self.run_dir.results_file()
        try:
            return parse_results_file(path) if path else []
        except (ET.ParseError, OSError):  # cut short (a full disk): as if there were none
            return []

    def _opponent_drivers(self) -> list[DriverResult]:
        """The TORCS robots, for a race without a results file; each with its TORCS car index (its
        place in the race file), by which the host kept the laps it saw them drive."""
        cfg = self.cfg
        drivers = []
        for car_index, entry in enumerate(grid(len(cfg.robots), cfg.opponents, cfg.grid_position)):
            if entry.module == ROBOT_MODULE:
                continue
            info = catalog.robot_indices(entry.module).get(entry.idx, {})
            drivers.append(DriverResult(name=info.get("name", f"{entry.module} {entry.idx}"), module=entry.module,
                                        idx=entry.idx, car=info.get("car", ""), car_index=car_index))
        return drivers

    def _diagnosis(self) -> str | None:
        cfg = self.cfg
        end = Ending(robots=list(cfg.robots), names=cfg.names, step_budget_ms=cfg.step_budget_ms,
                     setup_budget_ms=cfg.setup_budget_ms, wall_limit_s=self._deadline() - self.started,
                     timed_out=self.timed_out,
                     stalled_s=self.cfg.time_model.stall_limit_s() if self.stalled else None,
                     stalled_sim_s=self.reports.alive_sim_s if self.reports else 0.0,
                     fault=self.reports.fault if self.reports else None,
                     torcs_code=self.torcs.returncode if self.torcs else None,
                     host_code=self.host.poll() if self.host else None, host_stopped=self._host_stopped())
        error = diagnose(self.run_dir, end)
        if error is None:
            return None
        first, nl, rest = error.partition("\n")
        return f"{first} (run dir {self.run_dir})" + nl + rest

    def _save(self, result: RaceResult) -> None:
        """The result to the run dir, then to --json; what could not be kept, and where the result
        is, is said in the error (the files have the first part: they cannot know the rest)."""
        lost = self.reports.telemetry_errors if self.reports is not None else []
        lost_line = f"the telemetry was not kept ({'; '.join(lost)})" if lost else ""
        if lost_line:
            _add_error_line(result, lost_line)
        paths = [self.run_dir.result] + ([self.cfg.json_file] if self.cfg.json_file else [])
        failed = dict(save_result(result, paths))
        self.run_dir.remove_temporaries()
        if not (lost or failed):
            return
        kept = [str(p) for p in paths if p not in failed]
        note = f"the result is in {' and '.join(kept)}" if kept else "the result is shown here only"
        if failed:
            note = "the result could not be written to " + \
                ", ".join(f"{p} ({why})" for p, why in failed.items()) + "; " + note
        if lost_line and result.error:
            result.error = result.error.replace(lost_line, f"{lost_line}; {note}", 1)
        else:
            _add_error_line(result, note)


def _add_error_line(result: RaceResult, line: str) -> None:
    """A race that went well gets `line` as its error; one that did not keeps its cause first."""
    if not result.error:
        result.error = line
    else:
        first, nl, rest = result.error.partition("\n")
        result.error = f"{first}\n{line}" + nl + rest


def socket_root() -> str:
    """Where the folders of boxbox's sockets go: the temp folder (TMPDIR), or /tmp where TMPDIR is too
    long for a socket's path (a test's tmp_path as TMPDIR: "OSError: AF_UNIX path too long")."""
    root = tempfile.gettempdir()
    return root if len(root) <= SOCKET_ROOT_MAX_LEN else "/tmp"


def remove_stale_sockets(prefix: str = SOCK_PREFIX) -> None:
    """Socket folders (PREFIX<pid>-...) of launchers that are gone (killed outright, so they could
    not clean up); the Gymnasium env's folders too (gym/session.py)."""
    for path in Path(socket_root()).glob(f"{prefix}*"):
        pid = path.name.removeprefix(prefix).partition("-")[0]
        if pid.isdigit() and not psutil.pid_exists(int(pid)):
            shutil.rmtree(path, ignore_errors=True)
