"""Python robots as the env's opponents: `opponents=["boxbox", "my_robot.py:MyRobot", "bt:2"]`.

A Python robot among the opponents races as `boxbox race --robot` races it: boxbox's robot host
(torcs/host.py, started as `python -m boxbox.torcs.host_process`, torcs/host_process.py) drives it
in a process of its own, one host for the race's Python opponents.  The bridge has one socket, the
env's: the learner's car is robot 0 and the robots are 1, 2..., so the env relays their messages
to the host (robot k there is k - 1) and the host's answers back to the bridge; the host takes the
env for the bridge.  Each episode's race has its own host, killed with its TORCS.  A robot that
raises, exits or returns invalid controls is the RaceError `boxbox race` gives (the host's fault
record, with the last lines the robot printed); one that does not answer within the race's step
budget (200 ms) or set-up budget (120 s) too, with where it was stuck.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time

from boxbox.errors import RaceError
from boxbox.robot.loader import BUILTIN
from boxbox.torcs import wire
from boxbox.torcs.faults import Fault
from boxbox.torcs.messages import TrackChunks
from boxbox.torcs.raceprep import RaceConfig
from boxbox.torcs.rundir import RunDir

HANG_DUMP_WAIT_S = 0.5  # for the host to write where the robot is stuck (SIGUSR1: faulthandler)
NO_ANSWER = (wire.SHUTDOWN,)  # messages the host does not answer (NEW_TRACK: all but its last chunk)


def is_python_robot(entry: str) -> bool:
    """An opponent entry that names a Python robot ('boxbox', 'file.py:Class', 'module:Class')
    rather than a TORCS one ('bt:2': a module and a number)."""
    where, _, last = entry.strip().rpartition(":")
    return entry.strip() in BUILTIN or where.endswith(".py") or (bool(where) and not last.strip().isdigit())


def split_opponents(entries: list[str] | tuple[str, ...]) -> tuple[list[str], list[str]]:
    """(TORCS robots, Python robots), each in the order given."""
    return [e for e in entries if not is_python_robot(e)], [e.strip() for e in entries if is_python_robot(e)]


class HostedRobots:
    """The robot host of one race's Python opponents, and the relay of their messages."""

    def __init__(self, cfg: RaceConfig, run: RunDir, cpu: int, setpriv: str | None) -> None:
        self.cfg, self.run = cfg, run
        self.specs, self.names = cfg.robots[1:], cfg.robot_names[1:]
        self.conn: socket.socket | None = None
        self.reply = bytearray(wire.MAX_MESSAGE_BYTES + 64)
        self.chunks: dict[int, TrackChunks] = {}
        self.proc = self._start(cpu, setpriv)

    def _start(self, cpu: int, setpriv: str | None) -> subprocess.Popen:
        path = self.run.path / "host.sock"
        with socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as listener:
            listener.bind(str(path))
            listener.listen(1)
            self.run.host_spec.write_text(json.dumps(self._spec(listener.fileno())))
            cmd = [sys.executable, "-m", "boxbox.torcs.host_process", str(self.run.host_spec)]
            with open(self.run.host_log, "wb") as log:
                proc = subprocess.Popen([setpriv, "--pdeathsig", "KILL", "--", *cmd] if setpriv else cmd,
                                             stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                                             pass_fds=[listener.fileno()], start_new_session=True)
            with contextlib.suppress(OSError):
                os.sched_setaffinity(proc.pid, {cpu})  # beside its TORCS: they take turns
            self.conn = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET | socket.SOCK_CLOEXEC)
            self.conn.connect(str(path))  # the host accepts once its robots are made
        return proc

    def _spec(self, listen_fd: int) -> dict:
        cfg = self.cfg
        return {"run_dir": str(self.run.path), "listen_fd": listen_fd, "link_fd": None, "track": cfg.track,
                "category": cfg.category, "car": cfg.car,
                "robots": [{"spec": s, "name": n} for s, n in zip(self.specs, self.names, strict=True)],
                "options": {"laps": cfg.laps, "cars": len(cfg.robots) + len(cfg.opponents)}, "telemetry": False,
                "connect_timeout_s": cfg.setup_budget_ms / 1000, "limits": {"laps": cfg.laps},
                "skill_level": int(cfg.skill_level)}

    def relay(self, buf: bytearray, n: int) -> memoryview | None:
        """The bridge's message for a Python opponent (in buf[:n]) handed to the host; its answer,
        for the bridge, or None when it answers none.  RaceError when the robot failed or hung."""
        assert self.conn is not None
        kind, robot, step, count = wire.HEADER.unpack_from(buf, 0)
        wire.HEADER.pack_into(buf, 0, kind, robot - 1, step, count)
        answers = kind not in NO_ANSWER and (
            kind != wire.NEW_TRACK or self.chunks.setdefault(robot, TrackChunks()).add(buf, n, step, count) is not None)
        budget_s = (self.cfg.step_budget_ms if kind == wire.DRIVE else self.cfg.setup_budget_ms) / 1000
        try:
            self.conn.send(memoryview(buf)[:n])
            if not answers:
                return None
            self.conn.settimeout(budget_s)
            got = self.conn.recv_into(self.reply)
        except TimeoutError:
            raise self._hung(robot - 1, kind, step, budget_s) from None
        except OSError:
            got = 0
        if got == 0:
            raise self._gone(robot - 1, step)
        kind_back, robot_back, step_back, flags = wire.HEADER.unpack_from(self.reply, 0)
        if flags & wire.FLAG_FAULT:
            raise self._fault(robot - 1)
        wire.HEADER.pack_into(self.reply, 0, kind_back, robot_back + 1, step_back, flags)
        return memoryview(self.reply)[:got]

    def kill(self) -> None:
        """Kill the host (its process group) now; `close` collects it."""
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.proc.pid, signal.SIGKILL)

    def close(self) -> None:
        """Kill the host and collect it."""
        if self.conn is not None:
            self.conn.close()
            self.conn = None
        self.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=5)

    # --- what went wrong, as `boxbox race` says it ----------------------------------------------
    def _who(self, index: int) -> str:
        return f"robot '{self.specs[index]}' ({self.names[index]})"

    def _fault(self, index: int) -> RaceError:
        fault = None
        for _ in range(50):  # written by the host before it answers; read as it lands
            fault = Fault.read(self.run.fault)
            if fault is not None:
                break
            time.sleep(0.01)
        if fault is None:
            return RaceError(f"{self._who(index)} failed (its host reported no cause)")
        return RaceError(fault.line(self.specs[index]))  # (the race's folder goes with it: no pointer to host.log)

    def _hung(self, index: int, kind: int, step: int, budget_s: float) -> RaceError:
        if kind == wire.DRIVE:
            line = f"{self._who(index)} did not answer within its step budget of {budget_s * 1000:g} ms (step {step})"
        else:
            line = f"{self._who(index)} did not answer within its set-up budget of {budget_s:g} s"
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.proc.pid, signal.SIGUSR1)  # faulthandler: where it is stuck
            time.sleep(HANG_DUMP_WAIT_S)
        stuck = self.run.read_text(self.run.hang_traceback).strip()
        return RaceError(line + (f"\nwhere the robot was stuck:\n{stuck}" if stuck else ""))

    def _gone(self, index: int, step: int) -> RaceError:
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=5)
        code = self.proc.poll()
        fault = Fault.read(self.run.fault)
        if fault is not None:  # it failed before it served (its import, its constructor)
            return RaceError(fault.line(self.specs[index]))
        log = self.run.read_text(self.run.host_log).strip()
        return RaceError(f"the robot process ended (status {code}) during the race (step {step}) while driving "
                         f"{self._who(index)}" + (f"\n{log[-2000:]}" if log else ""))
