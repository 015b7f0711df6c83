"""docs/robots.md's field reference is the model's, and mistyped names suggest the real ones."""

from __future__ import annotations

from pathlib import Path

import pytest

from boxbox.model import State
from boxbox.model.reference import CLASSES, markdown
from trackdata import load

DOC = Path(__file__).resolve().parents[2] / "docs" / "robots.md"


def test_the_docs_hold_the_generated_reference():
    text = DOC.read_text()
    section = text[text.index("<!-- fields:start -->") + len("<!-- fields:start -->"):text.index("<!-- fields:end -->")]
    assert section.strip() == markdown().strip(), "run: python -c 'from boxbox.model.reference import markdown'"


def test_every_field_has_a_meaning():
    rows = [line for line in markdown().splitlines() if line.startswith("| `")]
    assert len(rows) > 130 and {c.__name__ for c in CLASSES} <= set(markdown().split())
    assert sum(line.endswith("|  |") for line in rows) <= 3


def test_a_mistyped_name_suggests_the_nearest():
    track, car = load("g-track-1")
    with pytest.raises(AttributeError, match="rpm_redline"):
        car.redline  # noqa: B018
    with pytest.raises(AttributeError, match="length_m"):
        track.lenght_m  # noqa: B018
    # State and Opponent are read dozens of times a step: a __getattr__ hook would slow every read
    # (about 40 ns each), so a mistyped State field gets Python's own "Did you mean" in the traceback
    with pytest.raises(AttributeError):
        State(*([0.0] * 43)).gears  # noqa: B018
