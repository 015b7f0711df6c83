"""The `./boxbox` script at the checkout's root runs the command in the caller's folder: README.md's
`./boxbox race --robot mine.py:Mine`, run from the robot's folder, finds mine.py there (the script
keeps .venv and uv.lock in the checkout).  No race: `params --robot` reads the same path."""

from __future__ import annotations

import subprocess
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "boxbox"
MINE = '''
from dataclasses import dataclass

from boxbox import Controls, Robot


@dataclass
class MineParams:
    lean: float = 0.25


class Mine(Robot):
    param_class = MineParams

    def drive(self, state):
        return Controls(steer=0.0, accel=0.3, gear=1)
'''


def _run(folder: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(SCRIPT), *args], cwd=folder, capture_output=True, text=True, timeout=300)


def test_relative_paths_are_the_callers(tmp_path):
    (tmp_path / "mine.py").write_text(MINE)
    done = _run(tmp_path, "params", "--robot", "mine.py:Mine")
    assert done.returncode == 0, done.stderr
    assert "lean" in done.stdout and "0.25" in done.stdout


def test_a_missing_robot_file_names_the_folder_it_looked_in(tmp_path):
    done = _run(tmp_path, "params", "--robot", "theirs.py:Mine")
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1] == (
        f"boxbox: error: robot file 'theirs.py' does not exist (looked in {tmp_path})")


def test_a_link_to_the_script_finds_its_checkout(tmp_path):
    """A link to ./boxbox (~/bin/boxbox) runs the checkout's command, not one beside the link
    (it said "No `pyproject.toml` found" when the link's folder was taken for the checkout)."""
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / "boxbox").symlink_to(SCRIPT)
    (tmp_path / "mine.py").write_text(MINE)
    done = subprocess.run([str(tmp_path / "bin" / "boxbox"), "params", "--robot", "mine.py:Mine"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "lean" in done.stdout
