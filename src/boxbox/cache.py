"""boxbox's cache folder (headers, bridge builds, overlays, runs, racing lines, learned data)."""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from boxbox.files import atomic_path

if TYPE_CHECKING:  # numpy loads with the first cached array: `boxbox tracks` reads the cache folder only
    import numpy as np


def cache_dir() -> Path:
    """$BOXBOX_CACHE, else $XDG_CACHE_HOME/boxbox, else ~/.cache/boxbox."""
    if env := os.environ.get("BOXBOX_CACHE"):
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "boxbox"


def cached_array(kind: str, key_parts: list[bytes], compute: Callable[[], np.ndarray]) -> np.ndarray:
    """compute(), or its earlier result for the same key parts (kept as .npy under the cache)."""
    import numpy as np

    digest = hashlib.sha256(b"\0".join(key_parts)).hexdigest()[:24]
    path = cache_dir() / kind / f"{digest}.npy"
    try:
        return np.load(path)
    except (OSError, ValueError):
        pass
    value = compute()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.save(f, value)  # to the open file: np.save would add .npy to a bare name
    except OSError:
        pass  # a read-only cache only costs time
    return value
