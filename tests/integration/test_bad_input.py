"""Bad input gets one clear line (with the nearest valid names) and exit 2, before TORCS starts."""

from __future__ import annotations

import pytest
from helpers import ROBOTS, run_boxbox

CASES = [
    (["--track", "g-trak-1"], "unknown track 'g-trak-1'; did you mean g-track-1"),
    (["--track", "nowhere"], "unknown track 'nowhere'"),
    (["--car", "car1-trb"], "unknown car 'car1-trb'; did you mean car1-trb"),
    (["--robot", "boxbx"], "unknown robot 'boxbx' (did you mean boxbox?)"),
    (["--robot", "no/such/file.py:Robot"], "robot file 'no/such/file.py' does not exist"),
    (["--robot", f"{ROBOTS / 'faulty.py'}:NoSuchClass"], "has no class 'NoSuchClass'"),
    (["--robot", f"{ROBOTS / 'faulty.py'}:NotARobot"], "is not a boxbox.Robot subclass"),
    (["--robot", "no_such_module:Robot"], "robot module 'no_such_module' failed to import"),
    (["--opponents", "btt:2"], "unknown TORCS robot 'btt'; did you mean bt"),
    (["--opponents", "bt:42"], "robot bt has no index 42"),
    (["--opponents", "bt"], "opponent 'bt' needs an index"),
    (["--opponents", "bt:x"], "index 'x' is not a number"),
    (["--laps", "0"], "--laps must be >= 1, got 0"),
    (["--laps", "-3"], "--laps must be >= 1, got -3"),
    (["--laps", "three"], "--laps must be a whole number of laps >= 1, got 'three'"),
    (["--fuel-laps", "nan"], "--fuel-laps must be a finite number"),
    (["--fuel-laps", "x"], "--fuel-laps must be a number, got 'x'"),
    (["--step-budget-ms", "0"], "--step-budget-ms must be a finite number >= 1"),
    (["--pit-laps", "2,x"], "--pit-laps takes lap numbers like 3,7"),
    (["--pit-laps", "5", "--laps", "3"], "a stop must be before the last lap"),
    (["--nonsense"], "No such option: --nonsense"),
    (["--track", "mixed-2", "--laps", "5", "--pit-laps", "2"], "track 'mixed-2' has no pit lane"),
    (["--set", "mu_scal=1"], "unknown parameter 'mu_scal' (did you mean mu_scale?)"),
    (["--set", "mu_scale=fast"], "mu_scale must be a float"),
]


@pytest.mark.parametrize("args,message", CASES, ids=[" ".join(a) for a, _ in CASES])
def test_bad_input_one_line_exit_2(args, message):
    proc = run_boxbox("race", *args, timeout=30)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("boxbox: error: ")
    assert message in lines[0], lines[0]
    assert proc.stdout == ""
