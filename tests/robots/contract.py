"""Robots that write down every callback the host makes (RUN_DIR/calls.jsonl, one JSON line a
call), for the tests of the robot contract (tests/integration/test_contract.py).

`drive` and `telemetry` run every step: only their first call is a line; every line carries the
counts of both so far, so a test sees how many there were before each later call."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

from boxbox import Controls, PitStops
from boxbox.robot.simple import MiddleRobot

CALLS_FILE = "calls.jsonl"
FAULT_AT_S = 1.0  # the endings below happen this far into the race (simulated time)


class Recorder(MiddleRobot):
    """The middle robot, noting each callback."""

    name = "recorder"

    def __init__(self, options=None) -> None:
        super().__init__(options)
        self.drives = self.telemetries = 0
        self._note("__init__")

    def _note(self, call: str, state=None, **extra) -> None:
        line = {"call": call, "robot": id(self), "pid": os.getpid(), "drives": self.drives,
                "telemetries": self.telemetries, **extra}
        if state is not None:
            line.update(t=state.sim_time_s, laps=int(state.laps), last_lap_time_s=state.last_lap_time_s)
        with open(Path(os.environ["BOXBOX_RUN_DIR"]) / CALLS_FILE, "a") as f:
            f.write(json.dumps(line) + "\n")

    def initial_fuel_l(self, track, car):
        self._note("initial_fuel_l")
        return super().initial_fuel_l(track, car)

    def car_setup(self, track, car):
        self._note("car_setup")
        return super().car_setup(track, car)

    def on_track(self, track, car):
        self._note("on_track", car_index=car.car_index)
        super().on_track(track, car)

    def telemetry_fields(self):
        self._note("telemetry_fields")
        return ("target_speed_mps",)

    def drive(self, state):
        self.drives += 1
        if self.drives == 1:
            self._note("drive", state)
        self.ending(state)
        return super().drive(state)

    def ending(self, state) -> None:
        """How the race ends, for the subclasses (here: it runs to the finish)."""

    def telemetry(self, state):
        self.telemetries += 1
        if self.telemetries == 1:
            self._note("telemetry", state)
        return (0.0,)

    def pit_stop(self, state):
        self._note("pit_stop", state)
        return super().pit_stop(state)

    def on_race_end(self, state):
        self._note("on_race_end", state)

    def race_report(self):
        self._note("race_report")
        return {"recorded": True}


class Faults(Recorder):
    def ending(self, state):
        if state.sim_time_s > FAULT_AT_S:
            raise ValueError("deliberate failure in drive")


class Hangs(Recorder):
    """Stops answering in drive: past its step budget the race is stopped (a hang)."""

    def ending(self, state):
        if state.sim_time_s > FAULT_AT_S:
            import time

            time.sleep(600)


class KillsTorcs(Recorder):
    """Kills TORCS once, found before the race starts: looked for in the step (an import and a walk
    of /proc) the step took over its 200 ms budget on a busy machine, so the race ended by timeout
    first and the robot, finding no TORCS left, failed."""

    sent = False

    def on_track(self, track, car):
        from faulty import torcs_pid  # beside this file: the robot's folder is on sys.path

        super().on_track(track, car)
        self.torcs_pid = torcs_pid()

    def ending(self, state):
        if state.sim_time_s > FAULT_AT_S and not self.sent:
            self.sent = True
            os.kill(self.torcs_pid, signal.SIGKILL)


class Interrupts(Recorder):
    """Signals its parent: SIGINT to the launcher (the robot host's parent), once: a fault of its own."""

    sent = False

    def ending(self, state):
        if state.sim_time_s > FAULT_AT_S and not self.sent:
            self.sent = True
            os.kill(os.getppid(), signal.SIGINT)


class Stops(Recorder):
    """Makes the stops --pit-laps asks for, with the shipped pit part."""

    def on_track(self, track, car):
        super().on_track(track, car)
        self.pits = PitStops(track, car, self.options)

    def drive(self, state):
        c = super().drive(state)
        return self.pits.filter(state, Controls(steer=c.steer, accel=min(c.accel, 0.6), brake=c.brake,
                                                clutch=c.clutch, gear=c.gear))

    def pit_stop(self, state):
        super().pit_stop(state)
        return self.pits.pit_stop(state)


class RaisesAtTheEnd(Recorder):
    """Fails in on_race_end: the race's result stands, the failure is said."""

    def on_race_end(self, state):
        super().on_race_end(state)
        raise RuntimeError("deliberate failure in on_race_end")
