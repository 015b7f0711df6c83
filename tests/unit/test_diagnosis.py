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
