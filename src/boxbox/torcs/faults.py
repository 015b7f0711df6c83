"""A robot fault: what stopped the race, as one typed record.

The robot host makes a `Fault` when a robot call raises, exits, returns something invalid, the
race outlives its simulated-time limit, or TORCS has lost every car (`sim-breakdown`); it sends it
to the launcher (torcs/hostlink.py, in memory) and keeps it in RUN_DIR/fault.json (written
atomically).  `Fault.from_json` is the only reader.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Literal

from boxbox.files import write_json_atomic
from boxbox.torcs.logcap import capped_text

FaultKind = Literal["exception", "exit", "invalid-controls", "invalid-value", "sim-time-limit", "sim-breakdown"]
RACE_KINDS = ("sim-time-limit", "sim-breakdown")  # the race's fault, not the robot's: no "robot X failed"
RobotCall = Literal["__init__", "initial_fuel_l", "on_track", "drive", "pit_stop", "on_race_end"]
# a fault's message and traceback are bounded as host.log is (torcs/logcap.py): the start and the
# end kept, the cut said, so an exception's 20 MB message is a few kB in the error line, fault.json
# and result.json (the traceback's last line repeats the message: bounded with it)
MESSAGE_CHARS = (1500, 500)
TRACEBACK_CHARS = (8000, 4000)


@dataclass(frozen=True)
class Fault:
    kind: FaultKind
    message: str  # one line: what went wrong and in which call
    where: RobotCall
    robot_index: int = -1  # the Python car (-1: before any car, e.g. creating the robot)
    robot: str = ""  # the robot's spec, as given to --robot
    name: str = ""  # the driver's name
    step: int = 0  # the drive step (0 before the race)
    sim_time_s: float = 0.0
    traceback: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "message", capped_text(self.message, "message", *MESSAGE_CHARS))
        object.__setattr__(self, "traceback", capped_text(self.traceback, "traceback", *TRACEBACK_CHARS))

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict) -> Fault:
        known = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in data.items() if k in known})

    def write(self, path: Path) -> None:
        write_json_atomic(path, self.to_json(), indent=1)

    @classmethod
    def read(cls, path: Path) -> Fault | None:
        try:
            return cls.from_json(json.loads(path.read_text()))
        except (OSError, ValueError, TypeError):
            return None

    def who(self, default_spec: str = "") -> str:
        """'robot SPEC (NAME)' for the one-line message."""
        return f"robot '{self.robot or default_spec}'" + (f" ({self.name})" if self.name else "")

    def line(self, default_spec: str = "") -> str:
        """The one-line cause, with the robot's traceback below it when there is one."""
        if self.kind in RACE_KINDS:
            text = self.message
        else:
            text = f"{self.who(default_spec)} failed: {self.message}"
        return text + ("\n" + self.traceback.rstrip() if self.traceback else "")
