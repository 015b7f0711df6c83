"""The TORCS source package set-up fetches: the tarball compiled into the bridge (which TORCS loads,
as root on many machines) is exactly the file Debian's signed index names, never a file that
happens to lie in the download folder."""

from __future__ import annotations

import hashlib
import os
import pwd
import stat

import pytest

from boxbox.errors import SetupError
from boxbox.torcs import setup

ORIG = "torcs_1.3.7+dfsg.orig.tar.xz"
DSC = "torcs_1.3.7+dfsg-5.dsc"


def sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def source_package(folder, tarball: bytes = b"the real tarball", listed: bytes | None = None) -> dict[str, str]:
    """A .dsc and an orig tarball in folder, as apt leaves them; returns the index's checksums."""
    listed_sum = sha(tarball if listed is None else listed)
    dsc = (f"Format: 3.0 (quilt)\nSource: torcs\nChecksums-Sha256:\n {listed_sum} {len(tarball)} {ORIG}\n"
           f" {sha(b'debian')} 6 torcs_1.3.7+dfsg-5.debian.tar.xz\n").encode()
    (folder / DSC).write_bytes(dsc)
    (folder / ORIG).write_bytes(tarball)
    uris = (f"'http://deb.debian.org/debian/pool/main/t/torcs/{DSC}' {DSC} {len(dsc)} SHA256:{sha(dsc)}\n"
            f"'http://deb.debian.org/debian/pool/main/t/torcs/{ORIG}' {ORIG} {len(tarball)} SHA256:{sha(tarball)}\n"
            f"'http://x/torcs_1.3.7+dfsg-5.debian.tar.xz' torcs_1.3.7+dfsg-5.debian.tar.xz 6 SHA256:{sha(b'debian')}\n")
    return setup.source_files("Need to get 394 MB of source archives.\n" + uris)


def test_the_named_tarball_is_taken_and_a_planted_one_is_not(tmp_path):
    files = source_package(tmp_path)
    (tmp_path / "torcs_0.0.orig.tar.gz").write_bytes(b"planted: sorts first")
    assert setup.verified_orig_tarball(tmp_path, files) == tmp_path / ORIG


def test_a_replaced_tarball_or_dsc_is_refused(tmp_path):
    files = source_package(tmp_path)
    (tmp_path / ORIG).write_bytes(b"planted over the real one")
    with pytest.raises(SetupError, match="sha256 differs"):
        setup.verified_orig_tarball(tmp_path, files)
    files = source_package(tmp_path)
    (tmp_path / DSC).write_text("Checksums-Sha256:\n")
    with pytest.raises(SetupError, match="sha256 differs"):
        setup.verified_orig_tarball(tmp_path, files)


def test_the_tarball_must_be_the_one_the_dsc_lists(tmp_path):
    files = source_package(tmp_path, listed=b"another tarball")
    with pytest.raises(SetupError, match="not the one"):
        setup.verified_orig_tarball(tmp_path, files)


def test_odd_names_from_apt_are_not_used(tmp_path):
    odd = f"'http://x/a' ../{ORIG} 3 SHA256:{sha(b'abc')}\n'http://x/b' .{ORIG} 3 SHA256:{sha(b'abc')}\n"
    assert setup.source_files(odd) == {}
    with pytest.raises(SetupError, match="no single"):
        setup.verified_orig_tarball(tmp_path, {})


def test_the_download_folder_is_private(tmp_path, monkeypatch):
    """mkdtemp's folder (0700) stays private; as root only apt's sandbox user may also write in the
    download folder, and the temporary folder above it may be passed through, not listed or written."""
    dl = tmp_path / "download"
    dl.mkdir(mode=0o700)
    tmp_path.chmod(0o700)
    setup._let_apt_sandbox_write(tmp_path, dl)
    for folder in (tmp_path, dl):
        mode = stat.S_IMODE(os.stat(folder).st_mode)
        assert mode & 0o022 == 0, f"{folder} is writable by others: {oct(mode)}"
    assert stat.S_IMODE(os.stat(dl).st_mode) == 0o700
    if os.geteuid() == 0:
        assert os.stat(dl).st_uid == pwd.getpwnam("_apt").pw_uid
