"""examples/train_cem.py learns: its short version beats a random policy by a clear margin."""

from __future__ import annotations

import json
import subprocess
import sys

from helpers import ROOT


def test_cem_quick_beats_a_random_policy(tmp_path, overlay):
    out = tmp_path / "cem.json"
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / "train_cem.py"), "--quick", "--json", str(out)],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(out.read_text())
    assert result["iterations"] == 3 and len(result["history"]) == 3
    # a policy that follows the track for 20 s against one that jitters on the grid
    assert result["best_progress_m"] > 200.0
    assert result["best_progress_m"] > 5 * max(result["random_progress_m"], 0.0) + 100.0
    assert result["history"][-1]["elite_mean_m"] > result["history"][0]["elite_mean_m"]  # it improves
    assert "lap completed: False after 3 iterations" in proc.stdout
