"""A race's logs, bounded: each keeps its first and its last megabyte and says what was cut.

A robot printing 100 kB a step fills 921 MB of an unbounded host.log in a 3 s race.  So what the
robot host and TORCS print goes through a pipe to a thread of the launcher (`LogPump`), which writes
the start of it to the file as it comes, keeps the end in memory, and at the end writes a line
saying how much was cut, then the end.  The robot's side costs what a write to a file would: a
write to a pipe.  TORCS's console (torcs.out), read by the launcher's own loop, is bounded the same way
(`CappedLog`).
"""

from __future__ import annotations

import codecs
import contextlib
import os
import selectors
import sys
import threading
from pathlib import Path
from typing import BinaryIO

HEAD_BYTES = 1 << 20  # the start of a log kept
TAIL_BYTES = 1 << 20  # and its end
NOTE_CHARS = 200  # room for cut_note's line


class CappedLog:
    """A log file holding at most head_bytes from its start and tail_bytes from its end (plus one
    line between them saying what was cut).  A write that fails (a full disk) stops the file, not
    the race."""

    def __init__(self, path: Path, head_bytes: int = HEAD_BYTES, tail_bytes: int = TAIL_BYTES) -> None:
        self.head_bytes, self.tail_bytes = head_bytes, tail_bytes
        self.written = 0  # bytes of the start written to the file
        self.cut = 0  # bytes dropped between the start and the end
        self.tail = bytearray()
        self.file: BinaryIO | None = None
        with contextlib.suppress(OSError):
            self.file = open(path, "wb")  # noqa: SIM115  (closed in close)

    def __enter__(self) -> CappedLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def write(self, data: bytes) -> None:
        room = self.head_bytes - self.written
        if room > 0:
            self._put(data[:room])
            self.written += min(room, len(data))
            data = data[room:]
        if data:
            self.tail += data
            if len(self.tail) > 2 * self.tail_bytes:  # trimmed now and then, not at every write
                self._trim()

    def _trim(self) -> None:
        extra = len(self.tail) - self.tail_bytes
        if extra > 0:
            del self.tail[:extra]
            self.cut += extra

    def _put(self, data: bytes) -> None:
        if self.file is None or not data:
            return
        try:
            self.file.write(data)
            self.file.flush()  # whoever watches the log sees it as it comes
        except OSError:
            self._close_file()

    def close(self) -> None:
        """The cut, said, and the end of the log."""
        self._trim()
        if self.cut:
            self._put(f"\n{cut_note(self.cut, 'bytes', 'log', self.head_bytes, self.tail_bytes)}\n".encode())
        self._put(bytes(self.tail))
        self.tail = bytearray()
        self._close_file()

    def _close_file(self) -> None:
        if self.file is not None:
            with contextlib.suppress(OSError):
                self.file.close()
            self.file = None


def cut_note(cut: int, unit: str, what: str, head: int, tail: int) -> str:
    """The line that stands where a bounded text was cut."""
    return f"[boxbox: {cut} {unit} of the {what} cut here; it keeps its first {head} and its last {tail} {unit}]"


def capped_text(text: str, what: str, head: int, tail: int) -> str:
    """text, or its first `head` and last `tail` characters with the cut said between them (a
    robot's exception of 20 MB made a 40 MB result.json, fault.json and stderr)."""
    if len(text) <= head + tail + NOTE_CHARS:  # a text cut once is not cut again when read back
        return text
    return f"{text[:head]} {cut_note(len(text) - head - tail, 'characters', what, head, tail)} {text[-tail:]}"


class LogPump:
    """A pipe whose write end a child of the race prints to, read by a thread into a CappedLog
    (and echoed to sys.stderr as it comes, when `echo`: as text, so that a progress bar on the
    terminal, which takes over sys.stderr, prints it above itself)."""

    def __init__(self, path: Path, echo: bool = False) -> None:
        self.read_fd, self.write_fd = os.pipe()
        self.log = CappedLog(path)
        self.echo = echo
        self._decode = codecs.getincrementaldecoder("utf-8")("replace").decode  # a character cut between reads
        self._stop = threading.Event()
        self._done = False
        self._thread = threading.Thread(target=self._run, name=f"log {path.name}", daemon=True)

    def child_started(self) -> None:
        """The child has its copy of the write end: the launcher's goes, so the end of the child's
        (and of whatever it started) is the end of the log; and the reading starts (a thread started
        only now: the robot host is forked from the launcher, which is best done without threads)."""
        if self.write_fd >= 0:
            os.close(self.write_fd)
            self.write_fd = -1
            self._thread.start()

    def _run(self) -> None:
        with selectors.DefaultSelector() as sel:
            sel.register(self.read_fd, selectors.EVENT_READ)
            while not self._stop.is_set():
                if not sel.select(timeout=0.1):
                    continue
                try:
                    chunk = os.read(self.read_fd, 1 << 16)
                except OSError:
                    return
                if not chunk:
                    return
                self.log.write(chunk)
                if self.echo:
                    with contextlib.suppress(OSError, ValueError):
                        sys.stderr.write(self._decode(chunk))
                        sys.stderr.flush()

    def finish(self, timeout_s: float = 2.0) -> None:
        """Read until every writer has closed its end (or timeout_s passes: something the race left
        holds it), then close the log with its end.  Once; later calls do nothing."""
        if self._done:
            return
        self._done = True
        self.child_started()
        self._thread.join(timeout_s)
        self._stop.set()
        self._thread.join()  # within 0.1 s: it looks at the stop every 0.1 s
        os.close(self.read_fd)
        self.log.close()
