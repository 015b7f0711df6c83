"""Find a robot class from `--robot NAME | path/file.py:Class | module:Class`."""

from __future__ import annotations

import difflib
import importlib
import importlib.util
import sys
from pathlib import Path

from boxbox.errors import UsageError
from boxbox.robot.base import Robot

# built-in robots by name; the first is the default
BUILTIN = {
    "boxbox": "boxbox.robot.tutorial:TutorialRobot",
    "middle": "boxbox.robot.simple:MiddleRobot",
}
DEFAULT_ROBOT = "boxbox"

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


def load_robot_class(spec: str) -> type[Robot]:
    """The Robot subclass named by spec; a UsageError with a one-line hint otherwise."""
    if spec in _REGISTERED:
        return _REGISTERED[spec]
    if spec.startswith("class:"):
        raise UsageError(f"robot {spec} was handed over as a class object, which only a forked robot host "
                         "sees; unset BOXBOX_HOST_EXEC or give the robot as path/file.py:Class")
    target = BUILTIN.get(spec, spec)
    if ":" not in target:
        near = difflib.get_close_matches(spec, BUILTIN, n=3)
        hint = f" (did you mean {', '.join(near)}?)" if near else ""
        raise UsageError(f"unknown robot '{spec}'{hint}; use one of {', '.join(BUILTIN)}, "
                         "path/file.py:Class or module:Class")
    where, _, cls_name = target.rpartition(":")
    if where.endswith(".py") or "/" in where:
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
    else:
        try:
            module = importlib.import_module(where)
        except (Exception, SystemExit) as exc:
            raise UsageError(f"robot module '{where}' failed to import: {import_failure(exc)}"
                             f"{file_hint(where, cls_name, exc)}") from exc
    cls = getattr(module, cls_name, None)
    if cls is None:
        names = [n for n, v in vars(module).items() if isinstance(v, type) and issubclass(v, Robot) and v is not Robot]
        near = difflib.get_close_matches(cls_name, names, n=3) or names[:3]
        hint = f" (robots there: {', '.join(near)})" if near else ""
        raise UsageError(f"'{where}' has no class '{cls_name}'{hint}")
    if not (isinstance(cls, type) and issubclass(cls, Robot)):
        raise UsageError(f"'{target}' is not a boxbox.Robot subclass")
    if cls.drive is Robot.drive:
        raise UsageError(f"robot class {cls_name} ('{target}') does not define drive(self, state), the method "
                         "that returns its Controls every step (see docs/robots.md)")
    return cls


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
