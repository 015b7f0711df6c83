"""Find a robot class from `--robot NAME | path/file.py:Class | module:Class`.

A robot's import is its author's code: it may call os._exit(), be killed, or hang.  So a robot
from a file or a module not imported yet is first loaded (and checked) in a forked child, under the
set-up budget (`in_child`): whatever it does there is one line naming the file, and the command
goes on.  boxbox's own robots are imported in place (the forked robot host then starts with them).
"""

from __future__ import annotations

import contextlib
import difflib
import importlib
import importlib.util
import json
import os
import selectors
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

from boxbox.errors import UsageError
from boxbox.robot.base import Robot

# built-in robots by name; the first is the default
BUILTIN = {
    "boxbox": "boxbox.robot.tutorial:TutorialRobot",
    "middle": "boxbox.robot.simple:MiddleRobot",
}
DEFAULT_ROBOT = "boxbox"
# the time a robot's import and checks may take in the child: the set-up budget's default
# (RaceConfig.setup_budget_ms); a race passes its own
IMPORT_BUDGET_S = 120.0

# robot classes handed over as objects (boxbox.race): the robot host is forked from the process
# that registered them, so it finds them here by their spec "class:NAME@ID"
_REGISTERED: dict[str, type[Robot]] = {}


def spec_for_class(cls: type[Robot]) -> str:
    """A spec naming a Robot subclass given as an object: `module:Class` when the module can be
    imported by name (any host finds it), else a registered in-process one."""
    if not (isinstance(cls, type) and issubclass(cls, Robot)):
        raise UsageError(f"{cls!r} is not a boxbox.Robot subclass")
    module = sys.modules.get(cls.__module__)
    if cls.__module__ not in ("__main__", "builtins") and getattr(module, cls.__qualname__, None) is cls \
            and importlib.util.find_spec(cls.__module__) is not None:
        return f"{cls.__module__}:{cls.__qualname__}"
    spec = f"class:{cls.__qualname__}@{id(cls):x}"
    _REGISTERED[spec] = cls
    return spec


def load_robot_class(spec: str, budget_s: float = IMPORT_BUDGET_S, isolated: bool = True) -> type[Robot]:
    """The Robot subclass named by spec; a UsageError with a one-line hint otherwise.  Unless in a
    process of its own already (isolated=False: the robot host), a robot not imported yet is loaded
    in a child first (`in_child`), so that its import cannot end or hang this process."""
    if isolated and not _imported(spec):
        in_child(spec, lambda cls: cls.name, budget_s)
    return _load(spec)


def robot_names(specs: list[str], check: Callable[[type[Robot]], None], budget_s: float) -> list[str]:
    """Each robot's name (`cls.name`), after loading it and running check on its class: a robot
    that is not boxbox's own in a child (`in_child`), never in this process."""
    def name_of(cls: type[Robot]) -> str:
        check(cls)
        return cls.name

    return [name_of(_load(spec)) if _trusted(spec) else in_child(spec, name_of, budget_s) for spec in specs]


def in_child(spec: str, work: Callable[[type[Robot]], str], budget_s: float) -> str:
    """work(the class spec names), run in a forked child within budget_s; its answer, or a
    UsageError in one line: the child's own, or how it ended (exited, killed, out of time)."""
    read_fd, write_fd = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        os.close(read_fd)
        _child_answer(spec, work, write_fd)
    os.close(write_fd)
    answer, timed_out = b"", False
    try:
        answer, timed_out = _read_answer(read_fd, budget_s)
    finally:
        os.close(read_fd)
        if timed_out or not answer:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        _, status = os.waitpid(pid, 0)
    if timed_out:
        raise UsageError(f"{_what(spec)} did not finish loading within the set-up budget of {budget_s:g} s "
                         "(a hang at import?); fix it, or give more time with --setup-budget-s")
    try:
        reply = json.loads(answer)
    except ValueError:
        raise UsageError(f"{_what(spec)} {_ended(status)} while being loaded, before boxbox could check it; "
                         f"run it with python to see why") from None
    if "error" in reply:
        raise UsageError(reply["error"])
    return str(reply["answer"])


def _child_answer(spec: str, work: Callable[[type[Robot]], str], write_fd: int) -> None:
    try:
        try:
            reply = {"answer": work(_load(spec))}
        except UsageError as exc:
            reply = {"error": str(exc)}
        except BaseException as exc:  # noqa: BLE001  (the robot's own checks failed: told as such)
            reply = {"error": f"{_what(spec)} failed its checks: {import_failure(exc)}"}
        # a line: its end is the answer's (a daemon the import started may hold the pipe open long after)
        data = json.dumps(reply).encode() + b"\n"
        while data:
            data = data[os.write(write_fd, data):]
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(0)


def _read_answer(fd: int, budget_s: float) -> tuple[bytes, bool]:
    """The child's answer (a line), or what it wrote before it closed the pipe; (so far, True) when
    budget_s ran out first."""
    chunks: list[bytes] = []
    deadline = time.monotonic() + budget_s
    with selectors.DefaultSelector() as sel:
        sel.register(fd, selectors.EVENT_READ)
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return b"".join(chunks), True
            if sel.select(timeout=remaining):
                if not (chunk := os.read(fd, 65536)):
                    return b"".join(chunks), False
                chunks.append(chunk)
                if chunk.endswith(b"\n"):
                    return b"".join(chunks), False


def _ended(status: int) -> str:
    code = os.waitstatus_to_exitcode(status)
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"ended its process (exit status {code}: os._exit() or a crash)"


def _what(spec: str) -> str:
    where = BUILTIN.get(spec, spec).rpartition(":")[0] or spec
    if where.endswith(".py") or "/" in where:
        return f"robot file '{where}'"
    return f"robot module '{where}'" if ":" in spec else f"robot '{spec}'"


def _trusted(spec: str) -> bool:
    """boxbox's own robots: imported in place (the forked robot host starts with them)."""
    target = BUILTIN.get(spec, spec)
    return target.partition(":")[0].startswith("boxbox.")


def _imported(spec: str) -> bool:
    """Whether loading spec runs no robot code that has not run here (a class handed over, boxbox's
    own, a module imported already); a file is run afresh each time (it may have been edited)."""
    if spec in _REGISTERED or _trusted(spec):
        return True
    where = spec.rpartition(":")[0]
    return bool(where) and not (where.endswith(".py") or "/" in where) and where in sys.modules


def _load(spec: str) -> type[Robot]:
    """The Robot subclass named by spec, imported in this process."""
    if spec in _REGISTERED:
        return _REGISTERED[spec]
    if spec.startswith("class:"):
        raise UsageError(f"robot {spec} was handed over as a class object, which only a forked robot host "
                         "sees; unset BOXBOX_HOST_EXEC or give the robot as path/file.py:Class")
    target = BUILTIN.get(spec, spec)
    if ":" not in target:
        if target.endswith(".py") and Path(target).is_file():
            names = _robot_classes(_import_file(target))
            raise UsageError(f"robot file '{target}': say which class races, as {target}:CLASS" +
                             (f" (robots there: {', '.join(names)})" if names else
                              "; it defines no boxbox.Robot subclass"))
        near = difflib.get_close_matches(spec, BUILTIN, n=3)
        hint = f" (did you mean {', '.join(near)}?)" if near else ""
        raise UsageError(f"unknown robot '{spec}'{hint}; use one of {', '.join(BUILTIN)}, "
                         "path/file.py:Class or module:Class")
    where, _, cls_name = target.rpartition(":")
    if where.endswith(".py") or "/" in where:
        module = _import_file(where)
    else:
        try:
            module = importlib.import_module(where)
        except (Exception, SystemExit) as exc:
            raise UsageError(f"robot module '{where}' failed to import: {import_failure(exc)}"
                             f"{file_hint(where, cls_name, exc)}") from exc
    cls = getattr(module, cls_name, None)
    if cls is None:
        names = _robot_classes(module)
        near = difflib.get_close_matches(cls_name, names, n=3) or names[:3]
        hint = f" (robots there: {', '.join(near)})" if near else ""
        raise UsageError(f"'{where}' has no class '{cls_name}'{hint}")
    if not (isinstance(cls, type) and issubclass(cls, Robot)):
        raise UsageError(f"'{target}' is not a boxbox.Robot subclass")
    if cls.drive is Robot.drive:
        raise UsageError(f"robot class {cls_name} ('{target}') does not define drive(self, state), the method "
                         "that returns its Controls every step (see docs/robots.md)")
    return cls


def _robot_classes(module) -> list[str]:
    """The robot classes a module defines (else those it imports)."""
    found = [(n, v) for n, v in vars(module).items() if isinstance(v, type) and issubclass(v, Robot) and v is not Robot]
    own = [n for n, v in found if v.__module__ == module.__name__]
    return own or [n for n, _ in found]


def _import_file(where: str):
    """The module of robot file `where`, run afresh, with its folder on sys.path."""
    path = Path(where)
    if not path.is_file():
        raise UsageError(f"robot file '{where}' does not exist (looked in {path.absolute().parent})")
    mod_name = f"boxbox_user_robot_{abs(hash(str(path.resolve())))}"
    module_spec = importlib.util.spec_from_file_location(mod_name, path)
    if module_spec is None or module_spec.loader is None:
        raise UsageError(f"robot file '{where}' cannot be imported as Python")
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[mod_name] = module
    folder = str(path.resolve().parent)
    if folder not in sys.path:  # the robot's own helpers beside it import as in a script
        sys.path.insert(0, folder)
    try:
        module_spec.loader.exec_module(module)
    except (Exception, SystemExit) as exc:  # a robot's sys.exit() at import must not end boxbox
        raise UsageError(f"robot file '{where}' failed to import: {import_failure(exc)}") from exc
    return module


def import_failure(exc: BaseException) -> str:
    """An exception out of a robot's import, in words (its sys.exit() as such)."""
    if isinstance(exc, SystemExit):
        return f"it called sys.exit({'' if exc.code is None else repr(exc.code)})"
    return f"{type(exc).__name__}: {exc}".splitlines()[0]


def file_hint(where: str, cls_name: str, exc: BaseException) -> str:
    """`midbot:MidBot` given beside midbot.py: the file spec it probably meant."""
    missing = isinstance(exc, ModuleNotFoundError) and exc.name == where.partition(".")[0]
    path = Path(where.replace(".", "/") + ".py")
    return f" (did you mean {path}:{cls_name}?)" if missing and path.is_file() else ""
