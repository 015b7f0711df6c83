"""Helpers for the tests (the integration tests run real TORCS races, never skipped)."""

from __future__ import annotations

import contextlib
import json
import os
import stat
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BOXBOX = [sys.executable, "-m", "boxbox.cli"]
ROBOTS = ROOT / "tests" / "robots"


def run_boxbox(*args: str, timeout: float = 120, env: dict | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200", **(env or {}))
    return subprocess.run([*BOXBOX, *args], capture_output=True, text=True, timeout=timeout, env=env, cwd=ROOT)


def processes_mentioning(text: str) -> list[str]:
    """Command lines of live processes that mention text (our run dir): must be none after a race."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            environ = Path(f"/proc/{pid}/environ").read_bytes().decode(errors="replace")
        except OSError:
            continue
        if text in cmdline or text in environ:
            found.append(f"{pid}: {cmdline}")
    return found


def read_json(path: Path) -> dict:
    return json.loads(path.read_text())


@contextlib.contextmanager
def kept_device(path: str) -> Iterator[str]:
    """Yields the device's path; after the block, fails if it is no longer the same character
    device, and first makes it again (as root: a regression of files.atomic_path must not break
    /dev/null for the whole machine)."""
    before = os.stat(path)
    assert stat.S_ISCHR(before.st_mode)
    try:
        yield path
    finally:
        after = os.stat(path)
        if not stat.S_ISCHR(after.st_mode):
            os.remove(path)
            os.mknod(path, stat.S_IFCHR | 0o666, before.st_rdev)
            os.chmod(path, stat.S_IMODE(before.st_mode))
        assert stat.S_ISCHR(after.st_mode), f"{path} is no longer a character device"
