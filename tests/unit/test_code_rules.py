"""The code rules of docs/architecture.md held by CI: imports run one way, down its table of folders,
no function is over 60 lines, no module or class over about 500."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src" / "boxbox"

SHARED = {"errors", "files", "options", "cache", "validate"}
# docs/architecture.md's table: what each folder (or top-level module) may import
ALLOWED = {
    "errors": set(), "files": {"errors"}, "options": set(), "cache": {"files"},
    "validate": {"errors", "options", "files"},
    "model": set(),
    "control": {"model"} | SHARED,
    "robot": {"control", "model"} | SHARED,
    "torcs": {"robot", "model"} | SHARED,
    "report": {"torcs", "model"} | SHARED,
    "bench": {"report", "torcs", "robot", "control", "model"} | SHARED,
    "gym": {"torcs", "robot", "control", "model"} | SHARED,
    "tune": {"report", "torcs", "robot", "model"} | SHARED,
    "testing": {"torcs", "robot", "model"} | SHARED,
}
ALLOWED["api"] = set(ALLOWED) - {"api"}
ALLOWED["cli"] = set(ALLOWED) - {"cli"}
ALLOWED["__init__"] = ALLOWED["__main__"] = set(ALLOWED) - {"__init__", "__main__"}
# of torcs/, report/ reads only a run dir's files: it never starts TORCS
REPORT_READS = {"results", "telemetry", "positions", "recording"}
MAX_FUNCTION_LINES = 60
MAX_MODULE_LINES = 500  # per module and per class: a file per concern
# modules over the cap today, each to be split along its seams (the count is a ceiling: it may only fall)
OVER_THE_CAP = {
}


def _unit_of(path: Path) -> str:
    parts = path.relative_to(SRC).parts
    return parts[0] if len(parts) > 1 else parts[0].removesuffix(".py")


def _split(module: str) -> tuple[str, str]:
    """boxbox.x.y -> (x, y); boxbox.x -> (x, "")."""
    parts = module.split(".") + [""]
    return parts[1], parts[2]


def _imports(tree: ast.AST) -> set[tuple[str, str]]:
    """(unit, module in it) for each boxbox import of a module; `from boxbox import x` -> (x, "")."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module == "boxbox":
            out.update((a.name, "") for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("boxbox."):
            out.add(_split(node.module or ""))
        elif isinstance(node, ast.Import):
            out.update(_split(a.name) for a in node.names if a.name.startswith("boxbox."))
    return out


SOURCES = sorted(SRC.rglob("*.py"))


def test_every_unit_is_in_the_table():
    units = {_unit_of(p) for p in SOURCES}
    assert units <= set(ALLOWED), f"add {sorted(units - set(ALLOWED))} to ALLOWED and to docs/architecture.md"


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(SRC)))
def test_imports_run_down(path: Path):
    unit = _unit_of(path)
    imports = _imports(ast.parse(path.read_text()))
    upward = sorted(u for u, _ in imports if u != unit and u not in ALLOWED[unit])
    assert not upward, f"{unit} may not import {upward} (docs/architecture.md)"
    if unit == "report":
        starts = sorted(m for u, m in imports if u == "torcs" and m not in REPORT_READS)
        assert not starts, f"report imports torcs.{starts}: only the run dir's readers {sorted(REPORT_READS)}"


def _long_functions(tree: ast.AST) -> list[tuple[str, int, int]]:
    """(name, first line, lines) of each function in tree over MAX_FUNCTION_LINES."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            lines = (node.end_lineno or node.lineno) - node.lineno + 1
            if lines > MAX_FUNCTION_LINES:
                out.append((node.name, node.lineno, lines))
    return out


def test_no_function_over_the_limit():
    long = [f"{path.relative_to(SRC)}:{line} {name} ({lines} lines)"
            for path in SOURCES for name, line, lines in _long_functions(ast.parse(path.read_text()))]
    assert not long, "split these functions: " + "; ".join(long)


def _long_classes(tree: ast.AST) -> list[tuple[str, int, int]]:
    """(name, first line, lines) of each class in tree over MAX_MODULE_LINES."""
    return [(node.name, node.lineno, (node.end_lineno or node.lineno) - node.lineno + 1) for node in ast.walk(tree)
            if isinstance(node, ast.ClassDef) and (node.end_lineno or node.lineno) - node.lineno >= MAX_MODULE_LINES]


def test_no_module_or_class_over_the_cap():
    lines = {str(path.relative_to(SRC)): len(path.read_text().splitlines()) for path in SOURCES}
    big = [f"{name} ({n} lines)" for name, n in lines.items() if n > OVER_THE_CAP.get(name, MAX_MODULE_LINES)]
    assert not big, "split these modules along their seams: " + "; ".join(big)
    gone = sorted(name for name in OVER_THE_CAP if lines.get(name, 0) <= MAX_MODULE_LINES)
    assert not gone, f"now under the cap: take {gone} off OVER_THE_CAP"
    long = [f"{path.relative_to(SRC)}:{line} {name} ({n} lines)"
            for path in SOURCES for name, line, n in _long_classes(ast.parse(path.read_text()))]
    assert not long, "split these classes: " + "; ".join(long)


def test_the_rules_catch_a_breach():
    """The checks themselves can fail: an upward import and a long method are both seen."""
    tree = ast.parse("from boxbox.robot.tutorial import TutorialRobot\nimport boxbox.cli.main\n")
    assert _imports(tree) == {("robot", "tutorial"), ("cli", "main")}
    assert "cli" not in ALLOWED["robot"]
    body = "class C:\n    def f(self):\n" + "        x = 1\n" * MAX_FUNCTION_LINES
    assert _long_functions(ast.parse(body)) == [("f", 2, MAX_FUNCTION_LINES + 1)]
    assert _long_functions(ast.parse("def g():\n" + "    x = 1\n" * (MAX_FUNCTION_LINES - 1))) == []
    big = "class D:\n" + "    x = 1\n" * MAX_MODULE_LINES
    assert _long_classes(ast.parse(big)) == [("D", 1, MAX_MODULE_LINES + 1)]
    assert _long_classes(ast.parse("class E:\n" + "    x = 1\n" * (MAX_MODULE_LINES - 1))) == []
