"""Socket folders go where a socket's path fits (107 bytes): TMPDIR, or /tmp when TMPDIR is long."""

from __future__ import annotations

import socket
import tempfile
from pathlib import Path

from boxbox.torcs.launch import SOCK_PREFIX, socket_root


def test_a_long_tmpdir_puts_the_sockets_in_tmp_and_a_short_one_keeps_them(tmp_path, monkeypatch):
    long_dir = tmp_path / ("x" * 60)
    long_dir.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(long_dir))
    assert socket_root() == "/tmp"
    folder = Path(tempfile.mkdtemp(prefix=f"{SOCK_PREFIX}1234567-", dir=socket_root()))
    try:  # the longest path boxbox makes there binds
        (folder / "r123").mkdir()
        with socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as s:
            s.bind(str(folder / "r123" / "bridge.sock"))
    finally:
        import shutil

        shutil.rmtree(folder)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    assert socket_root() == str(tmp_path) or len(str(tmp_path)) > 50
