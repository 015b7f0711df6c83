"""Bad input gets one clear line (with the nearest valid names) and exit 2, before TORCS starts."""

from __future__ import annotations

import os
import subprocess

import pytest

from helpers import BOXBOX, ROBOTS, kept_device, read_json, run_boxbox

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
    (["--laps", "0"], "Invalid value for '--laps': 0 is not in the range 1<=x<=10000"),
    (["--laps", "-3"], "Invalid value for '--laps': -3 is not in the range"),
    (["--laps", "three"], "Invalid value for '--laps': 'three' is not a valid integer"),
    (["--laps", "2147483647"], "Invalid value for '--laps': 2147483647 is not in the range 1<=x<=10000"),
    (["--fuel-laps", "nan"], "Invalid value for '--fuel-laps': nan is not a finite number"),
    (["--fuel-laps", "inf"], "Invalid value for '--fuel-laps': inf is not in the range"),
    (["--fuel-laps", "x"], "Invalid value for '--fuel-laps': 'x' is not a valid float"),
    (["--step-budget-ms", "0"], "Invalid value for '--step-budget-ms': 0.0 is not in the range 1<=x<=60000"),
    (["--step-budget-ms", "nan"], "Invalid value for '--step-budget-ms': nan is not a finite number"),
    (["--setup-budget-s", "1e12"], "Invalid value for '--setup-budget-s': 1000000000000.0 is not in the range"),
    (["--pit-laps", "2,x"], "Invalid value for '--pit-laps': 'x' is not a valid integer"),
    (["--pit-laps", "5", "--laps", "3"], "a stop must come before the last lap (3 laps)"),
    (["--pit-mode", "fast"], "Invalid value for '--pit-mode': 'fast' is not one of 'constant-decel', 'bang-bang'"),
    (["--opponents", "bt:1,bt:1"], "opponent bt:1 is given twice"),
    (["--opponents", ",".join(f"{m}:{i}" for m in ("bt", "damned") for i in range(10))
      + "," + ",".join(f"{m}:{i}" for m in ("berniw", "inferno") for i in range(1, 11))],
     "41 cars in one race: at most 40 race together; drop 1 opponent(s)"),
    (["--robot", "boxbox"] * 11, "11 Python cars: at most 10 race together"),
    (["--set", "mu_scale=nan"], "--set: mu_scale must be a finite number from 0.3 to 1.5, got nan"),
    (["--set", "mu_scale=-5"], "--set: mu_scale must be a finite number from 0.3 to 1.5, got -5"),
    (["--skill-level", "expert"], "'expert' is not one of 'rookie', 'amateur', 'semi-pro', 'pro'"),
    (["--opponents", "bt:2", "--grid-position", "3"], "grid position 3 is behind the field"),
    (["--json", "/proc/nope.json"], "Invalid value for '--json': cannot write in /proc"),
    (["--json", "/tmp"], "Invalid value for '--json': /tmp is a folder; give a file name"),
    (["--report", "/proc/boxbox-no-such"], "Invalid value for '--report': cannot write in /proc/boxbox-no-such"),
    (["--run-dir", "/proc/boxbox-no-such/run"], "'--run-dir': cannot write in /proc/boxbox-no-such/run"),
    (["--nonsense"], "No such option: --nonsense"),
    (["--track", "mixed-2", "--laps", "5", "--pit-laps", "2"], "track 'mixed-2' has no pit lane"),
    (["--set", "mu_scal=1"], "unknown parameter 'mu_scal' (did you mean mu_scale?)"),
    (["--set", "mu_scale=fast"], "mu_scale must be a number, got 'fast'; e.g. --set mu_scale=1"),
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
    assert line.startswith("boxbox: error: Invalid value for '--json'") and "does not exist" in line


@pytest.mark.parametrize("command", [["bench", "--tracks", "g-track-1", "--robots", "bt:2", "--json"],
                                     ["bench", "--tracks", "g-track-1", "--robots", "bt:2", "--csv"],
                                     ["bench-pits", "--tracks", "g-track-1", "--json"],
                                     ["sweep", "--tracks", "g-track-1", "--cars", "car1-trb1", "--markdown"],
                                     ["soak", "--races", "1", "--long-laps", "0", "--json"],
                                     ["drill", "stop", "--at", "100", "--json"],
                                     ["bench-telemetry", "--runs", "1", "--json"],
                                     ["report", ".", "--out"]])
def test_unwritable_outputs_fail_before_racing(command):
    """Every output file is checked while the command line is read: exit 2, one line, nothing raced."""
    proc = run_boxbox(*command, "/proc/boxbox-nope.json", timeout=30)
    assert proc.returncode == 2, proc.stderr
    [line] = proc.stderr.strip().splitlines()
    assert "cannot write in /proc" in line, line


SETUP_CASES = [
    # (file under the setups folder, its text, the message)
    ("default.toml", "mu_scal = 0.7\n", "unknown parameter 'mu_scal' (did you mean mu_scale?)"),
    ("default.toml", 'mu_scale = "fast"\n', "mu_scale must be a number, got 'fast'; e.g. mu_scale = 1"),
    ("default.toml", "mu_scale = \n", "not valid TOML"),
    ("car1-trb1/default.toml", "learning = 1\n", "learning must be true or false, got 1; e.g. learning = true"),
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


def test_relative_paths_work(tmp_path, overlay):
    """--run-dir and --json relative to the current folder (a relative run dir once broke TORCS's paths)."""
    env = dict(os.environ, COLUMNS="200")
    proc = subprocess.run([*BOXBOX, "race", "--track", "g-track-1", "--laps", "1", "--quiet", "--run-dir", "out/r1",
                           "--json", "r.json"], capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    result = read_json(tmp_path / "r.json")
    assert result["run_dir"] == str(tmp_path / "out" / "r1") and result["drivers"][0]["laps"] == 1
    assert (tmp_path / "out" / "r1" / "result.json").exists()


def test_outputs_keep_the_devices_and_links_they_land_on(tmp_path, overlay):
    """`race --json /dev/null` renamed a JSON file over /dev/null (as root): it is written into now,
    and /dev/null stays a character device; the race's report and replay pages go through a
    symlink to its target, the link kept (tests/unit/test_outputs.py walks every option)."""
    run_dir = tmp_path / "run"
    with kept_device("/dev/null"):
        proc = run_boxbox("race", "--track", "g-track-1", "--laps", "1", "--quiet", "--run-dir", str(run_dir),
                          "--json", "/dev/null")
        assert proc.returncode == 0, proc.stderr
    assert read_json(run_dir / "result.json")["drivers"][0]["laps"] == 1
    assert not (run_dir / "hang-traceback.txt").exists()  # no hang, so none kept
    (tmp_path / "pages").mkdir()
    for command in ("report", "replay"):
        link = tmp_path / f"{command}.html"
        link.symlink_to(tmp_path / "pages" / f"{command}.html")
        proc = run_boxbox(command, str(run_dir), "--out", str(link))
        assert proc.returncode == 0, proc.stderr
        assert link.is_symlink() and "<html" in (tmp_path / "pages" / f"{command}.html").read_text().lower()
