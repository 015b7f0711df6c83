"""The bounded logs (torcs/logcap.py): the start and the end kept, the cut said."""

from __future__ import annotations

import os

from boxbox.torcs.logcap import CappedLog, LogPump


def test_a_short_log_is_kept_whole(tmp_path):
    with CappedLog(tmp_path / "a.log", head_bytes=10, tail_bytes=10) as log:
        log.write(b"0123456789")
        log.write(b"abc")
    assert (tmp_path / "a.log").read_bytes() == b"0123456789abc"


def test_a_long_log_keeps_its_start_and_end_and_says_what_was_cut(tmp_path):
    with CappedLog(tmp_path / "a.log", head_bytes=10, tail_bytes=5) as log:
        for i in range(1000):
            log.write(f"{i:04d}".encode())
    text = (tmp_path / "a.log").read_bytes()
    assert text.startswith(b"0000000100") and text.endswith(b"80999")
    assert b"[boxbox: 3985 bytes of the log cut here; it keeps its first 10 and its last 5 bytes]" in text


def test_the_pump_reads_until_the_last_writer_closes(tmp_path):
    pump = LogPump(tmp_path / "p.log")
    fd = os.dup(pump.write_fd)  # a child's copy
    pump.child_started()
    os.write(fd, b"hello\n")
    os.close(fd)
    pump.finish(5.0)
    pump.finish()  # once only
    assert (tmp_path / "p.log").read_bytes() == b"hello\n"
