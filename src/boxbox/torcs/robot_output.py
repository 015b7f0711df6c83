"""What the robots print, each line marked with the car whose robot printed it.

In the robot host, `sys.stdout` and `sys.stderr` become `MarkedOutput`s: each line a robot prints
starts with its car's name in brackets (`[mine 1] lap 2`), the car the host is calling a robot
for (`CALLER`, set by the host as each message or call comes: one store a step).  The lines go
to RUN_DIR/host.log and, unless `--quiet`, to the terminal as they come (torcs/logcap.py's
LogPump); a fault's line shows the faulted car's last lines (`last_prints`, torcs/diagnosis.py).
What a robot writes past Python's streams (os.write, a child process, a C library) goes to the
log unmarked.
"""

from __future__ import annotations

import sys
from typing import Any, TextIO

CALLER = [-1]  # the robot index of the car whose robot the host is calling (-1: none, the host's own)
PRINT_LINES = 5  # a fault's line shows this many of the robot's last printed lines
PRINT_LINE_CHARS = 300  # ... each cut to this many characters


def mark(name: str) -> str:
    """The start of each line a car's robot prints."""
    return f"[{name}] "


class MarkedOutput:
    """A text stream that starts each line with the calling car's mark (`CALLER` indexes `names`);
    the rest (fileno, buffer, encoding, ...) is the stream's own."""

    def __init__(self, stream: TextIO, names: list[str]) -> None:
        self.stream = stream
        self.marks = [mark(n) for n in names]
        self.at_line_start = True

    def write(self, text: str) -> int:
        robot = CALLER[0]
        prefix = self.marks[robot] if 0 <= robot < len(self.marks) else ""
        if prefix and text:
            pieces = text.splitlines(keepends=True)
            head = prefix if self.at_line_start else ""
            self.at_line_start = pieces[-1].endswith(("\n", "\r"))
            self.stream.write(head + prefix.join(pieces) if len(pieces) > 1 else head + text)
        elif text:
            self.at_line_start = text.endswith(("\n", "\r"))
            self.stream.write(text)
        return len(text)

    def flush(self) -> None:
        self.stream.flush()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


def mark_robot_output(names: list[str]) -> None:
    """The host's sys.stdout and sys.stderr marked, line-buffered (a pipe's stream is block-buffered:
    a print would show only when the buffer fills)."""
    for attr in ("stdout", "stderr"):
        stream = getattr(sys, attr)
        try:
            stream.reconfigure(line_buffering=True)
        except (AttributeError, ValueError):
            pass
        setattr(sys, attr, MarkedOutput(stream, names))


def host_message(text: str) -> None:
    """A line of the host's own on stderr, never marked as a robot's."""
    robot, CALLER[0] = CALLER[0], -1
    try:
        print(text, file=sys.stderr, flush=True)
    finally:
        CALLER[0] = robot


def last_prints(log_text: str, name: str, count: int = PRINT_LINES) -> list[str]:
    """The last `count` lines the car `name`'s robot printed, in host.log's text (each cut to
    PRINT_LINE_CHARS)."""
    start = mark(name)
    lines = [ln for ln in log_text.splitlines() if ln.startswith(start)]
    return [ln if len(ln) <= PRINT_LINE_CHARS else ln[:PRINT_LINE_CHARS] + " ..." for ln in lines[-count:]]
