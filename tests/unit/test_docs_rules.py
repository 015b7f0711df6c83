"""Comments and docs say why, with the figure and the command that made it, never when: no text names
a numbered round of work ("session 8", "sessions 8 to 27", "round 2", "this session"), which means
nothing to a user. A figure names its date and command instead."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# the text of the project a user reads: the docs, and the comments and docstrings of the code and tests
TEXT_GLOBS = ["README.md", "docs/**/*.md", "src/**/*.py", "src/**/*.toml", "src/**/*.js", "src/**/*.html",
              "tests/**/*.py", "examples/**/*"]
# "session 8", "Sessions 17 to 27", "session 28's", "round 2", "this session"; not TORCS's race session
# or a process's session (no number after them)
ROUND_OF_WORK = re.compile(r"(?<!--)\b(sessions? \d+|rounds? \d+|this session|last session)\b", re.IGNORECASE)
THIS_FILE = Path(__file__).resolve()
# files other work is rewriting at the same time, each to lose its rounds of work there: drop a file
# from this set when it names none (the last test says which)
PENDING: set[str] = set()


def _texts() -> list[Path]:
    files = {p for glob in TEXT_GLOBS for p in ROOT.glob(glob) if p.is_file()}
    return sorted(p for p in files if p.resolve() != THIS_FILE and "__pycache__" not in p.parts)


def rounds_of_work(text: str) -> list[tuple[int, str]]:
    """(line number, line) of each line of text that names a round of work."""
    return [(n, line.strip()) for n, line in enumerate(text.splitlines(), 1) if ROUND_OF_WORK.search(line)]


def test_the_rule_finds_a_round_of_work_and_leaves_torcs_sessions_alone() -> None:
    text = ("measured in session 16\nSessions 17 to 27 kept it\nsession 28's base\nMeasured this session\n"
            "# issue 57, round 2\nin a race session only\nstarts a child in a session of its own\n")
    assert [n for n, _ in rounds_of_work(text)] == [1, 2, 3, 4, 5]


def test_no_comment_or_doc_names_a_round_of_work() -> None:
    found = [f"{p.relative_to(ROOT)}:{n}: {line}" for p in _texts() if str(p.relative_to(ROOT)) not in PENDING
             for n, line in rounds_of_work(p.read_text(errors="replace"))]
    assert not found, ("name the date and the command that made a figure, not a round of work:\n"
                       + "\n".join(found))


def test_every_file_left_pending_still_names_one() -> None:
    done = [name for name in sorted(PENDING) if not rounds_of_work((ROOT / name).read_text())]
    assert not done, f"these name no round of work: drop them from PENDING in {THIS_FILE.name}: {done}"
