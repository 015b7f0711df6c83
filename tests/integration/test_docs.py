"""The docs run as tests: every ```python block and every `boxbox ...` / `./boxbox ...` line of a
```sh (bash, shell, console) block in README.md and docs/*.md runs as written, one test per block
(its id is FILE:LINE of the opening fence). A new block is found without touching this file.

Markers, each an HTML comment on the line just before a block's opening fence (several may stand
on the lines above it, one a line):
    <!-- doctest: skip: REASON -->        the block is not run
    <!-- doctest: parse-only: REASON -->  each command's arguments are parsed by click (make_context):
                                          its options must exist and its values be valid; nothing runs
    <!-- example: NAME -->                the python block is a robot file, NAME.py, in the folder its
                                          document's commands run in (`--robot NAME.py:Class`)
A skip or parse-only marker without a reason fails the block's test.

A python block that stands alone (every name it reads it imports or defines) is what a user saves
as a script: it runs as one, `python FILE.py` in its document's folder, so that what only a script
meets (a vector env's worker processes importing the script again) is met. Every python block,
skipped ones too, must compile, and one that starts worker processes (SubprocVecEnv,
AsyncVectorEnv, multiprocessing) must start them under `if __name__ == "__main__":`. The other
python blocks of a document (and the robot files) run in order in one namespace, like a notebook
(a block may use what an earlier one defined). Commands run with bash, each document's in a folder of its own that
holds the document's example files, `./boxbox` (this checkout's command, also first on PATH as
`boxbox`) and an empty `docs/`. HOME is a folder of its own too: its ~/.cache/boxbox links the real
cache's set-up (headers, bridge, overlay, cached tracks) but has its own runs, learned data and
tune studies, so the docs' races leave nothing in the user's cache. For the commands that name
them, the folder holds RUN_DIR (a 1-lap race's run dir) and ~/.cache/boxbox/tune/NAME.toml and
road.toml (setup files such as `boxbox tune` writes).

Every race a block runs (each new run dir) is checked: no error, each Python car finished its laps
and made each stop it asked for; and a robot the docs describe does what their prose says (CLAIMS).
"""

from __future__ import annotations

import ast
import builtins
import json
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SHELLS = {"sh", "bash", "shell", "console"}
FENCE = re.compile(r"^```(\w*)\s*$")
MARKER = re.compile(r"^<!--\s*(doctest|example):\s*(.*?)\s*-->\s*$")
COMMAND = re.compile(r"^(?:\./)?boxbox(?:\s|$)")
# what the test's HOME keeps of its own; everything else of the cache is a link to the real one
OWN_CACHE = {"runs", "learning", "tune", "logs", "setup.lock"}
COMMAND_TIMEOUT_S = 600


@dataclass
class Block:
    doc: Path
    line: int  # the opening fence's, from 1
    lang: str
    text: str
    markers: list[tuple[str, str]] = field(default_factory=list)  # (kind, value): ("skip", reason)
    example: str | None = None  # NAME of <!-- example: NAME -->

    @property
    def id(self) -> str:
        return f"{self.doc.relative_to(ROOT)}:{self.line}"

    def commands(self) -> list[tuple[int, str]]:
        """(line number, command) of each boxbox command line (`$ ` prompts dropped, `\\` lines joined)."""
        found: list[tuple[int, str]] = []
        start, pending = 0, ""
        for i, raw in enumerate(self.text.splitlines()):
            line = raw.strip()
            if self.lang == "console" and not pending:
                if not line.startswith("$ "):
                    continue
                line = line[2:]
            if not pending:
                start = self.line + 1 + i
            line = f"{pending} {line}" if pending else line
            pending = line[:-1].rstrip() if line.endswith("\\") else ""
            if not pending and COMMAND.match(line):
                found.append((start, line))
        return found


def parse_blocks(doc: Path, text: str) -> list[Block]:
    """The python and shell blocks of a markdown text, with the markers just above each."""
    lines = text.splitlines()
    blocks: list[Block] = []
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        end = next((j for j in range(i + 1, len(lines)) if lines[j].startswith("```")), len(lines))
        lang = m.group(1)
        if lang == "python" or lang in SHELLS:
            block = Block(doc, i + 1, lang, "\n".join(lines[i + 1:end]) + "\n")
            k = i - 1
            while k >= 0 and (mm := MARKER.match(lines[k])):
                if mm.group(1) == "example":
                    block.example = mm.group(2)
                else:
                    kind, _, reason = mm.group(2).partition(":")
                    block.markers.append((kind.strip(), reason.strip()))
                k -= 1
            blocks.append(block)
        i = end + 1
    return blocks


def all_blocks() -> list[Block]:
    return [b for doc in DOCS for b in parse_blocks(doc, doc.read_text())]


def marker_problem(block: Block) -> str | None:
    for kind, reason in block.markers:
        if kind not in ("skip", "parse-only"):
            return f"{block.id}: unknown marker 'doctest: {kind}' (skip or parse-only)"
        if not reason:
            return f"{block.id}: <!-- doctest: {kind}: REASON --> needs its reason"
    if len(block.markers) > 1:
        return f"{block.id}: one doctest marker a block"
    return None


# --- python blocks as scripts ----------------------------------------------------------------------

# what starts worker processes, which (with spawn or forkserver, SubprocVecEnv's default) import the
# script again: without its `if __name__ == "__main__":` each worker would start its own
WORKER_PROCESSES = re.compile(r"SubprocVecEnv|AsyncVectorEnv|vectorization_mode\s*=\s*[\"']async|multiprocessing"
                              r"|ProcessPoolExecutor")


def free_names(text: str) -> set[str]:
    """The names a python block reads but neither imports nor defines (nor are builtins): what it
    takes from its document's earlier blocks."""
    bound, read = set(), set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Name):
            (read if isinstance(node.ctx, ast.Load) else bound).add(node.id)
        elif isinstance(node, ast.arg):
            bound.add(node.arg)
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            bound.add(node.name)
        elif isinstance(node, ast.alias):
            bound.add((node.asname or node.name).split(".")[0])
        elif isinstance(node, ast.ExceptHandler) and node.name:
            bound.add(node.name)
    return read - bound - set(dir(builtins))


def is_script(block: Block) -> bool:
    """A python block a user saves and runs as a script: it stands alone (a robot file is a module)."""
    return block.lang == "python" and block.example is None and not free_names(block.text)


def _main_guard(node: ast.stmt) -> bool:
    return isinstance(node, ast.If) and ast.unparse(node.test).replace("'", '"') == '__name__ == "__main__"'


def unguarded_workers(text: str) -> list[int]:
    """The lines of top-level statements that start worker processes outside the main guard."""
    return [node.lineno for node in ast.parse(text).body
            if not (_main_guard(node) or isinstance(node, ast.Import | ast.ImportFrom | ast.FunctionDef | ast.ClassDef))
            and WORKER_PROCESSES.search(ast.get_source_segment(text, node) or "")]


# --- what the docs say their robots do -------------------------------------------------------------

def _finishes(result: dict, driver: dict) -> None:
    assert driver["laps"] >= result["laps"], f"{driver['name']}: {driver['laps']} of {result['laps']} laps"


def _pitstopper(result: dict, driver: dict) -> None:
    """docs/robots.md: finishes its race with little damage and stops within a few tenths of a
    metre of its box's centre."""
    _finishes(result, driver)
    assert driver["damage"] < 100, f"{driver['name']}: damage {driver['damage']}"
    stops = [e for e in driver.get("pit_events", []) if e.get("stop_time") is not None]
    assert stops and driver["pit_stops"] == len(stops), f"{driver['name']}: no stop made: {driver}"
    for stop in stops:
        assert abs(stop["stop_error_m"]) < 0.5, f"{driver['name']}: stopped {stop['stop_error_m']} m from its box"


def _no_damage(result: dict, driver: dict) -> None:
    """docs/robots.md: the keepers finish their lap without touching each other (or anything)."""
    _finishes(result, driver)
    assert driver["damage"] == 0, f"{driver['name']}: damage {driver['damage']}"


# robot name (its cars are "NAME 1", ...) -> (the doc that races it, the check of each of its cars)
CLAIMS: dict[str, tuple[str, Callable[[dict, dict], None]]] = {
    "pitstopper": ("docs/robots.md", _pitstopper),
    "follower": ("docs/robots.md", _finishes),
    "keeper": ("docs/robots.md", _no_damage),
    "slowkeeper": ("docs/robots.md", _no_damage),
}


def check_race(result: dict, origin: str) -> None:
    """Every race of the docs: no error, a car finished the race, no Python car out of it (damage
    10000) or stuck for long (over 10 s, as the sweep's target), no stop it asked for missed; alone,
    it finished every lap (with others, a slow car is lapped); and the CLAIMS of the docs' robots."""
    assert result.get("error") is None, f"{origin}: the race failed: {result['error']}"
    drivers = result["drivers"]
    assert any(d["laps"] >= result["laps"] for d in drivers), f"{origin}: no car finished the race: {drivers}"
    for d in drivers:
        if d["module"] != "boxbox":
            continue
        assert d["laps"] >= result["laps"] or len(drivers) > 1, \
            f"{origin}: {d['name']} finished {d['laps']} of {result['laps']} laps (damage {d['damage']})"
        assert d["damage"] < 10_000 and d["longest_stuck_s"] <= 10.0, \
            f"{origin}: {d['name']}: damage {d['damage']}, stuck for {d['longest_stuck_s']} s"
        assert not d.get("missed_pit_stops"), f"{origin}: {d['name']} missed stops: {d['missed_pit_stops']}"
        robot = d["name"].rsplit(" ", 1)[0]
        if robot in CLAIMS:
            CLAIMS[robot][1](result, d)


# --- where a document's blocks run -----------------------------------------------------------------

@dataclass
class Workspace:
    """A document's folder, HOME and python namespace; env is what its commands run with."""

    folder: Path
    home: Path
    env: dict[str, str]
    namespace: dict = field(default_factory=dict)
    ran: dict[int, BaseException | None] = field(default_factory=dict)  # python block line -> its error

    @property
    def runs(self) -> Path:
        return self.home / ".cache" / "boxbox" / "runs"

    def run_dirs(self) -> set[Path]:
        return set(self.runs.iterdir()) if self.runs.is_dir() else set()


def make_workspace(folder: Path, blocks: list[Block], real_cache: Path) -> Workspace:
    home = folder / "home"
    cache = home / ".cache" / "boxbox"
    cache.mkdir(parents=True)
    for entry in real_cache.iterdir():
        if entry.name not in OWN_CACHE:
            (cache / entry.name).symlink_to(entry)
    from boxbox.robot.tunable import write_setup

    (cache / "tune").mkdir()
    for name in ("NAME", "road"):  # the setup files the docs name as a study's result
        write_setup(cache / "tune" / f"{name}.toml", {"mu_scale": 0.95}, ["a setup file, as boxbox tune writes"])
    work = folder / "work"
    (work / "docs").mkdir(parents=True)
    (work / "boxbox").symlink_to(Path(sys.executable).parent / "boxbox")
    for b in blocks:
        if b.example:
            (work / f"{b.example}.py").write_text(b.text)
    env = {k: v for k, v in os.environ.items() if k not in ("BOXBOX_CACHE", "XDG_CACHE_HOME", "BOXBOX_RUN_DIR")}
    env.update(HOME=str(home), PATH=f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}")
    return Workspace(work, home, env)


_WORKSPACES: dict[Path, Workspace] = {}


@pytest.fixture
def workspace(request, overlay, tmp_path_factory, monkeypatch):
    """The block's document's workspace (made once a session), entered: cwd and environment."""
    from boxbox.cache import cache_dir

    block: Block = request.getfixturevalue("block")
    real_cache = cache_dir()
    ws = _WORKSPACES.get(block.doc)
    if ws is None:
        blocks = parse_blocks(block.doc, block.doc.read_text())
        ws = make_workspace(tmp_path_factory.mktemp(block.doc.stem), blocks, real_cache)
        _WORKSPACES[block.doc] = ws
    monkeypatch.chdir(ws.folder)
    for key in ("BOXBOX_CACHE", "XDG_CACHE_HOME"):
        monkeypatch.delenv(key, raising=False)
    monkeypatch.setenv("HOME", ws.home.as_posix())
    if any("RUN_DIR" in c for _, c in block.commands()) and not (ws.folder / "RUN_DIR").exists():
        import boxbox

        boxbox.race(track="g-track-1", laps=1, run_dir=ws.folder / "RUN_DIR")
    return ws


def new_results(ws: Workspace, before: set[Path]) -> list[dict]:
    out = []
    for run in sorted(ws.run_dirs() - before):
        if (run / "result.json").exists():
            out.append(json.loads((run / "result.json").read_text()))
    return out


# --- running a block -------------------------------------------------------------------------------

def shell_words(command: str, ws: Workspace) -> list[str]:
    """The command's arguments as bash makes them (quotes, ~, comments), the command word dropped."""
    rest = command.split(None, 1)[1] if len(command.split(None, 1)) > 1 else ""
    proc = subprocess.run(["bash", "-c", "printf '%s\\0' " + rest], cwd=ws.folder, env=ws.env,
                          capture_output=True, text=True, check=True)
    return proc.stdout.split("\0")[:-1]


def parse_only(argv: list[str]) -> None:
    """Parse a boxbox command line as click would run it, without running it."""
    from boxbox.cli import main_group

    cmd: click.Command = main_group
    name, parent, args = "boxbox", None, list(argv)
    while isinstance(cmd, click.Group):
        ctx = click.Context(cmd, info_name=name, parent=parent)
        sub = cmd.get_command(ctx, args[0]) if args else None
        assert sub is not None, f"no command {args[:1]} in `{name}`"
        parent, name, cmd, args = ctx, args[0], sub, args[1:]
    with cmd.make_context(name, args, parent=parent):
        pass


def run_commands(block: Block, ws: Workspace, parse: bool) -> None:
    commands = block.commands()
    assert commands, f"{block.id}: a shell block without a boxbox command line (mark it skip, or make it text)"
    for line, command in commands:
        where = f"{block.doc.relative_to(ROOT)}:{line}: {command}"
        if parse:
            try:
                parse_only(shell_words(command, ws))
            except click.ClickException as exc:
                pytest.fail(f"{where}\n  {exc.format_message()}")
            continue
        before, start_s = ws.run_dirs(), time.monotonic()
        proc = subprocess.run(["bash", "-c", command], cwd=ws.folder, env=ws.env, capture_output=True, text=True,
                              timeout=COMMAND_TIMEOUT_S, stdin=subprocess.DEVNULL)
        print(f"{time.monotonic() - start_s:6.1f} s  {where}")  # shown with -s, or when the test fails
        assert proc.returncode == 0, f"{where}\n  exit {proc.returncode}:\n{proc.stdout[-3000:]}{proc.stderr[-3000:]}"
        for result in new_results(ws, before):
            check_race(result, where)


def _run_once(block: Block, ws: Workspace) -> BaseException | None:
    """Run a python block in its document's namespace (once a session), its races checked; its error."""
    if block.line not in ws.ran:
        before = ws.run_dirs()
        try:
            exec(compile(block.text, block.id, "exec"), ws.namespace)  # noqa: S102 - the docs' own code
            for result in new_results(ws, before):
                check_race(result, block.id)
            ws.ran[block.line] = None
        except Exception as exc:  # noqa: BLE001 - kept: a later block of the document names it
            ws.ran[block.line] = exc
    return ws.ran[block.line]


def run_script(block: Block, ws: Workspace) -> None:
    """The block saved as a file in its document's folder and run with python, as a user runs it."""
    path = ws.folder / f"{block.doc.stem}_{block.line}.py"
    path.write_text(block.text)
    before, start_s = ws.run_dirs(), time.monotonic()
    proc = subprocess.run([sys.executable, path.name], cwd=ws.folder, env=ws.env, capture_output=True, text=True,
                          timeout=COMMAND_TIMEOUT_S, stdin=subprocess.DEVNULL)
    print(f"{time.monotonic() - start_s:6.1f} s  {block.id} as a script")
    assert proc.returncode == 0, (f"{block.id}, run as a script ({path.name}): exit {proc.returncode}:\n"
                                  f"{proc.stdout[-3000:]}{proc.stderr[-3000:]}")
    for result in new_results(ws, before):
        check_race(result, block.id)


def run_python(block: Block, ws: Workspace) -> None:
    """A script on its own; another block after the document's python blocks before it, like a notebook."""
    if is_script(block):
        run_script(block, ws)
        return
    for b in parse_blocks(block.doc, block.doc.read_text()):
        if b.lang == "python" and b.line < block.line and not b.markers and (exc := _run_once(b, ws)):
            pytest.fail(f"{block.id}: the earlier block {b.id} failed: {exc!r}")
    if exc := _run_once(block, ws):
        raise exc


@pytest.mark.parametrize("block", all_blocks(), ids=lambda b: b.id)
def test_doc_block(block: Block, request) -> None:
    if problem := marker_problem(block):
        pytest.fail(problem)
    kinds = dict(block.markers)
    if "skip" in kinds:
        pytest.skip(kinds["skip"])
    ws = request.getfixturevalue("workspace")
    if block.lang == "python":
        assert "parse-only" not in kinds, f"{block.id}: parse-only is for shell blocks"
        run_python(block, ws)
    else:
        run_commands(block, ws, parse="parse-only" in kinds)


def test_every_python_block_compiles_and_starts_its_workers_under_the_main_guard() -> None:
    """Skipped blocks too: what a block that trains for long would do as a script is checked here."""
    for block in all_blocks():
        if block.lang == "python":
            compile(block.text, block.id, "exec")
            lines = [block.line + n for n in unguarded_workers(block.text)]
            assert not lines, f"{block.id}: line(s) {lines} start worker processes outside " \
                              "`if __name__ == \"__main__\":` (each worker imports the script again)"


def test_every_claimed_robot_is_raced_by_its_doc() -> None:
    """A robot whose behaviour CLAIMS checks is raced by a command its doc runs (not skipped)."""
    for robot, (doc, _) in CLAIMS.items():
        blocks = parse_blocks(ROOT / doc, (ROOT / doc).read_text())
        example = next((b for b in blocks if b.example and re.search(rf'name = "{robot}"', b.text)), None)
        assert example, f"{doc} has no example robot named {robot}"
        raced = [c for b in blocks if b.lang in SHELLS and not b.markers for _, c in b.commands()
                 if f"--robot {example.example}.py:" in c]
        assert raced, f"{doc}: no command that runs races {example.example}.py"


# --- the parser itself (no TORCS) ------------------------------------------------------------------

SAMPLE = """# Doc

```sh
./boxbox race --laps 1   # one lap
ls -l
boxbox params \\
    --track g-track-1
```

<!-- doctest: skip: takes an hour -->
```bash
./boxbox soak
```

<!-- doctest: parse-only:   -->
```sh
boxbox bench
```

<!-- example: bot -->
```python
print("hi")
```

```text
./boxbox race
```
"""


def test_blocks_are_found_with_their_lines_markers_and_commands() -> None:
    blocks = parse_blocks(ROOT / "docs" / "sample.md", SAMPLE)
    assert [(b.id, b.lang) for b in blocks] == [("docs/sample.md:3", "sh"), ("docs/sample.md:11", "bash"),
                                                ("docs/sample.md:16", "sh"), ("docs/sample.md:21", "python")]
    assert blocks[0].commands() == [(4, "./boxbox race --laps 1   # one lap"),
                                    (6, "boxbox params --track g-track-1")]
    assert blocks[1].markers == [("skip", "takes an hour")] and marker_problem(blocks[1]) is None
    assert "needs its reason" in (marker_problem(blocks[2]) or "")
    assert blocks[3].example == "bot" and blocks[3].text == 'print("hi")\n'


def test_parse_only_refuses_what_click_refuses(tmp_path) -> None:
    parse_only(["race", "--track", "g-track-1", "--laps", "2"])
    parse_only(["drill", "stop", "--at", "1500"])
    with pytest.raises(click.ClickException, match="--lapz"):
        parse_only(["race", "--lapz", "2"])
    with pytest.raises(click.ClickException, match="range"):
        parse_only(["race", "--laps", "0"])
    with pytest.raises(AssertionError, match="no command"):
        parse_only(["rase"])


def test_a_failing_claim_fails() -> None:
    driver = {"name": "pitstopper 1", "module": "boxbox", "laps": 3, "damage": 0, "pit_stops": 1, "longest_stuck_s": 0,
              "missed_pit_stops": [], "pit_events": [{"stop_time": 20.0, "stop_error_m": 0.7}]}
    with pytest.raises(AssertionError, match="0.7 m from its box"):
        check_race({"laps": 3, "error": None, "drivers": [driver]}, "x")
    bt = {"name": "bt 2", "module": "bt", "laps": 3}
    with pytest.raises(AssertionError, match="2 of 3 laps"):  # lapped: fine for others, not for the PitStopper
        check_race({"laps": 3, "error": None, "drivers": [bt, {**driver, "laps": 2}]}, "x")
    with pytest.raises(AssertionError, match="no car finished"):
        check_race({"laps": 3, "error": None, "drivers": [{**driver, "laps": 2}]}, "x")
    check_race({"laps": 3, "error": None, "drivers": [{**driver, "pit_events": [{"stop_time": 2.0,
                                                                                  "stop_error_m": 0.2}]}]}, "x")


UNGUARDED = """import multiprocessing
import sys

worker = multiprocessing.get_context("spawn").Process(target=print, args=("worker",))
worker.start()
worker.join()
sys.exit(worker.exitcode)
"""


def test_a_script_block_runs_as_a_script_and_its_guard_is_checked(tmp_path) -> None:
    """A block that starts a worker without the main guard works in the notebook namespace but fails
    as the script a user saves; the guard check names it, and the guarded block runs."""
    guarded = UNGUARDED.replace("worker = ", 'if __name__ == "__main__":\n    worker = ').replace(
        "\nworker.", "\n    worker.").replace("\nsys.exit", "\n    sys.exit")
    ws = Workspace(tmp_path, tmp_path, dict(os.environ))
    bad, good = (Block(ROOT / "docs" / "sample.md", line, "python", text) for line, text in ((1, UNGUARDED),
                                                                                          (20, guarded)))
    assert is_script(bad) and is_script(good) and not free_names(UNGUARDED)
    assert unguarded_workers(UNGUARDED) == [4] and unguarded_workers(guarded) == []
    with pytest.raises(AssertionError, match="run as a script"):
        run_script(bad, ws)
    run_script(good, ws)
    assert free_names("result = boxbox.race(robots=[MyRobot])") == {"boxbox", "MyRobot"}
