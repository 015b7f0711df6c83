"""The built wheel is what a user installs: it must carry py.typed (PEP 561), or a user's mypy and
IDE see none of boxbox's annotations, and the bridge's C++ source, which `boxbox setup` builds."""

from __future__ import annotations

import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _uv() -> str:
    """uv as ./boxbox finds it (PATH, then pip --user's ~/.local/bin)."""
    found = shutil.which("uv") or shutil.which("uv", path=str(Path.home() / ".local" / "bin"))
    if found is None:
        pytest.skip("uv is not installed (./boxbox installs it)")
    return found


def test_the_wheel_carries_py_typed(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith("VIRTUAL_ENV")}
    done = subprocess.run([_uv(), "build", "--wheel", "--out-dir", str(tmp_path), "--quiet", str(ROOT)],
                          capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    (wheel,) = tmp_path.glob("boxbox-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "boxbox/py.typed" in names
    assert "boxbox/torcs/bridge/boxbox_bridge.cpp" in names
