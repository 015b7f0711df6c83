"""Choices a race offers beyond its track, car and robots, shared by the command line and the benches.

Each choice is a Literal (click shows its values; mypy checks them), with its values in a tuple.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Literal, get_args

from boxbox.cache import cache_dir

PitMode = Literal["constant-decel", "bang-bang"]  # how the robot brakes into its pit box
PIT_MODES: tuple[PitMode, ...] = get_args(PitMode)

# on: the shared learning folder; off: none; fresh: a new empty folder for this race (kept after it)
LearningMode = Literal["on", "off", "fresh"]
LEARNING_MODES: tuple[LearningMode, ...] = get_args(LearningMode)


def learning_dir(mode: LearningMode, run_dir: Path | None = None) -> str | None:
    """The folder robots keep what they learn in: for `fresh`, inside run_dir when one is given."""
    if mode == "off":
        return None
    if mode == "on":
        return str(cache_dir() / "learning")
    if run_dir is not None:
        (run_dir / "learning").mkdir(parents=True, exist_ok=True)
        return str(run_dir / "learning")
    return tempfile.mkdtemp(prefix="boxbox-learning-")
