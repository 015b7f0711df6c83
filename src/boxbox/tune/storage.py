"""Where a study lives, and what happens to the trial of a worker that died.

- Default: an Optuna journal file in the cache (CACHE/tune/NAME.log), for the workers of one
  machine.  Optuna's journal has no heartbeat, so each trial notes its worker (host, pid and the
  process's start time); a RUNNING trial whose worker process is gone (or a zombie) is failed and
  queued again (the same retry as Optuna's RetryHeartbeatStaleTrialCallback) by the next worker
  that looks.  Its writes are serialised by an flock (NAME.log.flock), which dies with its holder.
- `postgresql://USER@HOST/DB` (or `sqlite:///FILE`): Optuna's RDBStorage through SQLAlchemy and
  psycopg, with Optuna's heartbeat: a trial whose worker has not beaten for the grace period (any
  machine) is failed and retried by RetryHeartbeatStaleTrialCallback.  Processes that open a fresh
  database at once make its schema one at a time (an advisory lock).
- The front of `--workers N` fails and queues again at once the trial of a worker it saw die
  (fail_trials_of), on either storage.

Workers take trials under a lock (a file lock, a PostgreSQL advisory lock), so that a study ends
with exactly the asked number of finished trials however many workers join it.
"""

from __future__ import annotations

import contextlib
import fcntl
import math
import os
import re
import socket
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from boxbox.errors import UsageError

STUDY_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,99}$")
WORKER_ATTR = "worker"  # "host:pid:start" of the process running the trial
ADVISORY_LOCK_KEY = 0x626F78  # PostgreSQL advisory lock taken while a worker claims a trial
NO_WORKER_GRACE_S = 60.0  # a RUNNING journal trial that names no worker (not boxbox's claim) is stale after this
SCHEMA_LOCK_KEY = 0x626F79  # PostgreSQL advisory lock taken while a process opens (and maybe makes) the schema


def journal_path(study: str) -> Path:
    from boxbox.cache import cache_dir

    return cache_dir() / "tune" / f"{study}.log"


def describe(url: str | None, study: str) -> str:
    if url is None:
        return f"journal {journal_path(study)}"
    return re.sub(r"://([^:@/]*):[^@/]*@", r"://\1:***@", url)  # no password on the screen


def sqlalchemy_url(url: str) -> str:
    """psycopg (version 3) for postgresql:// URLs; a URL that is not PostgreSQL or SQLite is refused."""
    if url.startswith(("postgresql://", "postgres://")):
        return "postgresql+psycopg://" + url.split("://", 1)[1]
    if url.startswith(("postgresql+psycopg://", "sqlite:///")):
        return url
    raise UsageError(f"--storage: '{describe(url, '')}' is not a storage boxbox knows; give "
                     "postgresql://USER@HOST/DB (or sqlite:///FILE), or leave it out for the journal file")


def quiet_optuna() -> None:
    """No log lines per trial, no warnings that heartbeats and retries are experimental features."""
    import warnings

    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    warnings.filterwarnings("ignore", message="Heartbeat of storage is supposed to be used")


class Storage:
    """An Optuna storage for one study, with its stale-trial rule and its claim lock."""

    def __init__(self, url: str | None, study: str, heartbeat_s: int = 5, grace_s: int = 15,
                 max_retry: int = 3) -> None:
        import optuna
        from optuna.storages.journal import JournalFileBackend

        quiet_optuna()
        self.url, self.study_name, self.max_retry = url, study, max_retry
        self.heartbeat_s = heartbeat_s
        self._lock_conn: Any = None  # the PostgreSQL connection holding the claim lock, while held
        self._stale_checked = -math.inf  # time.monotonic() of the last stale-trial query
        if url is None:
            path = journal_path(study)
            path.parent.mkdir(parents=True, exist_ok=True)
            self.path: Path | None = path
            lock: Any = FlockLock(Path(f"{path}.flock"))  # Optuna calls its acquire and release only
            backend = JournalFileBackend(str(path), lock_obj=lock)
            self.optuna: Any = optuna.storages.JournalStorage(backend)
            return
        self.path = None
        from optuna.storages import RetryHeartbeatStaleTrialCallback

        try:
            with _schema_lock(url):  # Optuna makes a fresh database's schema: one process at a time
                self.optuna = optuna.storages.RDBStorage(
                    sqlalchemy_url(url), heartbeat_interval=heartbeat_s, grace_period=grace_s,
                    heartbeat_stale_trial_callback=RetryHeartbeatStaleTrialCallback(max_retry))
        except UsageError:
            raise
        except Exception as exc:  # sqlalchemy's ArgumentError, OperationalError...
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise UsageError(f"--storage {describe(url, study)}: cannot open it ({first}); "
                             "check the URL, that the server runs and the user may connect") from None

    @property
    def has_heartbeat(self) -> bool:
        return self.url is not None

    @contextlib.contextmanager
    def claim_lock(self) -> Iterator[None]:
        """Held while a worker counts the trials and takes one: a file lock beside the journal or
        the SQLite file, a PostgreSQL advisory lock."""
        lock_file = self.path.with_suffix(".lock") if self.path is not None else \
            Path(self.url.removeprefix("sqlite:///") + ".lock") if self.url and self.url.startswith("sqlite:///") \
            else None
        if lock_file is not None:
            with open(lock_file, "a") as f:
                fcntl.flock(f, fcntl.LOCK_EX)
                try:
                    yield
                finally:
                    fcntl.flock(f, fcntl.LOCK_UN)
            return
        if self.url is not None and self.url.startswith("postgres"):
            from sqlalchemy import text

            # a transaction's lock: its end (commit, rollback, a connection that died) releases it,
            # so no unlock statement
            with self.optuna.engine.begin() as conn:
                conn.execute(text("SELECT pg_advisory_xact_lock(:k)"), {"k": ADVISORY_LOCK_KEY})
                self._lock_conn = conn  # counts() under the lock runs in its transaction: no BEGIN, COMMIT of its own
                try:
                    yield
                finally:
                    self._lock_conn = None
            return
        yield

    def counts(self, study: Any) -> dict[str, int]:
        """Trials per state name: one COUNT query on a database (reading every trial costs more
        as the study grows), from memory for the journal."""
        if self.url is None:
            out: dict[str, int] = {}
            for t in study.get_trials(deepcopy=False):
                out[t.state.name] = out.get(t.state.name, 0) + 1
            return out
        from sqlalchemy import text

        query = text("SELECT state, count(*) FROM trials WHERE study_id = :s GROUP BY state")
        with contextlib.ExitStack() as stack:
            conn = self._lock_conn or stack.enter_context(self.optuna.engine.connect())
            rows = conn.execute(query, {"s": study._study_id})
            return {str(state).rpartition(".")[2]: int(n) for state, n in rows}

    def beat(self, trial_id: int) -> None:
        if self.has_heartbeat:
            self.optuna.record_heartbeat(trial_id)

    def fail_stale(self, study: Any) -> list[int]:
        """Fail (and queue again) the RUNNING trials whose worker is gone; their ids.  On a
        database at most once a heartbeat interval: a trial turns stale only grace_s after its
        last beat, so asking at every claim of a short trial only repeats the answer."""
        import optuna

        if self.has_heartbeat:
            if time.monotonic() - self._stale_checked < self.heartbeat_s:
                return []
            self._stale_checked = time.monotonic()
            stale = self.optuna._get_stale_trial_ids(study._study_id)  # one query; usually none
            if stale:
                optuna.storages.fail_stale_trials(study)
            return stale
        return self._fail_running(study, lambda trial: not worker_alive(trial.user_attrs[WORKER_ATTR])
                                  if WORKER_ATTR in trial.user_attrs else _older_than(trial, NO_WORKER_GRACE_S))

    def fail_trials_of(self, study: Any, dead: set[str]) -> list[int]:
        """Fail (and queue again) the RUNNING trials of the workers tagged `dead` (the front saw
        them end); their numbers.  Under the claim lock."""
        return [self.optuna.get_trial(i).number
                for i in self._fail_running(study, lambda trial: trial.user_attrs.get(WORKER_ATTR) in dead)]

    def _fail_running(self, study: Any, dead: Callable[[Any], bool]) -> list[int]:
        """Fail the RUNNING trials `dead` takes for a dead worker's, each queued again (Optuna's
        RetryHeartbeatStaleTrialCallback, at most max_retry times); their ids.  Under the claim
        lock (a boxbox claim makes a trial RUNNING with its worker noted, study._ask)."""
        import optuna
        from optuna.storages import RetryHeartbeatStaleTrialCallback

        failed = []
        retry = RetryHeartbeatStaleTrialCallback(self.max_retry)
        for trial in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,)):
            if not dead(trial):
                continue
            try:
                if not self.optuna.set_trial_state_values(trial._trial_id, optuna.trial.TrialState.FAIL):
                    continue
            except optuna.exceptions.UpdateFinishedTrialError:
                continue  # failed by another process meanwhile
            failed.append(trial._trial_id)
            retry(study, self.optuna.get_trial(trial._trial_id))
        return failed


def _older_than(trial: Any, age_s: float) -> bool:
    import datetime

    started = trial.datetime_start or datetime.datetime.now()
    return (datetime.datetime.now() - started).total_seconds() >= age_s


def worker_tag(pid: int | None = None) -> str:
    """host:pid:start time of this process, or of process pid (the start time tells a reused pid
    apart)."""
    pid = os.getpid() if pid is None else pid
    return f"{socket.gethostname()}:{pid}:{_start_ticks(pid)}"


def _stat_fields(pid: int) -> list[str] | None:
    """The fields of /proc/PID/stat after the command name (field 3, the state, first), or None."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat.rpartition(")")[2].split()


def _start_ticks(pid: int) -> str:
    fields = _stat_fields(pid)
    return fields[19] if fields else "?"  # field 22, starttime


def worker_alive(tag: str) -> bool:
    """Whether the worker named by tag still runs (a worker of another host counts as alive: the
    journal file is for one machine).  A zombie is dead: it keeps its /proc entry until its parent
    reaps it, but it runs nothing."""
    host, _, rest = tag.partition(":")
    pid_text, _, start = rest.partition(":")
    if host != socket.gethostname():
        return True
    try:
        fields = _stat_fields(int(pid_text))
    except ValueError:
        return False
    return fields is not None and fields[19] == start and fields[0] not in ("Z", "X")


class FlockLock:
    """The lock of Optuna's journal writes as an flock on a file of its own: the kernel lets it go
    when its holder dies (Optuna's default lock, a symlink, outlives a worker killed while it
    writes, and stalls every other writer for its 30 s grace period)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fd: int | None = None

    def acquire(self) -> bool:
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
        fcntl.flock(fd, fcntl.LOCK_EX)
        self._fd = fd
        return True

    def release(self) -> None:
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)  # closing drops the flock


@contextlib.contextmanager
def _schema_lock(url: str) -> Iterator[None]:
    """Held while a process opens a database storage, in which Optuna makes the schema of a fresh
    database: a PostgreSQL advisory lock in a transaction of its own (two processes making it at
    once collide on its type names: UniqueViolation), a file lock beside a SQLite file."""
    if url.startswith("sqlite:///"):
        with open(url.removeprefix("sqlite:///") + ".lock", "a") as f:
            fcntl.flock(f, fcntl.LOCK_EX)  # closing the file lets it go
            yield
        return
    if not url.startswith("postgres"):
        yield
        return
    import sqlalchemy
    from sqlalchemy.pool import NullPool

    engine = sqlalchemy.create_engine(sqlalchemy_url(url), poolclass=NullPool)
    try:
        with engine.begin() as conn:  # the transaction's end, or its connection's, lets the lock go
            conn.execute(sqlalchemy.text("SELECT pg_advisory_xact_lock(:k)"), {"k": SCHEMA_LOCK_KEY})
            yield
    finally:
        engine.dispose()
