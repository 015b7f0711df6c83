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

from boxbox.robot.template import robot_files

ROOT = Path(__file__).resolve().parents[1]
BOXBOX = [sys.executable, "-m", "boxbox.cli"]
ROBOTS = ROOT / "tests" / "robots"


def template_robot(folder: Path, name: str = "parts") -> Path:
    """The robot `boxbox new-robot NAME` writes (robot/template.py), saved in folder: its path."""
    path = folder / f"{name}.py"
    path.write_text(robot_files(name)[path.name])
    return path


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


VIEWPORT = {"width": 1280, "height": 1000}  # the pages' tests' browser window (CSS pixels)


def open_page(browser, page_file: Path, ready: str | None = "window.replay && window.replay.ready"):
    """The page loaded (and its viewer ready, unless ready is None); the list it appends console
    errors, page errors and any request off the page's own file to."""
    page = browser.new_page(viewport=VIEWPORT)
    errors: list[str] = []
    page.on("console", lambda m: errors.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    page.on("request", lambda r: errors.append(f"request: {r.url}") if not r.url.startswith(("file:", "data:"))
            else None)
    page.goto(page_file.as_uri())
    if ready:
        page.wait_for_function(ready, timeout=30_000)
    return page, errors


# The Gymnasium env with observations in units, the grid start, a decision every drive step and two
# pedals: what the tests that drive by hand in units from the grid take (the env's defaults scale the
# observations, start along the lap and take one pedal column: tests/unit/gym/test_gym_defaults.py)
GRID_IN_UNITS = dict(raw_observations=True, random_start=False, action_repeat=1, actions=("steer", "throttle", "brake"))
