"""Outputs never replace what they land on (files.atomic_path): a regular file is replaced
atomically, a symlink is followed to its target (the link kept), a character device or FIFO is
written into (still a device or FIFO after), a block device is refused in one line.  Every output
option of every command is checked with each kind of path, then written as boxbox writes it."""

from __future__ import annotations

import json
import os
import re
import stat
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import click
import pytest

from boxbox.cli import main_group
from boxbox.cli.types import OutputDir, OutputFile
from boxbox.errors import UsageError
from boxbox.files import atomic_path, write_json_atomic, write_text_atomic
from boxbox.validate import output_file
from helpers import kept_device

SRC = Path(__file__).resolve().parents[2] / "src" / "boxbox"
# the output options the command line has: the walk below must find at least these
KNOWN = {("race", "json_file"), ("race", "report_dir"), ("replay", "out_file"), ("report", "out_file"),
         ("contacts", "json_file"), ("bench", "json_file"), ("bench", "csv_file"), ("sweep", "markdown_file"),
         ("tune", "report_dir"), ("tune", "setup_out"), ("limit", "json_file"), ("bench-gym", "json_file")}


def output_options() -> list[tuple[str, click.Parameter]]:
    ctx = click.Context(main_group)
    out = []
    for name in main_group.list_commands(ctx):
        command = main_group.get_command(ctx, name)
        assert command is not None
        out += [(name, p) for p in command.params if isinstance(p.type, OutputFile | OutputDir)]
    return out


OPTIONS = output_options()


def test_the_walk_finds_every_output_option():
    assert KNOWN <= {(name, p.name) for name, p in OPTIONS}


class Fifo:
    """A FIFO with a reader thread: what is written to it is in `.read`."""

    def __init__(self, path: Path) -> None:
        self.path, self.read = path, b""
        os.mkfifo(path)
        self.thread = threading.Thread(target=self._drain, daemon=True)
        self.thread.start()

    def _drain(self) -> None:
        with open(self.path, "rb") as f:  # blocks until a writer opens it
            self.read = f.read()

    def done(self) -> bytes:
        self.thread.join(timeout=10)
        assert not self.thread.is_alive(), "the writer never closed the FIFO"
        return self.read


@pytest.fixture
def null_device() -> Iterator[str]:
    with kept_device("/dev/null") as path:
        yield path


Writer = Callable[[Path], None]
WRITERS: dict[str, Writer] = {
    "json": lambda p: write_json_atomic(p, {"a": 1}, indent=1),
    "text": lambda p: write_text_atomic(p, '{"a": 1}'),
}


def _write_via_option(param: click.Parameter, value: str, writer: Writer) -> None:
    """The option's check, then the write to what it returns (OutputDir: a file in the folder)."""
    path = Path(param.type.convert(value, param, None))
    if isinstance(param.type, OutputDir):
        path.mkdir(parents=True, exist_ok=True)  # as the commands make it
        path /= "report.html"
    writer(path)


@pytest.mark.parametrize("writer", WRITERS)
@pytest.mark.parametrize(("command", "param"), OPTIONS, ids=[f"{c}-{p.name}" for c, p in OPTIONS])
def test_every_output_option_keeps_symlinks_devices_and_fifos(tmp_path, null_device, command, param, writer):
    write = WRITERS[writer]
    is_dir = isinstance(param.type, OutputDir)
    # a regular file: replaced whole
    regular = tmp_path / "regular"
    _write_via_option(param, str(regular), write)
    assert json.loads(((regular / "report.html") if is_dir else regular).read_text()) == {"a": 1}
    # a symlink: its target written, the link kept
    target_dir = tmp_path / "elsewhere"
    target_dir.mkdir()
    link = tmp_path / "link"
    link.symlink_to(target_dir if is_dir else target_dir / "target.json")
    _write_via_option(param, str(link), write)
    assert link.is_symlink()
    assert json.loads((target_dir / ("report.html" if is_dir else "target.json")).read_text()) == {"a": 1}
    assert sorted(p.name for p in target_dir.iterdir()) == ["report.html" if is_dir else "target.json"]
    if is_dir:
        return  # a folder option's files are regular files in it, as above
    # /dev/null: written into, still the device
    _write_via_option(param, null_device, write)
    # a FIFO with a reader: written into, still a FIFO, no file left beside it
    fifo = Fifo(tmp_path / "pipe")
    _write_via_option(param, str(fifo.path), write)
    assert json.loads(fifo.done()) == {"a": 1}
    assert stat.S_ISFIFO(os.stat(fifo.path).st_mode)
    # a symlink to the device: the link and the device kept
    dev_link = tmp_path / "null-link"
    dev_link.symlink_to(null_device)
    _write_via_option(param, str(dev_link), write)
    assert dev_link.is_symlink() and os.readlink(dev_link) == null_device
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere", "link", "null-link", "pipe", "regular"]


def test_the_binary_writers_keep_devices(tmp_path, null_device):
    """Telemetry, the recording and the cached arrays write through atomic_path with a writer of
    their own (parquet, numpy): the same rules hold."""
    import numpy as np

    for path in (null_device, tmp_path / "link.npy"):
        if path != null_device:
            Path(path).symlink_to(tmp_path / "arrays.npy")
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.save(f, np.arange(3))
    assert np.load(tmp_path / "arrays.npy").tolist() == [0, 1, 2] and (tmp_path / "link.npy").is_symlink()


def test_a_device_that_fails_the_write_reports_it_and_stays(tmp_path):
    """/dev/full: the write fails with ENOSPC (the writer's caller reports it), /dev/full stays."""
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    with kept_device("/dev/full"), pytest.raises(OSError, match="No space left"):
        write_json_atomic("/dev/full", {"a": 1})


def test_a_block_device_or_a_socket_is_refused_in_one_line(tmp_path):
    import socket

    sock_path = tmp_path / "s"
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind(str(sock_path))
        with pytest.raises(UsageError, match=r"is a socket; give a file name\.$"):
            output_file(str(sock_path), name="json")
        with pytest.raises(UsageError, match="is a socket"):
            write_json_atomic(sock_path, {})
    blocks = [f"/dev/{n}" for n in sorted(os.listdir("/dev")) if stat.S_ISBLK(os.stat(f"/dev/{n}").st_mode)]
    if blocks:
        with pytest.raises(UsageError, match="is a block device"):
            output_file(blocks[0])


def test_only_files_py_renames_over_a_path():
    """Every output goes through files.atomic_path: no other module renames over a path (setup.py's
    renames of a fresh folder into place are not outputs)."""
    offenders = []
    for source in SRC.rglob("*.py"):
        if source.name != "files.py" and re.search(r"\bos\.replace\(", source.read_text()):
            offenders.append(source.relative_to(SRC))
    assert offenders == []


def test_a_file_where_the_folder_should_be_is_said(tmp_path):
    """--json FILE/x.json with FILE a file said the folder does not exist."""
    (tmp_path / "FILE").write_text("")
    for value in (tmp_path / "FILE" / "x.json", tmp_path / "FILE" / "sub" / "x.json"):
        with pytest.raises(UsageError, match=f"^Invalid value for 'json': {tmp_path / 'FILE'} is a file, not a "
                                             "folder; give a file in a folder.$"):
            output_file(str(value), name="json")
