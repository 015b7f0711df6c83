"""Writing outputs so that a reader never sees half of one, and so that an output never replaces
what it lands on.

This is boxbox's only writer of whole files: every output (results, fault records, telemetry,
cached arrays, pages, the bridge build, every command's --json/--csv/--markdown/--out/--report)
goes through `atomic_path`.  What the path names decides how it is written:
- a regular file (or none yet): a temporary file beside it, then a rename, so a reader sees the
  old file or the new one; a write that fails (a full disk, an exception in the writer) leaves the
  old file as it was and no temporary file behind;
- a symlink: followed to its target, which is written as above; the link stays;
- a character device or a FIFO (/dev/null, a pipe a reader waits on): written through, opened for
  writing as `>` in a shell opens it, never renamed over (a rename would turn /dev/null into a
  regular file for the whole machine);
- a block device or a socket: refused (`output_kind`), before anything is written.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from boxbox.errors import UsageError

REGULAR, WRITE_THROUGH = "regular", "write-through"


def output_target(path: Path | str) -> Path:
    """Where an output to `path` lands: the path itself, or, for a symlink (a chain of them, or one
    whose target does not exist yet), its final target."""
    return Path(os.path.realpath(path))


def output_kind(target: Path) -> str:
    """REGULAR (a regular file, or nothing yet: replaced atomically), WRITE_THROUGH (a character
    device or FIFO: written into), else what it is that takes no output ('a folder', 'a block
    device', 'a socket')."""
    try:
        mode = os.stat(target).st_mode
    except (FileNotFoundError, NotADirectoryError):  # nothing there yet (a file in the way is found later)
        return REGULAR
    if stat.S_ISREG(mode):
        return REGULAR
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return WRITE_THROUGH
    return "a folder" if stat.S_ISDIR(mode) else "a block device" if stat.S_ISBLK(mode) else "a socket"


@contextlib.contextmanager
def atomic_path(path: Path | str) -> Iterator[Path]:
    """A fresh temporary path (same suffix) for the block to write; when the block succeeds, its
    bytes land on `path` as the module says (renamed over a regular file, a symlink's target, or
    copied into a device or FIFO), and when anything fails it is removed."""
    target = output_target(path)
    kind = output_kind(target)
    if kind not in (REGULAR, WRITE_THROUGH):  # validate.output_file refuses these before any work
        raise UsageError(f"{target} is {kind}; give a file to write.")
    through = kind == WRITE_THROUGH
    # a device's folder (/dev) takes no temporary files: those go to the temp folder, then through
    folder = Path(tempfile.gettempdir()) if through else target.parent
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=f".tmp{target.suffix}", dir=folder)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        if through:
            _write_through(tmp, target)
        else:
            os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; a result file is as readable as any other
            os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


def _write_through(tmp: Path, target: Path) -> None:
    """Copy tmp's bytes into an existing device or FIFO: opened without O_CREAT or O_TRUNC, so
    nothing is made or replaced (should it be gone meanwhile, the write fails)."""
    out_fd = os.open(target, os.O_WRONLY | os.O_NOCTTY)
    with open(out_fd, "wb") as out, open(tmp, "rb") as src:
        shutil.copyfileobj(src, out)


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
