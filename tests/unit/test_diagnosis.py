"""The one-line diagnosis of a robot that missed its step budget: stuck, or only late."""

from boxbox.torcs.diagnosis import Ending, diagnose
from boxbox.torcs.rundir import RunDir

FINISHING = '''Stack (most recent call first):
  File "/x/src/boxbox/torcs/telemetry.py", line 288 in write_telemetry
  File "/x/src/boxbox/torcs/host.py", line 484 in finish
  File "/x/src/boxbox/torcs/host.py", line 582 in main
'''
STUCK = '''Stack (most recent call first):
  File "/x/my_robot.py", line 12 in drive
  File "/x/src/boxbox/torcs/host.py", line 300 in serve
'''


def _diagnose(tmp_path, traceback: str) -> str:
    run_dir = RunDir(tmp_path)
    run_dir.torcs_err.write_text("BOXBOX-FAULT timeout robot=0 step=181 budget_ms=200 answer=10\n")
    run_dir.hang_traceback.write_text(traceback)
    line = diagnose(run_dir, Ending(robots=["my_robot.py:R"], names=["r 1"], step_budget_ms=200.0,
                                    setup_budget_ms=120000.0, wall_limit_s=100.0))
    assert line is not None
    return line


def test_a_host_found_finishing_answered_late_and_was_not_stuck(tmp_path):
    line = _diagnose(tmp_path, FINISHING)
    assert line.startswith("robot 'my_robot.py:R' (r 1) did not answer within its step budget of 200 ms (step 181)")
    assert "was not stuck" in line and "--step-budget-ms" in line
    assert "\n" not in line


def test_a_host_found_in_the_robot_shows_where_it_was_stuck(tmp_path):
    line = _diagnose(tmp_path, STUCK)
    assert "where the robot was stuck:" in line and "my_robot.py" in line


# --- where a stalled TORCS was (gdb's backtrace, torcs/launch.py _dump_torcs_stack) -------------

LOOPING_ROBOT = """\
[Thread debugging using libthread_db enabled]
#0  0x00007f5dc248bfb4 in spline(int, double, double const*, double const*) () from /c/lib//drivers/lliaw/lliaw.so
#1  0x00007f5dc248ffa0 in Pathfinder::correctPath(int, CarElt*, MyCar*) () from /c/lib//drivers/lliaw/lliaw.so
#2  0x00007f5dc3941319 in ?? () from /usr/lib/x86_64-linux-gnu/torcs/lib/libraceengine.so
"""
IN_A_LIBRARY = """\
#0  __math_invalidf (x=-nan(0x400000)) at ../sysdeps/ieee754/flt-32/math_errf.c:75
#1  0x00007f924b7832e6 in sgMakeCoordMat4(float (*) [4], float) () from /lib/x86_64-linux-gnu/libplibsg.so.1
#2  0x00007f924b2a381b in ?? () from /c/lib//modules/simu/simuv2.so
"""
IN_THE_BRIDGE = """\
#0  0x00007fc7b6a56929 in __libc_recv (fd=3, buf=0x7fc7b58f8a80 <g_in>, len=60064, flags=0) at recv.c:28
#1  0x00007fc7b58f29ed in bb_recv(int, int, int, int, int*) () from /c/lib//drivers/boxbox/boxbox.so
#2  0x00007fc7b58f332b in drive(int, CarElt*, Situation*) () from /c/lib//drivers/boxbox/boxbox.so
"""


def test_stack_top_names_the_torcs_robot_or_library_a_stalled_torcs_was_in():
    from boxbox.torcs.diagnosis import stack_top
    assert stack_top(LOOPING_ROBOT) == "the TORCS robot 'lliaw' (spline in lliaw.so)"
    assert stack_top(IN_A_LIBRARY) == "sgMakeCoordMat4 in libplibsg.so.1"  # the first frame with a library
    assert stack_top(IN_THE_BRIDGE) == "boxbox's bridge (bb_recv in boxbox.so)"
    assert stack_top("") is None
    assert stack_top("ptrace: Operation not permitted.\n") is None  # gdb could not attach


# --- a robot's fault: bounded, and pointing to the robot's prints ------------------------------------

def test_a_huge_exception_message_is_bounded_and_the_cut_said():
    from boxbox.torcs.faults import Fault

    huge = "x" * 20_000_000
    fault = Fault(kind="exception", message=f"ValueError: {huge} (in drive, step 3)", where="drive",
                  traceback=f"Traceback (most recent call last):\n  File 'r.py', line 1\nValueError: {huge}\n")
    assert len(fault.message) < 3000 and len(fault.traceback) < 15_000
    assert fault.message.startswith("ValueError: xxx") and fault.message.endswith("(in drive, step 3)")
    assert "characters of the message cut here" in fault.message and "\n" not in fault.message
    assert "characters of the traceback cut here" in fault.traceback
    assert Fault.from_json(fault.to_json()) == fault  # read back as written


def test_a_robots_fault_line_points_to_its_prints(tmp_path):
    from boxbox.torcs.faults import Fault

    run_dir = RunDir(tmp_path)
    end = Ending(robots=["my_robot.py:R"], names=["r 1"], step_budget_ms=200.0, setup_budget_ms=120000.0,
                 wall_limit_s=100.0, fault=Fault(kind="exception", message="ValueError: boom (in drive, step 3)",
                                                 where="drive", traceback="Traceback ...\nValueError: boom\n"))
    run_dir.host_log.write_text("the robot's last words\n")
    first, _, rest = (diagnose(run_dir, end) or "").partition("\n")
    assert first == (f"robot 'my_robot.py:R' failed: ValueError: boom (in drive, step 3); its prints are in "
                     f"{run_dir.host_log}")
    assert rest.startswith("Traceback")


def test_a_run_dir_keeps_hang_traceback_txt_only_when_a_hang_wrote_in_it(tmp_path):
    """The host opens it at its start (faulthandler writes there on a hang); a race without a hang
    left it empty in every run dir."""
    run_dir = RunDir(tmp_path)
    run_dir.hang_traceback.write_text("")
    run_dir.remove_temporaries()
    assert not run_dir.hang_traceback.exists()
    run_dir.hang_traceback.write_text(STUCK)
    run_dir.remove_temporaries()
    assert run_dir.hang_traceback.read_text() == STUCK


def test_a_host_that_dropped_the_bridge_while_running_is_not_said_killed(tmp_path):
    """A robot that closed the bridge's socket: the host ran on until the launcher killed it at
    the end, which read as "killed by SIGKILL"."""
    run_dir = RunDir(tmp_path)
    run_dir.torcs_err.write_text("BOXBOX-FAULT host-gone robot=0 step=99\n")
    end = Ending(robots=["my_robot.py:R"], names=["r 1"], step_budget_ms=200.0, setup_budget_ms=120000.0,
                 wall_limit_s=100.0, host_code=-9, host_stopped=True)
    line = diagnose(run_dir, end) or ""
    assert line.startswith("the robot process dropped its connection to TORCS during the race (step 99) while "
                           "driving robot 'my_robot.py:R' (r 1), though it still ran")
    end.host_stopped = False  # died of a SIGKILL from outside (the OOM killer's kind): said as such
    assert (diagnose(run_dir, end) or "").startswith("the robot process was killed by SIGKILL during the race")
