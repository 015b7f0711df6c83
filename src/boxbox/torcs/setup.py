"""Setting up TORCS for boxbox, idempotently: packages, headers, the bridge, the overlay.

Nothing under /usr or /etc is changed apart from installing Debian's packages: our robot lives in
an overlay (folders of symlinks to the system TORCS plus our own `drivers/boxbox/`), and the headers
come from Debian's source package fetched with an apt configuration of its own in a private
temporary folder.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import re
import shutil
import struct
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from boxbox.errors import SetupError
from boxbox.files import atomic_path, write_text_atomic
from boxbox.torcs import wire
from boxbox.torcs.paths import BRIDGE_SOURCE, HEADER_MEMBERS, ROBOT_MODULE, TorcsInstall, cache_dir, system_torcs

Report = Callable[[str], None]
PACKAGES = ["torcs", "libplib-dev"]


@dataclass(frozen=True)
class Overlay:
    """The directories a race runs TORCS with."""

    torcs: TorcsInstall
    lib_dir: Path
    data_dir: Path
    bridge: Path


def _quiet(msg: str) -> None:
    pass


def _run(cmd: list[str], log: Path, what: str, cwd: Path | None = None) -> None:
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "ab") as out:
        proc = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, cwd=cwd, stdin=subprocess.DEVNULL)
    if proc.returncode != 0:
        tail = log.read_text(errors="replace").strip().splitlines()[-1:] or [""]
        raise SetupError(f"{what} failed ({' '.join(cmd)}): {tail[0]}; full log: {log}")


def _privileged(cmd: list[str]) -> list[str]:
    if os.geteuid() == 0:
        return cmd
    if shutil.which("sudo"):
        return ["sudo", "-n", *cmd]
    raise SetupError(f"`{' '.join(cmd)}` needs root: run it as root or install sudo")


def packages_missing() -> list[str]:
    missing = []
    if not system_torcs().binary.exists():
        missing.append("torcs")
    if not Path("/usr/include/plib/sg.h").exists():
        missing.append("libplib-dev")
    return missing


def apt_install(packages: list[str], report: Report = _quiet, update: bool = True) -> Path:
    """Install Debian packages with apt-get (as root, or through sudo), logging to the cache's
    apt.log; `update`: refresh the package lists first.  Returns the log's path."""
    names = ", ".join(packages)
    if not shutil.which("apt-get"):
        raise SetupError(f"Debian packages {names} are missing and apt-get is not available: install them")
    log = cache_dir() / "logs" / "apt.log"
    report(f"installing Debian packages: {names} (log: {log})")
    env_cmd = ["env", "DEBIAN_FRONTEND=noninteractive"]
    if update:
        _run(_privileged([*env_cmd, "apt-get", "update"]), log, "apt-get update")
    _run(_privileged([*env_cmd, "apt-get", "install", "-y", "--no-install-recommends", *packages]), log,
         f"apt-get install {names}")
    return log


def install_packages(report: Report = _quiet) -> None:
    missing = packages_missing()
    if not missing:
        return
    log = apt_install(missing, report)
    still = packages_missing()
    if still:
        raise SetupError(f"apt-get did not install {', '.join(still)}; see {log}")


def _deb_src_entries() -> tuple[str, str]:
    """deb-src entries mirroring the machine's Debian deb entries (same URIs and suites): the
    deb822 stanzas (.sources) and the one-line entries (sources.list)."""
    stanzas = []
    for path in sorted(Path("/etc/apt/sources.list.d").glob("*.sources")):
        for block in path.read_text().split("\n\n"):
            fields = {}
            for line in block.splitlines():
                if ":" in line and not line.startswith("#"):
                    key, value = line.split(":", 1)
                    fields[key.strip()] = value.strip()
            if fields.get("Types", "").split() == ["deb"] and "debian" in fields.get("URIs", ""):
                lines = ["Types: deb-src"] + [f"{k}: {v}" for k, v in fields.items() if k != "Types"]
                stanzas.append("\n".join(lines))
    one_line = []
    sources_list = Path("/etc/apt/sources.list")
    if sources_list.exists():
        for line in sources_list.read_text().splitlines():
            if line.startswith("deb ") and "debian" in line:
                one_line.append(line.replace("deb ", "deb-src ", 1))
    return "\n\n".join(stanzas) + "\n", "\n".join(one_line) + "\n"


def headers_dir(report: Report = _quiet) -> Path:
    """TORCS headers: $TORCS_SRC (a source tree) or extracted once from Debian's source package."""
    if env := os.environ.get("TORCS_SRC"):
        src = Path(env)
        if not (src / "src" / "interfaces" / "robot.h").exists():
            raise SetupError(f"TORCS_SRC={src} has no src/interfaces/robot.h; point it at a TORCS source tree")
        return _include_tree(src, cache_dir() / "headers-from-TORCS_SRC")
    root = cache_dir() / "torcs-headers"
    include = root / "include"
    if (include / "robot.h").exists():
        return include
    log = cache_dir() / "logs" / "headers.log"
    with tempfile.TemporaryDirectory(prefix="boxbox-src-") as tmp:
        tarball = _download_source(Path(tmp), log, report)
        report("extracting the TORCS headers from the source package")
        src = Path(tmp) / "src-tree"
        _extract_headers(tarball, src)
        staging = root.with_name("torcs-headers.partial")
        shutil.rmtree(staging, ignore_errors=True)
        _include_tree(src, staging / "include")
        shutil.rmtree(root, ignore_errors=True)
        staging.rename(root)
    return include


def _download_source(tmp: Path, log: Path, report: Report) -> Path:
    """Debian's torcs orig tarball, fetched into `tmp` (made by mkdtemp: 0700, ours) with an apt
    configuration of its own in it: deb-src entries mirroring the machine's deb entries and their
    package lists, so nothing outside `tmp` changes and no root is needed. apt checks the lists'
    signatures and each file's checksum; the tarball used is the one apt named, checked again."""
    if not shutil.which("apt-get"):
        raise SetupError("the TORCS headers need apt-get (or set TORCS_SRC to a TORCS source tree)")
    report(f"downloading Debian's torcs source package for its headers (log: {log})")
    apt = ["apt-get", *_private_apt(tmp)]
    dl = tmp / "download"
    dl.mkdir(mode=0o700)
    _let_apt_sandbox_write(tmp, dl)
    _run([*apt, "update"], log, "apt-get update (deb-src lists, in a temporary folder)")
    files = source_files(_output([*apt, "source", "--print-uris", "torcs"], log, "apt-get source --print-uris"))
    _run([*apt, "source", "--download-only", "torcs"], log, "apt-get source", cwd=dl)
    return verified_orig_tarball(dl, files)


def _private_apt(tmp: Path) -> list[str]:
    """apt options that keep its sources, lists and caches in tmp/apt."""
    stanzas, one_line = _deb_src_entries()
    if not stanzas.strip() and not one_line.strip():
        raise SetupError("no Debian apt source found to derive a deb-src entry from; set TORCS_SRC")
    root = tmp / "apt"
    for sub in ("sources.list.d", "lists/partial", "cache/archives/partial"):
        (root / sub).mkdir(parents=True)
    (root / "sources.list.d" / "boxbox-deb-src.sources").write_text(stanzas)
    (root / "sources.list").write_text(one_line)
    settings = [f"Dir::Etc::SourceList={root / 'sources.list'}", f"Dir::Etc::SourceParts={root / 'sources.list.d'}",
                f"Dir::State::Lists={root / 'lists'}", f"Dir::Cache={root / 'cache'}",
                "Dir::Cache::pkgcache=", "Dir::Cache::srcpkgcache="]
    return [arg for setting in settings for arg in ("-o", setting)]


def _let_apt_sandbox_write(tmp: Path, dl: Path) -> None:
    """As root, apt downloads as its sandbox user (_apt): it may pass through tmp (0711: no listing,
    no writing) and write in dl, which it alone (and root) can; nobody else can plant a file there."""
    import pwd

    if os.geteuid() != 0:
        return  # apt downloads as us
    try:
        sandbox = pwd.getpwnam("_apt")
    except KeyError:
        return  # no sandbox user: apt downloads as root
    os.chmod(tmp, 0o711)
    os.chown(dl, sandbox.pw_uid, -1)


def _output(cmd: list[str], log: Path, what: str) -> str:
    """The command's standard output (its errors go to the log)."""
    with open(log, "ab") as errors:
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=errors, stdin=subprocess.DEVNULL, text=True)
    if proc.returncode != 0:
        tail = log.read_text(errors="replace").strip().splitlines()[-1:] or [""]
        raise SetupError(f"{what} failed ({' '.join(cmd)}): {tail[0]}; full log: {log}")
    return proc.stdout


def source_files(print_uris: str) -> dict[str, str]:
    """File name -> sha256 of each file of the source package, from `apt-get source --print-uris`
    (lines `'URI' NAME SIZE SHA256:HEX`, the checksums of the signed Sources index)."""
    files = {}
    for line in print_uris.splitlines():
        m = re.fullmatch(r"'[^']+' (\S+) \d+ SHA256:([0-9a-f]{64})", line.strip())
        if m and m.group(1) == Path(m.group(1)).name and not m.group(1).startswith("."):
            files[m.group(1)] = m.group(2)
    return files


def verified_orig_tarball(folder: Path, files: dict[str, str]) -> Path:
    """The orig tarball apt named in `files`, in `folder`, with the sha256 the index and the .dsc
    give it (the .dsc itself checked against the index). Nothing else in the folder is looked at."""
    dscs = [n for n in files if n.endswith(".dsc")]
    origs = [n for n in files if re.fullmatch(r"torcs_[^/]+\.orig\.tar\.\w+", n)]
    if len(dscs) != 1 or len(origs) != 1:
        raise SetupError(f"apt named no single torcs .dsc and orig tarball: {sorted(files)}")
    dsc, orig = folder / dscs[0], folder / origs[0]
    for path in (dsc, orig):
        if not path.is_file() or _sha256(path) != files[path.name]:
            raise SetupError(f"{path} is missing or not the file Debian's index names (sha256 differs)")
    listed = re.findall(r"^ ([0-9a-f]{64}) \d+ (\S+)$", dsc.read_text(errors="replace"), re.M)
    if (files[orig.name], orig.name) not in listed:
        raise SetupError(f"{orig.name}: its sha256 is not the one {dsc.name} lists")
    return orig


def _extract_headers(tarball: Path, dest: Path) -> None:
    import fnmatch

    dest.mkdir(parents=True)
    # Decompress with the xz tool when present (much faster than Python's lzma for 390 MB).
    cmd = ["tar", "-xf", str(tarball), "-C", str(dest), "--strip-components=1", "--wildcards",
           *[f"*/{m}" for m in HEADER_MEMBERS]]
    if shutil.which("tar") and subprocess.run(cmd, capture_output=True).returncode == 0:
        return
    with tarfile.open(tarball) as tar:
        for member in tar:
            rel = member.name.split("/", 1)[-1]
            if member.isfile() and any(fnmatch.fnmatch(rel, m) for m in HEADER_MEMBERS):
                member.name = rel
                tar.extract(member, dest, filter="data")


def _include_tree(src: Path, include: Path) -> Path:
    """Flatten the needed headers into one include dir (math headers as <tmath/...>)."""
    include.mkdir(parents=True, exist_ok=True)
    (include / "tmath").mkdir(exist_ok=True)
    for pattern in HEADER_MEMBERS:
        for header in src.glob(pattern):
            target = include / "tmath" if "/math/" in str(header) else include
            shutil.copy2(header, target / header.name)
    if not (include / "robot.h").exists():
        raise SetupError(f"no robot.h found under {src}")
    return include


def bridge_fingerprint() -> str:
    digest = hashlib.sha256(BRIDGE_SOURCE.read_bytes() + wire.c_header().encode()).hexdigest()
    return digest[:16]


def bridge_module() -> Path:
    """Where the bridge for this source and wire layout is built (and kept)."""
    return cache_dir() / "bridge" / bridge_fingerprint() / f"{ROBOT_MODULE}.so"


def build_bridge(include: Path, torcs: TorcsInstall, report: Report = _quiet) -> Path:
    """The bridge module, built when missing, and rebuilt (with a message) when the cached one is
    damaged: not the file that was built (its hash) or not an ELF shared object (`bridge_problem`)."""
    module = bridge_module()
    if module.exists() and not _hash_file(module).exists() and not elf_problem(module.read_bytes()) \
            and not load_problem(module, torcs):
        write_text_atomic(_hash_file(module), _sha256(module))  # built before hashes were kept: adopted
    if module.exists():
        problem = bridge_problem(module, torcs, load=False)
        if problem is None:
            return module
        report(f"the bridge module {module} {problem}: rebuilding it")
        module.unlink(missing_ok=True)
    if not shutil.which("g++"):
        raise SetupError("g++ is needed to build the bridge: apt-get install g++")
    report("compiling the bridge module")
    out_dir = module.parent
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "bb_wire.h").write_text(wire.c_header())
    with atomic_path(module) as tmp:
        cmd = ["g++", "-O2", "-shared", "-fPIC", "-Wall", "-o", str(tmp), str(BRIDGE_SOURCE),
               f"-I{out_dir}", f"-I{include}", f"-L{torcs.shared_lib_dir}", "-lrobottools", "-ltgf",
               f"-Wl,-rpath,{torcs.shared_lib_dir}"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            first = next((ln for ln in proc.stderr.splitlines() if "error" in ln), proc.stderr.strip()[:300])
            raise SetupError(f"compiling the bridge failed: {first}")
        if problem := load_problem(tmp, torcs):
            raise SetupError(f"the bridge module just built does not load: {problem}")
        write_text_atomic(_hash_file(module), _sha256(tmp))
    return module


def _hash_file(module: Path) -> Path:
    return module.with_name(module.name + ".sha256")


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def bridge_problem(module: Path, torcs: TorcsInstall, load: bool = True) -> str | None:
    """Why the built bridge cannot be raced with, as the end of a sentence, or None when it can:
    missing, no hash recorded at its build, its contents not those built (a truncated or
    overwritten file), not a 64-bit ELF shared object, and (load=True) dlopen refusing it."""
    try:
        data = module.read_bytes()
    except OSError as exc:
        return f"is missing ({exc.strerror or exc})"
    try:
        recorded = _hash_file(module).read_text().strip()
    except OSError:
        return "has no build record (its sha256 file)"
    if hashlib.sha256(data).hexdigest() != recorded:
        return f"is damaged: its contents ({len(data)} bytes) are not those it was built with"
    if problem := elf_problem(data):
        return f"is not a shared library: {problem}"
    if load and (problem := load_problem(module, torcs)):
        return f"does not load: {problem}"
    return None


def elf_problem(data: bytes) -> str | None:
    """What is wrong with an x86-64 ELF shared object's header, or None: magic, class, byte order,
    type, and whether the file holds all its program and section headers (a truncated file does not)."""
    if len(data) < 64 or data[:4] != b"\x7fELF":
        return "no ELF header"
    if data[4] != 2 or data[5] != 1:
        return "not a 64-bit little-endian ELF file"
    e_type, e_machine = struct.unpack_from("<HH", data, 16)
    e_phoff, e_shoff = struct.unpack_from("<QQ", data, 32)
    e_phentsize, e_phnum, e_shentsize, e_shnum = struct.unpack_from("<HHHH", data, 54)
    if e_type != 3:  # ET_DYN
        return f"ELF type {e_type}, not a shared object"
    if e_machine != 62:  # EM_X86_64, the only machine TORCS is packaged for here
        return f"ELF machine {e_machine}, not x86-64"
    if e_phoff + e_phnum * e_phentsize > len(data) or e_shoff + e_shnum * e_shentsize > len(data):
        return f"truncated ({len(data)} bytes, its headers reach beyond the end)"
    return None


def load_problem(module: Path, torcs: TorcsInstall) -> str | None:
    """dlopen the module in a child process, as TORCS would (its XML library loaded first: libtgf
    needs it); the module's entry point must be there. None when it loads."""
    check = ("import ctypes, os, sys; ctypes.CDLL(sys.argv[2], mode=os.RTLD_GLOBAL); "
             f"getattr(ctypes.CDLL(sys.argv[1]), {ROBOT_MODULE!r})")
    try:
        proc = subprocess.run([sys.executable, "-I", "-S", "-c", check, str(module),
                               str(torcs.shared_lib_dir / "libtxml.so")],
                              capture_output=True, text=True, timeout=30, stdin=subprocess.DEVNULL)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"the load check could not run: {exc}"
    if proc.returncode == 0:
        return None
    lines = proc.stderr.strip().splitlines()
    return lines[-1] if lines else f"the load check exited with status {proc.returncode}"


def _mirror(src: Path, dest: Path, real_subdir: str) -> None:
    """dest/* -> symlinks to src/*, except real_subdir, which is a real dir of symlinks."""
    dest.mkdir(parents=True, exist_ok=True)
    for entry in src.iterdir():
        link = dest / entry.name
        if entry.name == real_subdir:
            link.mkdir(exist_ok=True)
            for sub in entry.iterdir():
                if not (link / sub.name).exists():
                    (link / sub.name).symlink_to(sub)
        elif not link.exists():
            link.symlink_to(entry)


def overlay_intact(root: Path, bridge: Path, torcs: TorcsInstall) -> bool:
    """The overlay holds this bridge build and a link to each entry of this TORCS (and its drivers).
    A few dozen stats and one 200 kB compare: checked before every race, so a broken overlay mends."""
    import filecmp

    try:
        if not filecmp.cmp(root / "lib" / "drivers" / ROBOT_MODULE / f"{ROBOT_MODULE}.so", bridge, shallow=False):
            return False
        for src, dest in ((torcs.lib_dir, root / "lib"), (torcs.data_dir, root / "data")):
            for entry in src.iterdir():
                links = [(sub, dest / "drivers" / sub.name) for sub in entry.iterdir()] \
                    if entry.name == "drivers" else [(entry, dest / entry.name)]
                for target, link in links:
                    if not link.exists() or os.readlink(link) != str(target):
                        return False
    except OSError:
        return False
    return True


def build_overlay(bridge: Path, torcs: TorcsInstall) -> Overlay:
    root = cache_dir() / "overlay" / bridge.parent.name
    lib, data = root / "lib", root / "data"
    if not overlay_intact(root, bridge, torcs):  # missing, or broken: (re)built
        tmp = root.with_name(root.name + ".partial")
        shutil.rmtree(tmp, ignore_errors=True)
        _mirror(torcs.lib_dir, tmp / "lib", "drivers")
        _mirror(torcs.data_dir, tmp / "data", "drivers")
        mod_dir = tmp / "lib" / "drivers" / ROBOT_MODULE
        mod_dir.mkdir()
        shutil.copy2(bridge, mod_dir / f"{ROBOT_MODULE}.so")
        (tmp / "data" / "drivers" / ROBOT_MODULE).mkdir()
        shutil.rmtree(root, ignore_errors=True)
        tmp.rename(root)
    bridge_copy = lib / "drivers" / ROBOT_MODULE / f"{ROBOT_MODULE}.so"
    return Overlay(torcs=torcs, lib_dir=lib, data_dir=data, bridge=bridge_copy)


def ensure_ready(report: Report = _quiet) -> Overlay:
    """Do whatever setup is missing; fast when everything is in place.  Safe to call from several
    processes at once (a lock in the cache: the second waits, then finds everything built)."""
    torcs = system_torcs()
    if os.environ.get("BOXBOX_TORCS_LIB") and not torcs.binary.exists():  # Debian's package cannot help
        raise SetupError(f"TORCS binary not found at {torcs.binary} (from BOXBOX_TORCS_LIB)")
    with _setup_lock():
        install_packages(report)
        if not torcs.binary.exists():
            raise SetupError(f"TORCS binary not found at {torcs.binary}; install Debian's torcs package")
        include = headers_dir(report)
        bridge = build_bridge(include, torcs, report)
        return build_overlay(bridge, torcs)


@contextlib.contextmanager
def _setup_lock():
    root = cache_dir()
    root.mkdir(parents=True, exist_ok=True)
    with open(root / "setup.lock", "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def doctor() -> list[tuple[str, bool, str]]:
    """(component, present, detail) for `boxbox doctor`."""
    torcs = system_torcs()
    rows = [
        ("TORCS binary", torcs.binary.exists(), str(torcs.binary)),
        ("TORCS data", (torcs.data_dir / "tracks").exists(), str(torcs.data_dir)),
        ("plib headers (libplib-dev)", Path("/usr/include/plib/sg.h").exists(), "/usr/include/plib"),
        ("g++", shutil.which("g++") is not None, shutil.which("g++") or "apt-get install g++"),
    ]
    include = Path(os.environ["TORCS_SRC"]) if os.environ.get("TORCS_SRC") else \
        cache_dir() / "torcs-headers" / "include"
    rows.append(("TORCS headers", (include / "robot.h").exists() or (include / "src/interfaces/robot.h").exists(),
                 str(include)))
    module = bridge_module()
    problem = bridge_problem(module, torcs)
    rows.append(("bridge module", problem is None, str(module) + (f" {problem}" if problem else "")))
    overlay = cache_dir() / "overlay" / bridge_fingerprint()
    rows.append(("overlay", (overlay / "lib" / "drivers" / ROBOT_MODULE).exists(), str(overlay)))
    return rows


def ensure_chromium(report: Report = _quiet) -> Path:
    """Headless Chromium for the report test: Debian's `chromium` package, installed when missing.
    Only the tests call this (never a race); returns the browser's path."""
    def find() -> Path | None:
        for name in ("chromium", "chromium-browser"):
            if found := shutil.which(name):
                return Path(found)
        return Path("/usr/bin/chromium") if Path("/usr/bin/chromium").exists() else None

    browser = find()
    if browser is not None:
        return browser
    log = apt_install(["chromium"], report)
    browser = find()
    if browser is None:
        raise SetupError(f"apt-get did not install chromium; see {log}")
    return browser
