"""A race's run directory: the one owner of its files' names.

Every race runs in a folder of its own (so races never collide): `--run-dir`, or a new folder
under `CACHE/runs` (`RunDir.new`), where the oldest automatic ones are pruned (`prune_runs`).
What the folder holds, documented in docs/reliability.md:

| file | written by | what |
|---|---|---|
| `.lock` | launcher | its pid; an flock held for the race (a second race there is refused) |
| `.auto` | launcher | marks a folder made under `CACHE/runs` (only those are ever pruned) |
| `race.xml`, `local/` | launcher | TORCS's race file and local folder (TORCS's results land there) |
| `host-spec.json` | launcher | what the robot host is to run |
| `host.log` | robot host | everything the robots print (stdout, stderr), and the host's own errors |
| `torcs.out`, `torcs.err` | TORCS | its console (progress lines) and its errors (`BOXBOX-FAULT` lines) |
| `fault.json` | robot host | the robot fault that stopped the race (`faults.Fault`) |
| `hang-traceback.txt` | robot host | where a hung robot was stuck (faulthandler, on SIGUSR1) |
| `telemetry.parquet` | robot host | every drive step of the Python cars (`torcs/telemetry.py`) |
| `states.parquet` | robot host | each drive step's `State` of the Python cars (`boxbox.testing.recorded_states`) |
| `.telemetry-N.rows`, `.sig` | robot host | telemetry spool while the race runs (removed at the end) |
| `recording.parquet` | robot host | every car, 10 times a second, for `boxbox replay` (`torcs/recording.py`) |
| `.telemetry-race.rows` | robot host | the recording's spool while the race runs (removed at the end) |
| `result.json` | launcher | the race's result (`results.RaceResult`) |
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from boxbox.cache import cache_dir
from boxbox.errors import UsageError

RESULT_FILE = "result.json"  # the names others read: the report, the tests
TELEMETRY_FILE = "telemetry.parquet"
STATES_FILE = "states.parquet"  # written with the telemetry, from the same rows
RECORDING_FILE = "recording.parquet"
KEEP_RUNS_DEFAULT = 50  # automatic run dirs kept under CACHE/runs (BOXBOX_KEEP_RUNS overrides)
AUTO_MARK = ".auto"


class RunDir:
    """A race's folder (absolute, so a relative --run-dir works from any working directory)."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(os.path.abspath(os.path.expanduser(path)))

    def __repr__(self) -> str:
        return f"RunDir({str(self.path)!r})"

    def __str__(self) -> str:
        return str(self.path)

    # --- the files -------------------------------------------------------------------------
    @property
    def lock_file(self) -> Path:
        return self.path / ".lock"

    @property
    def race_file(self) -> Path:
        return self.path / "race.xml"

    @property
    def local(self) -> Path:
        return self.path / "local"

    @property
    def host_spec(self) -> Path:
        return self.path / "host-spec.json"

    @property
    def host_log(self) -> Path:
        return self.path / "host.log"

    @property
    def torcs_out(self) -> Path:
        return self.path / "torcs.out"

    @property
    def torcs_err(self) -> Path:
        return self.path / "torcs.err"

    @property
    def fault(self) -> Path:
        return self.path / "fault.json"

    @property
    def hang_traceback(self) -> Path:
        return self.path / "hang-traceback.txt"

    @property
    def torcs_stack(self) -> Path:
        return self.path / "torcs-stack.txt"

    @property
    def telemetry(self) -> Path:
        return self.path / TELEMETRY_FILE

    @property
    def states(self) -> Path:
        return self.path / STATES_FILE

    @property
    def recording(self) -> Path:
        return self.path / RECORDING_FILE

    @property
    def recording_spool(self) -> Path:
        """The recording's spool (named like the telemetry's, so the same clean-ups remove it)."""
        return self.path / ".telemetry-race.rows"

    @property
    def result(self) -> Path:
        return self.path / RESULT_FILE

    def spool(self, car: int, kind: str) -> Path:
        """A telemetry spool file of one Python car (kind: rows or sig)."""
        return self.path / f".telemetry-{car}.{kind}"

    def results_file(self) -> Path | None:
        """TORCS's results file of the race, if it wrote one."""
        files = sorted((self.local / "results").glob("*/results-*.xml"))
        return files[-1] if files else None

    def read_text(self, path: Path) -> str:
        """One of the folder's text files, or "" when it is absent or unreadable."""
        try:
            return path.read_text(errors="replace")
        except OSError:
            return ""

    # --- its life ---------------------------------------------------------------------------
    def make(self) -> None:
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(f"run dir {self.path} cannot be made: {exc.strerror or exc}") from None

    def clear_stale(self) -> None:
        """Remove what an earlier race in this folder left, so nothing of it is read as this race's."""
        for path in (self.fault, self.hang_traceback, self.torcs_stack, self.telemetry, self.states, self.recording,
                     self.result, self.torcs_err, self.torcs_out):
            path.unlink(missing_ok=True)
        for spool in self.path.glob(".telemetry-*"):
            spool.unlink(missing_ok=True)
        shutil.rmtree(self.local / "results", ignore_errors=True)

    def remove_temporaries(self) -> None:
        """Telemetry spool and half-written files a killed host left (a host that ends normally
        removes its own), and hang-traceback.txt when no hang wrote in it."""
        for path in [*self.path.glob(".telemetry-*"), *self.path.glob(".*.tmp*")]:
            path.unlink(missing_ok=True)
        with contextlib.suppress(OSError):  # the host opens it for a hang's stack: kept only when one came
            if self.hang_traceback.stat().st_size == 0:
                self.hang_traceback.unlink()

    @contextlib.contextmanager
    def locked(self) -> Iterator[None]:
        """Hold .lock for the race: a second race in the same folder is refused (exit 2).

        An flock, so it goes with the process: a launcher killed outright leaves no stale lock."""
        fd = os.open(self.lock_file, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
                raise UsageError(f"run dir {self.path} is in use by another race"
                                 + (f" (pid {holder})" if holder else "")
                                 + "; give each race its own --run-dir") from None
            os.ftruncate(fd, 0)
            os.pwrite(fd, str(os.getpid()).encode(), 0)
            yield
        finally:
            os.close(fd)

    @classmethod
    def new(cls, keep: int | None = None) -> RunDir:
        """A new folder under CACHE/runs, named by the time; the oldest automatic ones beyond the
        newest `keep` (BOXBOX_KEEP_RUNS, default 50) are removed first."""
        root = runs_root()
        root.mkdir(parents=True, exist_ok=True)
        prune_runs(root, keep_runs(keep) - 1)
        run = cls(tempfile.mkdtemp(prefix=time.strftime("%Y%m%d-%H%M%S-"), dir=root))
        (run.path / AUTO_MARK).touch()
        return run


def runs_root() -> Path:
    return cache_dir() / "runs"


def keep_runs(keep: int | None = None) -> int:
    """How many automatic run dirs to keep: `keep`, else $BOXBOX_KEEP_RUNS, else 50 (at least 1)."""
    if keep is None:
        try:
            keep = int(os.environ.get("BOXBOX_KEEP_RUNS", KEEP_RUNS_DEFAULT))
        except ValueError:
            keep = KEEP_RUNS_DEFAULT
    return max(1, keep)


def prune_runs(root: Path, keep: int) -> list[Path]:
    """Remove the automatic run dirs under root beyond the newest `keep` (by name: the time they were
    made); folders without the `.auto` mark (a --run-dir) and folders a race holds are never removed."""
    try:
        auto = sorted(p for p in root.iterdir() if (p / AUTO_MARK).exists())
    except OSError:
        return []
    removed = []
    for old in auto[: max(0, len(auto) - keep)]:
        if _in_use(old):
            continue
        shutil.rmtree(old, ignore_errors=True)
        removed.append(old)
    return removed


def _in_use(path: Path) -> bool:
    try:
        fd = os.open(path / ".lock", os.O_RDONLY | os.O_CLOEXEC)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        return False
    except BlockingIOError:
        return True
    finally:
        os.close(fd)
