"""A throwaway PostgreSQL server (tests, `boxbox bench-tune`): Debian's `postgresql` package,
installed when missing, a cluster made by `initdb` in a temporary folder, listening only on a unix
socket in that folder, run by an unprivileged user (PostgreSQL refuses to run as root: as root,
the system user `boxbox-pg` is made and owns the folder), stopped and removed at the end.

    with TempServer() as server:
        boxbox tune --storage server.url ...
"""

from __future__ import annotations

import os
import pwd
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from pathlib import Path

from boxbox.errors import SetupError

PG_USER = "boxbox-pg"  # the system user that runs the server when boxbox runs as root
DB_USER = "boxbox"  # the database's superuser (trust authentication: the socket is in a private folder)
DB_NAME = "tune"


def bin_dir() -> Path | None:
    """The newest installed PostgreSQL's binaries (/usr/lib/postgresql/VERSION/bin), or None."""
    found = sorted(Path("/usr/lib/postgresql").glob("*/bin/initdb"), key=lambda p: int(p.parent.parent.name)
                   if p.parent.parent.name.isdigit() else 0)
    return found[-1].parent if found else None


def ensure_installed(report: Callable[[str], None] = lambda msg: None) -> Path:
    """PostgreSQL's binaries folder, installing Debian's `postgresql` with apt-get when missing."""
    found = bin_dir()
    if found is not None:
        return found
    from boxbox.torcs.setup import apt_install

    # a fresh machine's package lists (or a container's empty ones) may not know it yet
    known = shutil.which("apt-cache") is not None and \
        subprocess.run(["apt-cache", "show", "postgresql"], capture_output=True).returncode == 0
    log = apt_install(["postgresql"], report, update=not known)
    found = bin_dir()
    if found is None:
        raise SetupError(f"apt-get installed postgresql but no initdb is under /usr/lib/postgresql; see {log}")
    return found


def _server_user() -> pwd.struct_passwd | None:
    """The user to run the server as: None (this one) unless we are root."""
    if os.geteuid() != 0:
        return None
    try:
        return pwd.getpwnam(PG_USER)
    except KeyError:
        subprocess.run(["useradd", "--system", "--no-create-home", "--shell", "/usr/sbin/nologin", PG_USER],
                       check=True, capture_output=True)
        return pwd.getpwnam(PG_USER)


class TempServer:
    """A PostgreSQL server in a temporary folder for the life of the context; `url` reaches it."""

    def __init__(self, report: Callable[[str], None] = lambda msg: None) -> None:
        self.report = report
        self.folder: Path | None = None
        self.bin: Path | None = None
        self.user: pwd.struct_passwd | None = None
        self.started = False

    @property
    def url(self) -> str:
        return self.url_of(DB_NAME)

    def url_of(self, database: str) -> str:
        return f"postgresql://{DB_USER}@/{database}?host={self.folder}"

    def create_database(self, name: str) -> str:
        """A new, empty database on the server (no Optuna schema yet); its URL."""
        assert self.bin is not None, "the server is not started"
        self._check(self._as_server([str(self.bin / "createdb"), "-h", str(self.folder), "-U", DB_USER, name]),
                    f"createdb {name}")
        return self.url_of(name)

    def _as_server(self, args: list[str]) -> subprocess.CompletedProcess:
        user = self.user

        def drop() -> None:
            if user is not None:
                os.setgid(user.pw_gid)
                os.setgroups([])
                os.setuid(user.pw_uid)

        env = {"PATH": "/usr/bin:/bin", "LC_ALL": "C.UTF-8", "HOME": str(self.folder)}
        return subprocess.run(args, preexec_fn=drop, env=env, cwd=self.folder, capture_output=True, text=True,
                              stdin=subprocess.DEVNULL, timeout=120)

    def _check(self, proc: subprocess.CompletedProcess, what: str) -> None:
        if proc.returncode != 0:
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or [""]
            raise SetupError(f"PostgreSQL {what} failed: {tail[0]}")

    def __enter__(self) -> TempServer:
        self.bin = ensure_installed(self.report)
        self.user = _server_user()
        self.folder = Path(tempfile.mkdtemp(prefix="boxbox-pg-"))
        try:
            if self.user is not None:
                os.chown(self.folder, self.user.pw_uid, self.user.pw_gid)
            data = self.folder / "data"
            self._check(self._as_server([str(self.bin / "initdb"), "-D", str(data), "-U", DB_USER, "--auth=trust",
                                         "-E", "UTF8", "--no-sync"]), "initdb")
            # only the socket in our folder, no TCP; fsync off: a test server need not survive a crash
            opts = f"-k {self.folder} -c listen_addresses='' -c fsync=off"
            self._check(self._as_server([str(self.bin / "pg_ctl"), "-D", str(data), "-o", opts, "-l",
                                         str(self.folder / "server.log"), "-w", "-t", "60", "start"]), "start")
            self.started = True
            self._check(self._as_server([str(self.bin / "createdb"), "-h", str(self.folder), "-U", DB_USER,
                                         DB_NAME]), "createdb")
        except BaseException:
            self.__exit__()
            raise
        return self

    def __exit__(self, *exc) -> None:
        if self.folder is None:
            return
        if self.started and self.bin is not None:
            self._as_server([str(self.bin / "pg_ctl"), "-D", str(self.folder / "data"), "-m", "immediate", "-w",
                             "stop"])
            self.started = False
        shutil.rmtree(self.folder, ignore_errors=True)
        self.folder = None
