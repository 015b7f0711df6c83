"""Why a race did not end properly, in one line (plus a traceback where there is one).

The sources, in order: the robot host's `Fault` (a robot raised, exited, returned bad values, or
the race outlived its simulated-time limit), the bridge's `BOXBOX-FAULT` line in TORCS's stderr (a
robot that did not answer in time, a host that went away), the stall limit (with where gdb found
TORCS, when it is installed), the wall limit, and how TORCS and the host exited.
"""

from __future__ import annotations

import re
import signal
from dataclasses import dataclass

from boxbox.torcs import wire
from boxbox.torcs.faults import RACE_KINDS, Fault
from boxbox.torcs.paths import ROBOT_MODULE
from boxbox.torcs.robot_output import last_prints
from boxbox.torcs.rundir import RunDir

PROGRESS_LINE = re.compile(r"Sim Time:\s*([\d.]+)\s*\[s\], Leader Laps:\s*(\d+)")
FAULT_LINE = re.compile(r"BOXBOX-FAULT (\S+) robot=(-?\d+) step=(\d+)(?: budget_ms=(\d+) answer=(\d+))?")
HOST_LOG_TAIL = 2000  # characters of the host's log shown when it died
# the hang traceback is taken after TORCS gave up on the robot: a host found in Host.finish had left
# the late step and was winding down, so the step was slow, not stuck (one field race in about 760 on
# a loaded machine, docs/reliability.md)
LATE_NOT_STUCK = re.compile(r'torcs/host\.py", line \d+ in finish\n')
# a frame of gdb's backtrace: "#0  0x... in Name::fn(int, ...) () from /x/drivers/lliaw/lliaw.so"
GDB_FRAME = re.compile(r"^#\d+\s+(?:0x[0-9a-f]+ in )?(\S+?)(?:\(| \().*? from (\S+)$", re.MULTILINE)
ROBOT_LIB = re.compile(r"/drivers/([^/]+)/[^/]+\.so$")


@dataclass
class Ending:
    """What the launcher saw at the end of a race."""

    robots: list[str]  # the Python robots' specs
    names: list[str]  # their drivers' names
    step_budget_ms: float
    setup_budget_ms: float
    wall_limit_s: float
    timed_out: bool = False
    stalled_s: float | None = None  # timed out after this long without a robot call (TORCS stuck)
    stalled_sim_s: float = 0.0  # ... after this much simulated time
    fault: Fault | None = None
    torcs_code: int | None = None
    host_code: int | None = None
    host_stopped: bool = False  # the host still ran when the race was over, and the launcher killed it

    def who(self, robot: int) -> str:
        if 0 <= robot < len(self.robots):
            return f"robot '{self.robots[robot]}' ({self.names[robot]})"
        return "the robot host"


def diagnose(run_dir: RunDir, end: Ending) -> str | None:
    """One line saying why the race did not end properly, or None when it did."""
    err_text = run_dir.read_text(run_dir.torcs_err)
    fault = end.fault or Fault.read(run_dir.fault)
    if fault is not None:
        return robot_fault_line(run_dir, fault, end.robots[0] if end.robots else "")
    if marker := FAULT_LINE.search(err_text):
        return _bridge_fault(run_dir, end, marker)
    if end.timed_out and end.stalled_s is not None:
        where = stack_top(run_dir.read_text(run_dir.torcs_stack))
        return f"TORCS stopped calling the robots (last heard of at {end.stalled_sim_s:.1f} s of simulated time) " \
            f"and did not resume for {end.stalled_s:.0f} s; it was stopped" + \
            (f", inside {where}; {run_dir.torcs_stack.name}" if where else "") + f" (logs {run_dir.path}/torcs.*)"
    if end.timed_out:
        hang_tb = run_dir.read_text(run_dir.hang_traceback).strip()
        limit = f"{end.wall_limit_s:.0f}" if end.wall_limit_s >= 10 else f"{end.wall_limit_s:.2g}"
        return f"the race did not finish within its wall limit of {limit} s; TORCS was stopped" + \
            ("\n" + hang_tb if hang_tb else "")
    if end.torcs_code not in (0, None):
        tail = torcs_words(run_dir, err_text)
        if end.torcs_code in (126, 127) and "failed to run command" in tail:  # stdbuf could not exec it
            return f"TORCS could not be started: {tail}"
        return f"TORCS {exit_text(end.torcs_code)}" + (f": {tail}" if tail else "") + f" (log {run_dir.torcs_err})"
    if run_dir.results_file() is None:
        tail = torcs_words(run_dir, err_text)
        return "TORCS wrote no results file" + (f": {tail}" if tail else "") + f" (logs {run_dir.path}/torcs.*)"
    if end.host_code not in (0, None):
        log = run_dir.read_text(run_dir.host_log).strip()
        return f"the robot process {exit_text(end.host_code)}" + (f"\n{log[-HOST_LOG_TAIL:]}" if log else "")
    return None


def robot_fault_line(run_dir: RunDir, fault: Fault, default_spec: str) -> str:
    """The fault's line; a robot's fault also says where its prints are (host.log) and shows the
    last lines it printed."""
    line = fault.line(default_spec)
    return line if fault.kind in RACE_KINDS else with_prints(run_dir, fault.name, line)


def with_prints(run_dir: RunDir, name: str, line: str) -> str:
    """A robot's fault line (its first line, then what follows) with where host.log is and, below
    the first line, the last lines the car `name`'s robot printed (torcs/robot_output.py)."""
    first, nl, rest = line.partition("\n")
    prints = last_prints(run_dir.read_text(run_dir.host_log), name) if name else []
    first += f"; its prints are in {run_dir.host_log}"
    if prints:
        first += f"\nthe last {len(prints)} lines {name} printed:\n" + "\n".join(prints)
    return first + nl + rest


def stack_top(gdb_text: str) -> str | None:
    """Whose code a stuck TORCS was running, from gdb's backtrace of it: the innermost frame in a
    TORCS robot's library ("the TORCS robot 'lliaw' (correctPath in lliaw.so)"), else the innermost
    frame in any library; None without a backtrace."""
    frames = GDB_FRAME.findall(gdb_text)  # [(function, library)], innermost first
    for fn, lib in frames:
        if robot := ROBOT_LIB.search(lib):
            name = robot.group(1)
            whose = "boxbox's bridge" if name == ROBOT_MODULE else f"the TORCS robot '{name}'"
            return f"{whose} ({_short(fn)} in {lib.rsplit('/', 1)[-1]})"
    if frames:
        fn, lib = frames[0]
        return f"{_short(fn)} in {lib.rsplit('/', 1)[-1]}"
    return None


def _short(fn: str) -> str:
    return fn.rsplit("::", 1)[-1] if fn != "??" else "unknown code"


def _bridge_fault(run_dir: RunDir, end: Ending, marker: re.Match) -> str:
    kind, robot, step = marker.group(1), int(marker.group(2)), int(marker.group(3))
    who = end.who(robot)
    if kind == "timeout":
        hang_tb = run_dir.read_text(run_dir.hang_traceback).strip()
        if LATE_NOT_STUCK.search(hang_tb):
            return timeout_line(who, end, step, marker) + "; it answered late but was not stuck (asked where it " \
                "was, its host was already finishing the race): a slow step or a loaded machine; give more time " \
                "with --step-budget-ms, or race fewer jobs at once"
        line = timeout_line(who, end, step, marker) + (f"\nwhere the robot was stuck:\n{hang_tb}" if hang_tb else "")
        return with_prints(run_dir, end.names[robot], line) if 0 <= robot < len(end.names) else line
    if kind == "host-gone" and end.host_stopped:  # its socket closed, the process alive: not a kill from outside
        return f"the robot process dropped its connection to TORCS during the race (step {step}) while driving " \
            f"{who}, though it still ran (stopped at the end): a robot that closes file descriptors it did not " \
            "open (os.closerange) cuts the bridge"
    if kind in ("host-gone", "connect"):
        how = exit_text(end.host_code) if end.host_code is not None else "ended"
        log = run_dir.read_text(run_dir.host_log).strip()
        return f"the robot process {how} during the race (step {step}) while driving {who}" + \
            (f"\n{log[-HOST_LOG_TAIL:]}" if log else "")
    return f"bridge fault '{kind}' for {who} at step {step}"


def torcs_words(run_dir: RunDir, err_text: str) -> str:
    """TORCS's last complaint: its stderr, else its console lines other than progress; a module it
    could not load (linuxModLoad) is named first."""
    lines = [ln.strip() for ln in err_text.splitlines() if ln.strip()]
    if not lines:
        out = run_dir.read_text(run_dir.torcs_out)
        lines = [ln.strip() for ln in out.splitlines() if ln.strip() and not PROGRESS_LINE.search(ln)]
    load = next((ln for ln in lines if ln.startswith("linuxModLoad:")), None)
    if load:
        return "could not load " + load.partition("...")[2].strip()
    return " | ".join(lines[-3:])


def timeout_line(who: str, end: Ending, step: int, marker: re.Match) -> str:
    """Which call did not answer in time: a drive step (step budget) or a set-up call (set-up budget)."""
    answer = int(marker.group(5)) if marker.group(5) else wire.CONTROLS
    if answer == wire.CONTROLS:
        return f"{who} did not answer within its step budget of {end.step_budget_ms:g} ms (step {step})"
    call = {wire.FUEL: "initial_fuel_l", wire.PIT_ORDER: "pit_stop", wire.HELLO: "start-up",
            wire.ACK: "on_track" if step == 0 else "on_race_end"}.get(answer, f"answer kind {answer}")
    budget_s = int(marker.group(4)) / 1000 if marker.group(4) else end.setup_budget_ms / 1000
    when = f", step {step}" if answer in (wire.PIT_ORDER, wire.ACK) and step else ""
    return f"{who} did not answer within its set-up budget of {budget_s:g} s (in {call}{when})"


def exit_text(code: int) -> str:
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with status {code}"
