"""Writing files so that a reader never sees half of one: a temporary file beside it, then a rename.

This is boxbox's only write-then-rename: every whole-file write that others may read at the same
time (results, fault records, telemetry, cached arrays, the bridge build) goes through
`atomic_path`.  A write that fails (a full disk, an exception in the writer) leaves the old file as
it was and no temporary file behind.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any


@contextlib.contextmanager
def atomic_path(path: Path | str) -> Iterator[Path]:
    """A fresh temporary path beside `path` (same folder, same suffix) for the block to write; when
    the block succeeds it is renamed over `path`, and when anything fails it is removed."""
    path = Path(path)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; a result file is as readable as any other
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_bytes_atomic(path: Path | str, data: bytes) -> None:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_text_atomic(path: Path | str, text: str) -> None:
    """Write text to path atomically: concurrent writers leave one whole file (the last one's)."""
    write_bytes_atomic(path, text.encode())


def write_json_atomic(path: Path | str, data: Any, indent: int | None = None) -> None:
    write_text_atomic(path, json.dumps(data, indent=indent))


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
