"""docs/architecture.md's table names every module under src/boxbox/ in its folder's row, and no
module that does not exist."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src" / "boxbox"
DOC = ROOT / "docs" / "architecture.md"
# a row of the table: | `src/boxbox/FOLDER/` (or a top-level module, or `*.py`) | what lives there | may import |
ROW = re.compile(r"^\| `src/boxbox/([^`]*)`[^|]*\| ([^|]*)\|", re.MULTILINE)
MODULE_NAME = re.compile(r"`([\w/]+\.py)`")


def _rows(doc: str) -> dict[str, set[str]]:
    """Folder ("" for the top-level modules, whose rows are `api.py` and `*.py`) -> the module
    names its row gives: in its second column, or in its first for a module's own row."""
    rows: dict[str, set[str]] = {}
    for key, text in ROW.findall(doc):
        folder = key.rstrip("/") if key.endswith("/") else ""
        own = {key} if MODULE_NAME.fullmatch(f"`{key}`") else set()
        rows.setdefault(folder, set()).update(MODULE_NAME.findall(text), own)
    return rows


def _modules(src: Path, folder: str) -> list[Path]:
    """The modules of a folder and its subfolders (the top level's own only), relative to it."""
    base = src / folder
    found = base.rglob("*.py") if folder else base.glob("*.py")
    return sorted(p.relative_to(base) for p in found if p.name != "__init__.py")


def _mismatches(doc: str, src: Path) -> tuple[list[str], list[str]]:
    """(modules no row names, names in a row that are no module). A row names a module by its file
    name or its path from the folder; a name with a folder in it may also be a path from src/."""
    rows = _rows(doc)
    folders = {""} | {p.name for p in src.iterdir() if p.is_dir() and any(p.rglob("*.py"))}
    missing = [f"{folder or '.'}: {m}" for folder in sorted(folders) for m in _modules(src, folder)
               if str(m) not in rows.get(folder, set()) and m.name not in rows.get(folder, set())]
    unknown = [f"{folder or '.'}: {name}" for folder, names in sorted(rows.items()) for name in sorted(names)
               if not (src / folder / name).exists() and not any((src / folder).rglob(name))
               and not (src.parent / name).exists()]
    return missing, unknown


def test_the_doc_names_every_module():
    missing, unknown = _mismatches(DOC.read_text(), SRC)
    assert not missing, "name these modules in their folder's row of docs/architecture.md: " + "; ".join(missing)
    assert not unknown, "docs/architecture.md names modules that do not exist: " + "; ".join(unknown)


def test_the_check_catches_a_missing_and_an_unknown_module(tmp_path):
    """The check itself can fail: a module left out and a name of no module are both seen."""
    (tmp_path / "pkg" / "sub").mkdir(parents=True)
    for name in ("pkg/__init__.py", "pkg/a.py", "pkg/b.py", "pkg/sub/c.py", "top.py"):
        (tmp_path / name).write_text("")
    doc = ("| folder | what | may import |\n|---|---|---|\n"
           "| `src/boxbox/pkg/` | `a.py` and `sub/c.py`, `gone.py` | x |\n"
           "| `src/boxbox/top.py` | the top | x |\n"
           "| `src/boxbox/*.py` (shared) | none | x |\n")
    assert _mismatches(doc, tmp_path) == (["pkg: b.py"], ["pkg: gone.py"])
    whole = doc.replace("`gone.py`", "`b.py`")
    assert _mismatches(whole, tmp_path) == ([], [])
