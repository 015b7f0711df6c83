"""Helpers for the integration tests, which run real TORCS races (never skipped)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
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
