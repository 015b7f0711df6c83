"""One check per kind of option value, shared by every entry point: the command line (cli/types.py's
click types wrap these), `boxbox.race`, the Gymnasium env and the SCR server.

A check takes the value as a caller gives it (text from the command line, or any Python object),
returns it converted, or raises UsageError with one line.  Given `name` (the argument's name, e.g.
'laps'), the line starts "Invalid value for 'laps': "; the command line's click adds its own
("Invalid value for '--laps': "), so every entry point says the same after the name.  The words
are click's where click had words for it ("0 is not in the range 1<=x<=10000.").
"""

from __future__ import annotations

import math
import numbers
import operator
import os
import tempfile
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from boxbox.errors import UsageError
from boxbox.files import REGULAR, WRITE_THROUGH, output_kind, output_target
from boxbox.options import LEARNING_MODES, PIT_MODES

MAX_LAPS = 10_000  # far beyond any race worth running; keeps lap counts clear of C int overflows
MAX_GRID_SLOT = 40  # a TORCS race file holds 40 cars
SKILL_LEVELS = ("rookie", "amateur", "semi-pro", "pro")  # model/skill.py's SkillLevel, as driver files spell them
MAX_SENSORS = 360  # range finders of the env (SCR's clients have 19)
# the ranges of the race options the command line and boxbox.race share: (low, high)
FUEL_LAPS = (0.01, 10_000)
STEP_BUDGET_MS = (1, 60_000)
SETUP_BUDGET_S = (0.1, 3600)
# the SCR server's: a client silent this long is gone (another client's identification takes over);
# SCR's snakeoil client gives up after about 7 s
CLIENT_TIMEOUT_S = (0.1, 3600)
CLIENT_TIMEOUT_S_DEFAULT = 3.0
# `boxbox dataset`'s action noise, in each action column's half range: past twice it, the robot's
# action is lost in the noise
ACTION_NOISE = (0.0, 2.0)
# the shipped robot as the env's teacher, its action held for 0.1 s (the env's default), leaves
# g-track-1 at 1,137 m; held for 0.04 s it laps in 42.7 s (docs/gym.md, "The robot as teacher")
DATASET_ACTION_REPEAT = 2
ROBOT_HINT = "give a name ('boxbox'), 'path/file.py:Class', 'module:Class' or a boxbox.Robot subclass"


def fail(message: str, name: str | None = None) -> NoReturn:
    """Raise the UsageError for a bad value (with the argument's name first, when given)."""
    raise UsageError(message if name is None else f"Invalid value for {name!r}: {message}")


def range_text(lo: float | None, hi: float | None, lo_open: bool = False, hi_open: bool = False) -> str:
    """A range as click describes it: '1<=x<=10000', 'x>0', 'x<=5'."""
    if lo is None and hi is None:
        return "x"
    if hi is None:
        return f"x{'>' if lo_open else '>='}{lo}"
    if lo is None:
        return f"x{'<' if hi_open else '<='}{hi}"
    return f"{lo}{'<' if lo_open else '<='}x{'<' if hi_open else '<='}{hi}"


# --- numbers -----------------------------------------------------------------------------------
def whole_number(value: Any, lo: int | None = None, hi: int | None = None, *, name: str | None = None) -> int:
    """A whole number ('3' or 3; not True, not 3.0) within lo..hi."""
    if isinstance(value, str):
        try:
            number = int(value.strip())
        except ValueError:
            fail(f"{value!r} is not a valid integer.", name)
    elif isinstance(value, bool) or not hasattr(value, "__index__"):
        fail(f"{value!r} is not a valid integer.", name)
    else:
        number = operator.index(value)
    if (lo is not None and number < lo) or (hi is not None and number > hi):
        fail(f"{number} is not in the range {range_text(lo, hi)}.", name)
    return number


def finite_number(value: Any, lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
                  hi_open: bool = False, name: str | None = None) -> float:
    """A finite number ('2.5', 2.5 or 2; not True, NaN or an infinity) within lo..hi."""
    number = _real(value, name)
    if math.isnan(number):
        fail(f"{number} is not a finite number.", name)
    below = lo is not None and (number <= lo if lo_open else number < lo)
    above = hi is not None and (number >= hi if hi_open else number > hi)
    if below or above:
        fail(f"{number} is not in the range {range_text(lo, hi, lo_open, hi_open)}.", name)
    if math.isinf(number):
        fail(f"{number} is not a finite number.", name)
    return number


def _real(value: Any, name: str | None) -> float:
    if isinstance(value, bool) or not isinstance(value, str | numbers.Real):
        fail(f"{value!r} is not a valid float.", name)
    try:
        return float(value.strip() if isinstance(value, str) else value)
    except ValueError:
        fail(f"{value!r} is not a valid float.", name)
    except OverflowError:  # an int beyond float's range
        fail(f"{value} is not a finite number.", name)


def positive_limit(value: Any, *, name: str | None = None) -> float | None:
    """A limit that None switches off, else a finite number above 0."""
    return None if value is None else finite_number(value, 0, None, lo_open=True, name=name)


def laps(value: Any, *, name: str | None = None) -> int:
    return whole_number(value, 1, MAX_LAPS, name=name)


def fuel_laps(value: Any, *, name: str | None = None) -> float | None:
    """Start fuel for this many laps; None: the robot's choice."""
    return None if value is None else finite_number(value, *FUEL_LAPS, name=name)


def step_budget_ms(value: Any, *, name: str | None = None) -> float:
    return finite_number(value, *STEP_BUDGET_MS, name=name)


def setup_budget_s(value: Any, *, name: str | None = None) -> float:
    return finite_number(value, *SETUP_BUDGET_S, name=name)


def action_noise(value: Any, *, name: str | None = None) -> float:
    return finite_number(value, *ACTION_NOISE, name=name)


def client_timeout_s(value: Any, *, name: str | None = None) -> float:
    return finite_number(value, *CLIENT_TIMEOUT_S, name=name)


def flag(value: Any, *, name: str | None = None) -> bool:
    if not isinstance(value, bool):
        fail(f"{value!r} is not True or False.", name)
    return value


# --- choices and names -------------------------------------------------------------------------
def choice(value: Any, choices: Sequence[str], *, name: str | None = None) -> str:
    """One of `choices`, spelt exactly."""
    if isinstance(value, str) and value in choices:
        return value
    fail(f"{value!r} is not one of {', '.join(map(repr, choices))}.", name)


def pit_mode(value: Any, *, name: str | None = None) -> str:
    return choice(value, PIT_MODES, name=name)


def learning_mode(value: Any, *, name: str | None = None) -> str:
    return choice(value, LEARNING_MODES, name=name)


def skill_level(value: Any, *, name: str | None = None) -> str:
    """A skill level's name ('semi-pro'; model.skill.SkillLevel.parse turns it into the level)."""
    return choice(value, SKILL_LEVELS, name=name)


def text(value: Any, what: str, example: str, *, name: str | None = None) -> str:
    """A name (a track, a car): a printable string with something in it."""
    if not isinstance(value, str) or not value.strip() or not value.isprintable():
        fail(f"{value!r} is not a {what}; give one like {example!r}.", name)
    return value.strip()


def grid_position(value: Any, *, name: str | None = None) -> int | str | None:
    """A grid slot: 1 (pole) .. 40, or 'last'; None: the default (pole)."""
    if value is None or (isinstance(value, str) and value.strip() == "last"):
        return None if value is None else "last"
    try:
        number = int(value.strip()) if isinstance(value, str) else _index(value)
    except (ValueError, TypeError):
        fail(f"{value!r} is not a grid slot; give a number from 1 (pole) or 'last'.", name)
    if not 1 <= number <= MAX_GRID_SLOT:
        fail(f"{number} is not a grid slot; TORCS grids have 1 to {MAX_GRID_SLOT}.", name)
    return number


def _index(value: Any) -> int:
    if isinstance(value, bool):
        raise TypeError("a bool is no number here")
    return operator.index(value)


# --- lists ---------------------------------------------------------------------------------------
def items(value: Any, what: str, *, name: str | None = None) -> list:
    """A list's items: a string is a comma list ('a, b' -> ['a', 'b'], blanks dropped), any other
    iterable (a list, a tuple) its items; a mapping, bytes or a lone number is refused."""
    if isinstance(value, str):
        return [part.strip() for part in value.split(",") if part.strip()]
    if isinstance(value, bytes | bytearray | Mapping) or not isinstance(value, Iterable):
        fail(f"{value!r} is not a list of {what}.", name)
    return list(value)


def names(value: Any, what: str, *, unique: bool = True, name: str | None = None) -> list[str]:
    """'a,b,c' or ['a', 'b', 'c'] -> ['a', 'b', 'c'] (blanks dropped; with unique, repeats too)."""
    out = []
    for item in items(value, what, name=name):
        if not isinstance(item, str) or not item.isprintable():
            fail(f"{item!r} is not one of the {what}; give names.", name)
        if item.strip():
            out.append(item.strip())
    return list(dict.fromkeys(out)) if unique else out


def lap_list(value: Any, *, name: str | None = None) -> list[int]:
    """Laps ('3,7' or [3, 7]), each 1..MAX_LAPS, repeats dropped, in the order given."""
    return list(dict.fromkeys(laps(item, name=name) for item in items(value, "laps, e.g. '3,7'", name=name)))


def lap_lengths(value: Any, *, name: str | None = None) -> list[int]:
    """Race lengths: '10', '8,10,12' or '6-14' (both ends included), or a list of numbers."""
    if isinstance(value, str) and "-" in value and "," not in value:
        lo, _, hi = value.strip().partition("-")
        first, last = laps(lo, name=name), laps(hi, name=name)
        if last < first:
            fail(f"{value.strip()!r}: the range ends before it starts (e.g. 6-14).", name)
        return list(range(first, last + 1))
    lengths = lap_list(value, name=name)
    if not lengths:
        fail("give at least one race length, e.g. 10 or 6-14.", name)
    return lengths


def opponent_list(value: Any, *, name: str | None = None) -> list[str]:
    """TORCS robots: 'bt:2,berniw:3' or ['bt:2', ('berniw', 3)] -> ['bt:2', 'berniw:3'] (the names
    and indices are checked against the installed TORCS later, torcs/checks.py)."""
    out = []
    for item in items(value, "opponents, e.g. 'bt:2,berniw:3'", name=name):
        if isinstance(item, tuple | list) and len(item) == 2 and isinstance(item[0], str) \
                and not isinstance(item[1], bool) and hasattr(item[1], "__index__"):
            item = f"{item[0]}:{operator.index(item[1])}"
        if not isinstance(item, str) or not item.strip() or not item.isprintable():
            fail(f"{item!r} is not an opponent; give 'module:idx', e.g. 'bt:2'.", name)
        out.append(item.strip())
    return out


def robot_list(value: Any, *, name: str | None = None) -> list:
    """Python robots: one spec or class, or a list of them (a string is one robot, as one --robot
    is: a robot file's path may hold a comma); at least one."""
    if isinstance(value, str | type):
        value = [value]
    robots = items(value, "robots", name=name)
    if not robots:
        fail(f"{value!r} has no robot; give at least one, e.g. ['boxbox'].", name)
    out: list = []
    for item in robots:
        if isinstance(item, str) and item.strip() and item.isprintable():
            out.append(item.strip())
        elif isinstance(item, type):
            out.append(item)  # loader.spec_for_class checks it is a Robot subclass
        else:
            fail(f"{item!r} is not a robot; {ROBOT_HINT}.", name)
    return out


def angle_list(value: Any, *, name: str | None = None) -> tuple[float, ...]:
    """Sensor angles in degrees: 1 to MAX_SENSORS finite numbers in -180..180."""
    angles = tuple(finite_number(a, -180, 180, name=name) for a in items(value, "angles in degrees", name=name))
    if not 1 <= len(angles) <= MAX_SENSORS:
        fail(f"{len(angles)} angles: give 1 to {MAX_SENSORS}, e.g. (-45, 0, 45).", name)
    return angles


# --- robot settings --------------------------------------------------------------------------------
def settings(value: Any, *, name: str | None = None) -> dict[str, Any]:
    """Robot parameters: a dict {'mu_scale': 0.9}, or 'KEY=VALUE' strings as --set takes them
    ('mu_scale=0.9', values read as TOML: numbers, true, "text"); None: none."""
    if value is None:
        return {}
    if isinstance(value, Mapping):
        pairs = list(value.items())
    else:
        pairs = [_key_value(item, name) for item in items(value, "KEY=VALUE settings", name=name)]
    for key, setting in pairs:
        if not isinstance(key, str) or not key.strip():
            fail(f"{key!r} is not a parameter name; e.g. {{'mu_scale': 0.9}}.", name)
        if not isinstance(setting, bool | int | float | str):
            fail(f"{key!r}: {setting!r} is not a number, True/False or a string.", name)
    return {key.strip(): setting for key, setting in pairs}


def _key_value(item: Any, name: str | None) -> tuple[str, Any]:
    if not isinstance(item, str) or "=" not in item:
        fail(f"{item!r} is not KEY=VALUE, e.g. 'mu_scale=0.9'.", name)
    key, _, text_value = item.partition("=")
    try:
        return key.strip(), tomllib.loads(f"v = {text_value}")["v"]
    except tomllib.TOMLDecodeError:
        return key.strip(), text_value


# --- files and folders ---------------------------------------------------------------------------
def shown(path: Path) -> str:
    """A path as a message shows it: as it is, or quoted when it holds a newline or the like (the
    message stays one line)."""
    text_ = str(path)
    return text_ if text_.isprintable() else repr(text_)


def _path(value: Any, name: str | None) -> Path:
    if not isinstance(value, str | os.PathLike) or (isinstance(value, str) and not value.strip()):
        fail(f"{value!r} is not a path.", name)
    try:
        path = Path(os.path.abspath(os.path.expanduser(value)))
    except (ValueError, TypeError):  # a PathLike of bytes
        fail(f"{value!r} is not a path.", name)
    if "\0" in str(path):  # no file name holds a NUL byte (and the system calls refuse it)
        fail(f"{value!r} is not a path.", name)
    return path


def probe_writable(folder: Path) -> str | None:
    """None when a file can be created in folder, else why not (a real create: permissions alone
    do not tell, e.g. /proc or a read-only mount)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".boxbox-probe-", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    os.unlink(probe)
    return None


def output_file(value: Any, *, name: str | None = None) -> Path:
    """A file boxbox will write: made absolute, its folder must exist and take a new file."""
    path = _path(value, name)
    try:
        why = _output_file_problem(path)
    except OSError as exc:  # a name too long, say
        why = f"{shown(path)}: {exc.strerror or exc}; choose another file."
    if why:
        fail(why, name)
    return path


def _output_file_problem(path: Path) -> str | None:
    target = output_target(path)  # a symlink's target is what gets written (files.atomic_path)
    kind = output_kind(target)
    if kind == WRITE_THROUGH:  # a device or FIFO: written into, no file made beside it
        return None if os.access(target, os.W_OK) else f"{shown(path)} is not writable; choose another file."
    if kind != REGULAR:
        return f"{shown(path)} is {kind}; give a file name."
    if not target.parent.is_dir():
        existing = _nearest_existing(target.parent)
        if not existing.is_dir():
            return f"{shown(existing)} is a file, not a folder; give a file in a folder."
        return f"folder {shown(target.parent)} does not exist; create it first."
    if why := probe_writable(target.parent):
        return f"cannot write in {shown(target.parent)} ({why}); choose another place."
    if target.exists() and not os.access(target, os.W_OK):
        return f"{shown(path)} is not writable; choose another file."
    return None


def _nearest_existing(path: Path) -> Path:
    """path, or the nearest folder above it that exists (a file in the way counts: it exists)."""
    return next(p for p in (path, *path.parents) if p.exists())


def output_dir(value: Any, *, name: str | None = None) -> Path:
    """A folder boxbox will write into: made absolute; it, or the nearest folder above it that
    exists (where it will be created), must take a new file."""
    path = _path(value, name)
    try:
        existing = _nearest_existing(path)
    except OSError as exc:
        fail(f"{shown(path)}: {exc.strerror or exc}; choose another place.", name)
    if not existing.is_dir():
        fail(f"{shown(existing)} is a file, so {shown(path)} cannot be a folder.", name)
    if why := probe_writable(existing):
        where = shown(path) if existing == path else f"{shown(path)} (in {shown(existing)})"
        fail(f"cannot write in {where}: {why}; choose another place.", name)
    return path


def input_file(value: Any, *, name: str | None = None) -> Path:
    """A file boxbox will read: made absolute; it must exist and be a file."""
    path = _path(value, name)
    try:
        found, folder = path.exists(), path.is_dir()
    except OSError as exc:
        fail(f"{shown(path)}: {exc.strerror or exc}.", name)
    if not found:
        fail(f"file {shown(path)} does not exist.", name)
    if folder:
        fail(f"{shown(path)} is a folder; give a file.", name)
    return path
