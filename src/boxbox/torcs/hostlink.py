"""What the robot host tells the launcher while a race runs: JSON lines over a pipe.

The launcher keeps what it hears in memory, so a host that is killed or stuck, or a full disk under
the run dir, costs none of it: the lap times so far (sent at every lap), the fault that stopped the
race, and at the end the host's summary of each Python car.

| message | when | what |
|---|---|---|
| `connected` | TORCS's bridge connected | - |
| `track` | the track arrived | `length_m` (the launcher's wall limit needs it) |
| `alive` | every HEARTBEAT_S of wall time while TORCS calls the robots | `sim_time_s` |
| `progress` | every lap of a Python car | `cars`, `other_lap_times` as in `summary` (step times left out) |
| `fault` | a robot fault | a `faults.Fault` |
| `summary` | the host's end | `cars` (per Python car: lap times, step times, incidents, missed pit |
|  |  | stops, the robot's report), `other_lap_times` (the other cars', by car index) |
| `telemetry` | after the summary, when telemetry was lost | `errors`: why (a full disk) |
"""

from __future__ import annotations

import json
import os
import selectors
import time

from boxbox.torcs.faults import Fault


class HostLink:
    """The host's end: each message one line, written whole (a launcher that is gone is ignored)."""

    def __init__(self, fd: int | None) -> None:
        self.fd = fd

    def send(self, kind: str, **payload) -> None:
        if self.fd is None:
            return
        data = memoryview((json.dumps({"kind": kind, **payload}) + "\n").encode())
        try:
            while data:
                data = data[os.write(self.fd, data):]
        except OSError:  # the launcher has gone: nobody to tell
            self.fd = None


class HostReports:
    """The launcher's end: reads the host's messages as they come and keeps the latest of each."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        os.set_blocking(fd, False)
        self._pending = b""
        self.closed = False
        self.connected = False
        self.track_length_m: float | None = None
        self.progress: dict | None = None
        self.summary: dict | None = None
        self.fault: Fault | None = None
        self.telemetry_errors: list[str] = []
        self.alive_at: float | None = None  # perf_counter of the last heartbeat
        self.alive_sim_s = 0.0  # the simulated time it gave

    def read(self) -> None:
        """Take what the pipe holds now (never blocks); `closed` once the host's end is closed."""
        while not self.closed:
            try:
                chunk = os.read(self.fd, 65536)
            except BlockingIOError:
                return
            if not chunk:
                self.close()
                break
            self._pending += chunk
            *lines, self._pending = self._pending.split(b"\n")
            for line in lines:
                self._take(line)

    def drain(self, timeout_s: float) -> bool:
        """Read until the host closes its end (it has exited) or timeout_s passes; True if closed."""
        if self.closed:
            return True
        deadline = time.monotonic() + timeout_s
        with selectors.DefaultSelector() as sel:
            sel.register(self.fd, selectors.EVENT_READ)
            while not self.closed:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                if sel.select(timeout=remaining):
                    self.read()
        return True

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            os.close(self.fd)

    def cars(self) -> dict:
        """The host's last word on the Python cars: its summary, else its last lap's progress."""
        return self.summary or self.progress or {}

    def _take(self, line: bytes) -> None:
        try:
            msg = json.loads(line)
            kind = msg.pop("kind")
        except (ValueError, KeyError, AttributeError):
            return  # not one of ours: ignored
        if kind == "connected":
            self.connected = True
        elif kind == "track":
            self.track_length_m = float(msg["length_m"])
        elif kind == "alive":
            self.alive_at = time.perf_counter()
            self.alive_sim_s = float(msg.get("sim_time_s", 0.0))
        elif kind == "progress":
            self.progress = msg
        elif kind == "summary":
            self.summary = msg
        elif kind == "telemetry":
            self.telemetry_errors = list(msg.get("errors", []))
        elif kind == "fault" and self.fault is None:
            self.fault = Fault.from_json(msg["fault"])
