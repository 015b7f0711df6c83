"""The bench cache: a race's inputs hashed into a key, its result kept under <cache>/bench-cache/<key>.json.

The key covers everything the race depends on: track, laps, the robots in it and their versions
(Python robots: the boxbox package's source files plus the robot's own file; TORCS robots: their
.so and data files' mtime and size), the Python cars' car, --set values and the learning mode.
The simulation is deterministic, so a cached race is the race.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import time
from pathlib import Path

from boxbox.cache import cache_dir
from boxbox.files import write_json_atomic
from boxbox.robot.loader import BUILTIN
from boxbox.torcs.paths import system_torcs
from boxbox.torcs.results import RaceResult

CACHE_FORMAT = 1


def _hash_files(paths, h=None, root: Path | None = None):
    h = h or hashlib.sha256()
    for p in sorted(paths):
        h.update(str(p.relative_to(root) if root else p).encode() + b"\0")
        try:
            h.update(p.read_bytes())
        except OSError:
            h.update(b"<missing>")
        h.update(b"\0")
    return h


def package_version() -> str:
    """Hash of the boxbox package's sources (.py, setups .toml, the bridge's C++)."""
    root = Path(__file__).resolve().parents[1]  # src/boxbox
    files = [p for ext in ("py", "toml", "cpp", "h") for p in root.rglob(f"*.{ext}") if "__pycache__" not in p.parts]
    return _hash_files(files, root=root).hexdigest()[:16]


def _stat(path: Path) -> str:
    try:
        st = path.stat()
        return f"{st.st_mtime_ns}:{st.st_size}"
    except OSError:
        return "missing"


def python_robot_version(spec: str, package: str | None = None) -> str:
    """The package hash, plus the robot's own file for 'file.py:Class' or outside-boxbox 'module:Class'."""
    h = hashlib.sha256((package or package_version()).encode())
    target = BUILTIN.get(spec, spec)
    where = target.rpartition(":")[0]
    own: Path | None = None
    if where.endswith(".py") or "/" in where:
        own = Path(where).resolve()
    elif where and not where.startswith("boxbox."):
        try:
            found = importlib.util.find_spec(where)
            own = Path(found.origin) if found and found.origin else None
        except (ImportError, ValueError):
            own = None
    if own is not None:
        _hash_files([own], h)
    return h.hexdigest()[:16]


def torcs_robot_version(module: str) -> str:
    """mtime and size of the robot's .so and of its data files."""
    torcs = system_torcs()
    parts = [_stat(torcs.lib_dir / "drivers" / module / f"{module}.so")]
    data = torcs.data_dir / "drivers" / module
    if data.is_dir():
        parts += [f"{p.relative_to(data)}={_stat(p)}" for p in sorted(data.rglob("*")) if p.is_file()]
    return hashlib.sha256("|".join(parts).encode()).hexdigest()[:16]


def _dir_hash(path: Path) -> str:
    files = [p for p in path.rglob("*") if p.is_file()] if path.is_dir() else []
    return _hash_files(files, root=path).hexdigest()[:16]


def cache_key(track: str, car: str, laps: int, robots: list[dict], settings: dict | None, learning: str,
              skill_level: str = "semi-pro", grid_position: int | None = None, fuel_offset_l: float = 0.0) -> str:
    """sha256 of a race's inputs.  robots: [{"entry", "kind", "version"}] in race order.

    The car, settings and learning mode only count when a Python robot is in the race (TORCS robots
    drive their own car and know nothing of them)."""
    has_python = any(r["kind"] == "python" for r in robots)
    inputs = {"format": CACHE_FORMAT, "track": track, "laps": laps,
              "robots": [[r["entry"], r["kind"], r["version"]] for r in robots],
              "car": car if has_python else None,
              "settings": (settings or {}) if has_python else None,
              "learning": learning if has_python else None,
              "torcs": _stat(system_torcs().binary), "skill_level": skill_level, "grid_position": grid_position}
    if has_python and fuel_offset_l:  # only when given: every earlier key stays as it was
        inputs["fuel_offset_l"] = fuel_offset_l
    if has_python and learning == "on":
        inputs["learned"] = _dir_hash(cache_dir() / "learning")
    return hashlib.sha256(json.dumps(inputs, sort_keys=True, default=str).encode()).hexdigest()


def cache_path(key: str) -> Path:
    return cache_dir() / "bench-cache" / f"{key}.json"


def load_cached(key: str) -> RaceResult | None:
    try:
        return RaceResult.from_json(json.loads(cache_path(key).read_text())["result"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def store(key: str, inputs: dict, result: RaceResult) -> None:
    path = cache_path(key)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, {"key": key, "inputs": inputs, "stored": time.strftime("%Y-%m-%d %H:%M:%S"),
                             "result": result.to_json()}, indent=1)
