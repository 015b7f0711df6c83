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
    (["--run-dir", "/proc/boxbox-no-such/run"], "run dir /proc/boxbox-no-such/run cannot be made"),
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


def test_bad_input_starts_nothing(tmp_path):
    """The checks come before any race: no run folder is even made."""
    run_dir = tmp_path / "run"
    proc = run_boxbox("race", "--track", "g-trak-1", "--run-dir", str(run_dir), timeout=30)
    assert proc.returncode == 2 and not run_dir.exists()


def test_json_file_in_a_missing_folder(tmp_path):
    proc = run_boxbox("race", "--json", str(tmp_path / "no" / "such" / "r.json"), timeout=30)
    assert proc.returncode == 2
    [line] = proc.stderr.strip().splitlines()
    assert line.startswith("boxbox: error: --json") and "does not exist" in line


SETUP_CASES = [
    # (file under the setups folder, its text, the message)
    ("default.toml", "mu_scal = 0.7\n", "unknown parameter 'mu_scal' (did you mean mu_scale?)"),
    ("default.toml", 'mu_scale = "fast"\n', "mu_scale must be a float, got 'fast'"),
    ("default.toml", "mu_scale = \n", "not valid TOML"),
    ("car1-trb1/default.toml", "learning = 1\n", "learning must be a bool, got 1"),
    ("car1-trb1/g-track-1.toml", 'steering = "sideways"\n', "steering must be one of line, lookahead"),
]


@pytest.mark.parametrize("name,text,message", SETUP_CASES, ids=[f"{n}:{t.strip()}" for n, t, _ in SETUP_CASES])
def test_bad_setup_file_one_line_exit_2(name, text, message, tmp_path):
    """The boxbox robot's TOML setup files (BOXBOX_SETUPS points at a test folder) are checked
    before TORCS starts: one line naming the file, exit 2, no run folder made."""
    setups = tmp_path / "setups"
    (setups / name).parent.mkdir(parents=True)
    (setups / name).write_text(text)
    run_dir = tmp_path / "run"
    for command in (["race", "--track", "g-track-1", "--run-dir", str(run_dir)],
                    ["bench", "--tracks", "g-track-1", "--robots", "boxbox"]):
        proc = run_boxbox(*command, timeout=30, env={"BOXBOX_SETUPS": str(setups)})
        assert proc.returncode == 2, (command, proc.stderr)
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("boxbox: error: "), proc.stderr
        assert message in lines[0] and str(setups / name) in lines[0], lines[0]
    assert not run_dir.exists()
