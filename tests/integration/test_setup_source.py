"""Set-up finds Debian's torcs source package with an apt configuration of its own, in a private
temporary folder: nothing under /etc/apt or apt's own lists changes (the 390 MB download itself
is left to a fresh machine's first race)."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest

from boxbox.torcs import setup


def apt_state() -> tuple:
    sources = sorted((p.name, p.stat().st_mtime) for p in Path("/etc/apt/sources.list.d").iterdir())
    lists = sorted(p.name for p in Path("/var/lib/apt/lists").iterdir())
    return sources, lists


@pytest.mark.skipif(shutil.which("apt-get") is None, reason="Debian's apt is needed")
def test_the_source_package_is_found_without_touching_the_system_apt(tmp_path):
    before = apt_state()
    with tempfile.TemporaryDirectory(prefix="boxbox-src-") as tmp:
        assert os.stat(tmp).st_mode & 0o077 == 0  # made private
        apt = ["apt-get", *setup._private_apt(Path(tmp))]
        log = tmp_path / "apt.log"
        setup._run([*apt, "update"], log, "apt-get update")
        files = setup.source_files(setup._output([*apt, "source", "--print-uris", "torcs"], log, "print-uris"))
    assert any(n.startswith("torcs_") and ".orig.tar." in n for n in files), files
    assert any(n.endswith(".dsc") for n in files), files
    assert apt_state() == before, "set-up changed /etc/apt/sources.list.d or /var/lib/apt/lists"
