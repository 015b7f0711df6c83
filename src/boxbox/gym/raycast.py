"""The range finders' hot loop in C (raycast.c), compiled on first use into the cache.

numpy needs ~60 us a step for 19 rays against ~170 edge chords (some twenty array operations,
each paying numpy's call overhead); the C loop needs 5 to 10 us.  The library is built once per source
version with the system's C compiler (boxbox's bridge needs one anyway) and loaded with ctypes;
without a compiler `load()` returns None and gym/sensors.py casts with numpy instead.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
from pathlib import Path

from boxbox.cache import cache_dir

SOURCE = Path(__file__).with_name("raycast.c")
FLAGS = ["-O2", "-shared", "-fPIC", "-Wall"]
_lib: ctypes.CDLL | None = None
_tried = False


def library_path(source: Path = SOURCE) -> Path:
    digest = hashlib.sha256(source.read_bytes() + " ".join(FLAGS).encode()).hexdigest()[:16]
    return cache_dir() / "gym" / f"{source.stem}-{digest}.so"


def build(source: Path = SOURCE) -> Path | None:
    """The compiled library (built now when missing); None without a C compiler or when it fails.
    (gym/render.py builds its render.c the same way.)"""
    path = library_path(source)
    if path.exists():
        return path
    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        return None
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")  # builders side by side never share a file
    proc = subprocess.run([compiler, *FLAGS, "-o", str(tmp), str(source), "-lm"], capture_output=True)
    if proc.returncode != 0:
        tmp.unlink(missing_ok=True)
        return None
    tmp.replace(path)
    return path


def load() -> ctypes.CDLL | None:
    """The library with bb_cast's signature set, once per process; None when it cannot be had."""
    global _lib, _tried
    if not _tried:
        _tried = True
        try:
            path = build()
            lib = ctypes.CDLL(str(path)) if path is not None else None
        except OSError:
            lib = None
        if lib is not None:
            d, p, n = ctypes.c_double, ctypes.c_void_p, ctypes.c_long
            lib.bb_cast.argtypes = [p, n, d, d, d, p, n, d, n, p]
            lib.bb_cast.restype = ctypes.c_long
        _lib = lib
    return _lib
