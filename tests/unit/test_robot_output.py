"""What a robot prints is marked with its car in the robot host (torcs/robot_output.py), and a
fault's line shows the faulted car's last five printed lines (torcs/diagnosis.py)."""

from __future__ import annotations

import io

import pytest

from boxbox.torcs import robot_output
from boxbox.torcs.diagnosis import Ending, diagnose
from boxbox.torcs.faults import Fault
from boxbox.torcs.robot_output import CALLER, MarkedOutput, host_message, last_prints
from boxbox.torcs.rundir import RunDir


@pytest.fixture
def caller():
    before = CALLER[0]
    yield CALLER
    CALLER[0] = before


def test_each_line_is_marked_with_the_calling_car(caller, monkeypatch):
    stream = io.StringIO()
    out = MarkedOutput(stream, ["mine 1", "other 1"])
    caller[0] = 0
    print("one", file=out)  # print writes "one", then "\n"
    out.write("two\nthree")
    out.write(" and the rest\n")
    caller[0] = 1
    out.write("a\n\nb\n")
    caller[0] = -1  # the host itself, or a robot's import: unmarked
    out.write("host\n")
    monkeypatch.setattr("sys.stderr", out)
    caller[0] = 0
    host_message("boxbox host: a line of its own")
    assert CALLER[0] == 0  # given back
    assert stream.getvalue() == ("[mine 1] one\n[mine 1] two\n[mine 1] three and the rest\n"
                                 "[other 1] a\n[other 1] \n[other 1] b\nhost\nboxbox host: a line of its own\n")
    assert out.getvalue() == stream.getvalue()  # the rest is the stream's own


def test_last_prints_are_the_cars_own_last_five_cut_to_a_line(caller):
    log = "".join(f"[mine 1] line {i}\n[other 1] not mine {i}\nunmarked {i}\n" for i in range(8))
    log += "[mine 1] " + "x" * 1000 + "\n"
    lines = last_prints(log, "mine 1")
    assert lines[:4] == [f"[mine 1] line {i}" for i in range(4, 8)]
    assert lines[4].startswith("[mine 1] xxx") and len(lines[4]) < robot_output.PRINT_LINE_CHARS + 10
    assert last_prints(log, "mine 2") == []


def test_a_fault_line_shows_the_last_five_lines_and_where_host_log_is(tmp_path):
    run_dir = RunDir(tmp_path)
    run_dir.host_log.write_text("".join(f"[r 1] step {i}\n[s 1] other car\n" for i in range(9)))
    fault = Fault(kind="exception", message="ValueError: boom (in drive, step 3)", where="drive", name="r 1",
                  traceback="Traceback ...\nValueError: boom\n")
    end = Ending(robots=["my_robot.py:R", "s.py:S"], names=["r 1", "s 1"], step_budget_ms=200.0,
                 setup_budget_ms=120000.0, wall_limit_s=100.0, fault=fault)
    lines = (diagnose(run_dir, end) or "").splitlines()
    assert lines[0] == (f"robot 'my_robot.py:R' (r 1) failed: ValueError: boom (in drive, step 3); "
                        f"its prints are in {run_dir.host_log}")
    assert lines[1:7] == ["the last 5 lines r 1 printed:", *[f"[r 1] step {i}" for i in range(4, 9)]]
    assert lines[7:] == ["Traceback ...", "ValueError: boom"]
