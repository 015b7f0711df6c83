"""The command line starts quickly: `import boxbox.cli`, `boxbox --help` and `boxbox tracks` load
none of the heavy libraries (numpy alone is about 0.3 s); a command loads its modules when run.
Measured by what a fresh interpreter has imported, not by a clock, so a loaded machine cannot
make it flaky."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("numpy", "scipy", "polars", "pyarrow", "gymnasium", "optuna", "sqlalchemy", "torch", "ray")

PROBE = """
import json, sys
from click.testing import CliRunner
import boxbox.cli
args = json.loads(sys.argv[1])
if args:
    result = CliRunner().invoke(boxbox.cli.main_group, args)
    assert result.exit_code == 0, result.output
loaded = sorted({m.split(".")[0] for m in sys.modules} & set(json.loads(sys.argv[2])))
print(json.dumps({"loaded": loaded, "cli": sorted(m for m in sys.modules if m.startswith("boxbox.cli."))}))
"""


def _loaded_by(args: list[str]) -> dict:
    done = subprocess.run([sys.executable, "-c", PROBE, json.dumps(args), json.dumps(HEAVY)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize("args", [[], ["--help"], ["tracks"], ["race", "--help"]], ids=" ".join)
def test_the_command_line_loads_no_heavy_library_before_a_command_runs(args):
    assert _loaded_by(args)["loaded"] == []


def test_the_help_loads_no_rich():
    """click prints the help; rich (a third of its time) loads with the first console output."""
    code = ("import sys; from click.testing import CliRunner; import boxbox.cli; "
            "CliRunner().invoke(boxbox.cli.main_group, ['--help']); print('rich' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout.split() == ["False"], done.stderr


def test_a_command_loads_only_its_own_module():
    assert _loaded_by(["tracks"])["cli"] == ["boxbox.cli.common", "boxbox.cli.info"]


def test_importing_boxbox_loads_the_robot_side_when_it_is_used():
    """`import boxbox` is light; `boxbox.Robot` is there all the same, and a type checker sees it."""
    code = ("import sys, boxbox; light = 'numpy' not in sys.modules; from boxbox import Robot, Controls, race; "
            "print(light, Robot.__module__, Controls.__module__, race.__module__, 'Robot' in dir(boxbox))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout.split() == ["True", "boxbox.robot.base", "boxbox.model.controls", "boxbox.api", "True"]
