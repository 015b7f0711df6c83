"""Races started by processes that know nothing of each other (a Ray node's workers) take cores of
their own: `claimed_core` (torcs/processes.py), one lock file per core."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys

from boxbox.torcs.processes import claimed_core


def test_each_claim_takes_a_core_no_other_holds_and_then_none_is_left(tmp_path):
    cores = os.sched_getaffinity(0)
    with contextlib.ExitStack() as held:
        claimed = [held.enter_context(claimed_core(tmp_path)) for _ in cores]
        assert sorted(claimed) == sorted(cores)  # every core once, none twice
        with claimed_core(tmp_path) as extra:
            assert extra is None  # every core held: the race takes pick_cpu's
    with claimed_core(tmp_path) as again:
        assert again in cores  # released with the block


def test_a_core_held_by_another_process_is_not_claimed_again(tmp_path):
    cores = sorted(os.sched_getaffinity(0))
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, pathlib\nfrom boxbox.torcs.processes import claimed_core\n"
         "with claimed_core(pathlib.Path(sys.argv[1])) as core:\n    print(core, flush=True)\n    sys.stdin.read()",
         str(tmp_path)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        theirs = int(holder.stdout.readline())
        with claimed_core(tmp_path) as ours:
            assert ours != theirs
            assert ours in cores or (ours is None and len(cores) == 1)
    finally:
        holder.communicate("")
