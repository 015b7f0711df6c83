"""The robot host's process: `python -m boxbox.torcs.host_process SPEC.json`, or `main` in the
launcher's forked child (torcs/processes.py).  It reads the race's spec, takes over the inherited
listening socket and pipe, waits for the bridge and serves it with a `Host` (torcs/host.py)."""

from __future__ import annotations

import faulthandler
import json
import os
import signal
import socket
import sys
from pathlib import Path

from boxbox.torcs import host as host_module
from boxbox.torcs.faults import Fault
from boxbox.torcs.host import Host, RobotFault, abandon_call, forked_child, report_fault
from boxbox.torcs.hostlink import HostLink
from boxbox.torcs.robot_output import mark_robot_output
from boxbox.torcs.rundir import RunDir


def _accept(listener: socket.socket, timeout_s: float) -> socket.socket | None:
    listener.settimeout(timeout_s)
    try:
        conn, _ = listener.accept()
    except TimeoutError:
        return None
    conn.settimeout(None)
    return conn


def serve_profiled(host: Host, conn: socket.socket, stats_file: str) -> None:
    """host.serve under cProfile, its statistics written to stats_file (BOXBOX_PROFILE=FILE: where
    a robot's step time goes; read with `python -m pstats FILE`)."""
    import cProfile

    profiler = cProfile.Profile()
    try:
        profiler.runcall(host.serve, conn)
    finally:
        profiler.dump_stats(stats_file)


def main(argv: list[str]) -> int:
    spec = json.loads(Path(argv[0]).read_text())
    run_dir = RunDir(spec["run_dir"])
    mark_robot_output([entry["name"] for entry in spec["robots"]])  # each robot's prints marked with its car
    link = HostLink(spec.get("link_fd"))
    host_module.MEMORY_LIMIT_GIB[0] = spec.get("memory_limit_gib")
    os.register_at_fork(after_in_child=lambda: forked_child(link))
    os.environ["BOXBOX_RUN_DIR"] = str(run_dir)  # robots may keep files of their race here
    hang_file = open(run_dir.hang_traceback, "w")  # noqa: SIM115  (open for the process's life)
    faulthandler.register(signal.SIGUSR1, file=hang_file, all_threads=False)
    signal.signal(signal.SIGUSR2, abandon_call)
    listener = socket.socket(fileno=int(spec["listen_fd"]))
    try:
        host = Host(spec, link)
    except BaseException as exc:  # noqa: BLE001  (robot import or constructor failed, or exited)
        fault = RobotFault.from_exception(exc, "creating the robot")
        report_fault(run_dir, link, Fault(kind=fault.kind, message=fault.message, where="__init__",
                                          traceback=fault.tb))
        return 1
    conn = _accept(listener, float(spec.get("connect_timeout_s", 60)))
    if conn is None:
        return 2
    link.send("connected")
    try:
        serve_profiled(host, conn, profile) if (profile := os.environ.get("BOXBOX_PROFILE")) else host.serve(conn)
    except (BrokenPipeError, ConnectionResetError):
        pass  # TORCS went away while we answered (killed): what we have is sent below
    finally:
        if host_module.FORKED[0]:
            os._exit(0)  # a robot's forked child: the host's end is the parent's
        host.finish()
    return 1 if host.fault else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
