"""Robot loading and TORCS name checks (no race needed)."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from boxbox.errors import UsageError
from boxbox.robot.base import RaceOptions, Robot
from boxbox.robot.loader import BUILTIN, load_robot_class
from boxbox.torcs import checks, racefile
from helpers import BOXBOX, ROBOTS


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_builtin_robots_load(name):
    assert issubclass(load_robot_class(name), Robot)


def test_file_and_module_specs():
    assert load_robot_class(f"{ROBOTS / 'faulty.py'}:Plain").__name__ == "Plain"
    assert load_robot_class("boxbox.robot.simple:MiddleRobot").__name__ == "MiddleRobot"


@pytest.mark.parametrize("spec,message", [
    ("boxbo", "did you mean boxbox"),
    (f"{ROBOTS / 'faulty.py'}:Plian", "robots there: Plain"),
    ("boxbox.robot.simple:Nope", "has no class 'Nope'"),
])
def test_bad_specs_name_the_nearest(spec, message):
    with pytest.raises(UsageError, match=message):
        load_robot_class(spec)


def test_race_file_lists_drivers_in_order():
    xml = racefile.race_xml("g-track-1", "road", 5, [racefile.Entry("boxbox", 0), racefile.Entry("bt", 2)])
    assert xml.index('val="boxbox"') < xml.index('val="bt"')
    assert '<attnum name="laps" val="5"/>' in xml
    assert '<attstr name="display mode" val="results only"/>' in xml


def test_an_unknown_track_or_car_in_capitals_gets_the_nearest_names(monkeypatch):
    """E-TRACK-2 got no suggestion: the nearest names are found case aside."""
    import pytest

    from boxbox.errors import UsageError
    from boxbox.torcs import catalog

    monkeypatch.setattr(catalog, "tracks", lambda: {"e-track-2": "road", "g-track-1": "road"})
    monkeypatch.setattr(catalog, "cars", lambda: ["car1-trb1", "155-DTM"])
    with pytest.raises(UsageError, match=r"unknown track 'E-TRACK-2'; did you mean e-track-2[,?]"):
        catalog.check_track("E-TRACK-2")
    with pytest.raises(UsageError, match=r"unknown car '155-dtm'; did you mean 155-DTM\?"):
        catalog.check_car("155-dtm")


@pytest.mark.parametrize("fault,message", [
    ("exit0", "ended its process (exit status 0: os._exit() or a crash) while being loaded"),
    ("kill", "was killed by SIGKILL while being loaded"),
    ("hang", "did not finish loading within the set-up budget of 2 s"),
])
def test_a_robot_import_that_exits_is_killed_or_hangs_is_one_line_and_exit_2(fault, message):
    """The import runs in a child under the set-up budget: os._exit(0) there gave exit 0 and no
    output, SIGKILL 137 and no message, a hang no time limit; each is one line naming the file,
    exit 2, before TORCS starts."""
    spec = f"{ROBOTS / 'import_faults.py'}:Mine"
    started = time.monotonic()
    proc = subprocess.run([*BOXBOX, "race", "--robot", spec, "--setup-budget-s", "2", "--laps", "1", "--quiet"],
                          capture_output=True, text=True, timeout=60, env=dict(os.environ, IMPORT_FAULT=fault))
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"boxbox: error: robot file '{ROBOTS / 'import_faults.py'}' "), \
        proc.stderr
    assert message in lines[0]
    assert time.monotonic() - started < 30


def test_a_robot_file_without_its_class_lists_the_files_robots():
    with pytest.raises(UsageError, match=r"say which class races, as .*import_faults.py:CLASS "
                                         r"\(robots there: Mine, Other\)"):
        load_robot_class(str(ROBOTS / "import_faults.py"))


def test_a_robot_file_is_checked_in_a_child_and_named(monkeypatch):
    """The loader's checks are kept (the class found, its settings), and a clean import gives the
    cars' names, without importing the file here."""
    spec = f"{ROBOTS / 'import_faults.py'}:Mine"
    assert checks.check_robots([spec, "middle"], RaceOptions(), "g-track-1", "car1-trb1") == ["middle 1", "middle 2"]
    assert not any(getattr(m, "__file__", None) == str(ROBOTS / "import_faults.py") for m in list(sys.modules.values()))
    with pytest.raises(UsageError, match="has no class 'Mien' \\(robots there: Mine"):
        checks.check_robots([f"{ROBOTS / 'import_faults.py'}:Mien"], RaceOptions(), "g-track-1", "car1-trb1")


def test_a_robot_import_that_leaves_a_child_behind_is_checked_at_once(monkeypatch):
    """The child's answer is a line: a process the import forked, holding the answer's pipe open
    for 20 s, does not hold the check (it waited for the pipe to close: the whole set-up budget)."""
    monkeypatch.setenv("IMPORT_FAULT", "daemon")
    started = time.monotonic()
    assert checks.check_robots([f"{ROBOTS / 'import_faults.py'}:Mine"], RaceOptions(), "g-track-1", "car1-trb1",
                               setup_budget_s=15) == ["middle 1"]
    assert time.monotonic() - started < 10
