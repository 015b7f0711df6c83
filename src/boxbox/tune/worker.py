"""A worker process of `boxbox tune --workers N`: python -m boxbox.tune.worker CONFIG_JSON CPU."""

from __future__ import annotations

import os
import sys

from boxbox.errors import BoxboxError
from boxbox.tune.objective import TuneConfig
from boxbox.tune.study import StopFlag, run_worker


def main(argv: list[str]) -> int:
    cfg = TuneConfig.from_json(argv[0])
    cpu = int(argv[1]) if len(argv) > 1 and int(argv[1]) >= 0 else None
    if cpu is not None:  # the worker's own sampling runs between its races, on their core
        os.sched_setaffinity(0, {cpu})
    stop = StopFlag()
    stop.install()
    try:
        run_worker(cfg, cpu, stop)
    except BoxboxError as exc:
        print(f"boxbox tune worker: error: {exc}", file=sys.stderr)
        return exc.exit_code
    return 130 if stop.set else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
