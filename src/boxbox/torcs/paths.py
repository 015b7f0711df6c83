"""Where TORCS and boxbox's own TORCS files live.  The only module that knows TORCS paths."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from boxbox.cache import cache_dir  # noqa: F401  (re-exported: setup and launch use it)

BRIDGE_SOURCE = Path(__file__).parent / "bridge" / "boxbox_bridge.cpp"
ROBOT_MODULE = "boxbox"  # the name TORCS loads our bridge under
MAX_PYTHON_CARS = 10  # robot slots in one TORCS module


@dataclass(frozen=True)
class TorcsInstall:
    """The system TORCS from Debian's package (override with BOXBOX_TORCS_LIB/_DATA)."""

    lib_dir: Path
    data_dir: Path

    @property
    def binary(self) -> Path:
        return self.lib_dir / "torcs-bin"

    @property
    def shared_lib_dir(self) -> Path:
        return self.lib_dir / "lib"


def system_torcs() -> TorcsInstall:
    return TorcsInstall(
        lib_dir=Path(os.environ.get("BOXBOX_TORCS_LIB", "/usr/lib/x86_64-linux-gnu/torcs")),
        data_dir=Path(os.environ.get("BOXBOX_TORCS_DATA", "/usr/share/games/torcs")),
    )


# files taken from Debian's torcs source package: enough to compile a robot module
HEADER_MEMBERS = [
    "src/interfaces/*.h",
    "src/libs/tgf/tgf.h",
    "src/libs/tgf/os.h",
    "src/linux/osspec.h",
    "src/libs/robottools/robottools.h",
    "src/libs/math/*.h",
]
