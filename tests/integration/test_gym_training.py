"""examples/train_sac.py and train_ppo.py (Stable-Baselines3, the rl extra) and train_bc.py
(PyTorch) at a tiny scale: `./boxbox install-rl` installs the extra when .venv lacks it, each
example trains for a few hundred steps, and what it saves is whole: the learning curve has a row
per episode, the plot is a PNG, and the saved model, loaded again (examples/evaluate.py for PPO's),
drives the env exactly as the policy did at the end of training (the summary's rollout)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from helpers import ROOT, run_boxbox

STEPS = 300
# the deterministic rollout of the saved model, in a fresh interpreter: the example's own rollout()
CHECK = """
import importlib.util, json, sys
spec = importlib.util.spec_from_file_location("train_sac", sys.argv[1])
example = importlib.util.module_from_spec(spec)
spec.loader.exec_module(example)
model = example.SAC.load(sys.argv[2])
env = example.make_env()
print(json.dumps(example.rollout(model, env)))
env.close()
"""


def torch_wheel() -> Path:
    """The PyTorch CPU wheel pyproject.toml's rl extra installs from."""
    sources = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["uv"]["sources"]
    return Path(sources["torch"]["path"])


@pytest.fixture(scope="module")
def rl_python() -> str:
    """This interpreter, with the rl extra: found, or installed by `./boxbox install-rl` into .venv."""
    has_extra = [sys.executable, "-c", "import stable_baselines3, torch"]
    if subprocess.run(has_extra, capture_output=True).returncode == 0:
        return sys.executable
    if Path(sys.prefix).resolve() != (ROOT / ".venv").resolve():
        pytest.skip(f"the rl extra is not installed in {sys.prefix}, and ./boxbox install-rl installs into .venv")
    if not torch_wheel().is_file():
        pytest.skip(f"{torch_wheel()} (PyTorch's CPU build, which the rl extra installs) is not on this machine")
    proc = subprocess.run([str(ROOT / "boxbox"), "install-rl"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "stable-baselines3 2.9.2, torch 2.13.0+cpu" in proc.stderr
    assert subprocess.run(has_extra, capture_output=True).returncode == 0
    return sys.executable


def test_sac_example_trains_saves_and_reloads(tmp_path, overlay, rl_python):
    example = ROOT / "examples" / "train_sac.py"
    # seed 1: after 300 steps its policy drives from the grid (seed 0's stands: nothing to compare)
    proc = subprocess.run([rl_python, str(example), "--out", str(tmp_path), "--steps", str(STEPS),
                           "--eval-every", "200", "--seed", "1"], capture_output=True, text=True, timeout=300,
                          cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    # SAC trains on whole episodes here (gSDE's noise drawn once an episode): the last one may run past STEPS
    assert STEPS <= summary["steps"] < STEPS + 1200 and summary["wall_s"] > 0
    assert "deterministic rollout" in proc.stdout and "lap completed:" in proc.stdout

    with (tmp_path / "curve.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert {r["kind"] for r in rows} == {"train", "eval"}, rows  # episodes ended, and a rollout at step 200
    steps, wall_s = [int(r["steps"]) for r in rows], [float(r["wall_s"]) for r in rows]
    assert steps == sorted(steps) and wall_s == sorted(wall_s) and 0 < steps[-1] <= summary["steps"]
    assert all(r["lap_completed"] in ("0", "1") and r["termination"] for r in rows)
    assert (tmp_path / "curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    check = subprocess.run([rl_python, "-c", CHECK, str(example), str(tmp_path / "model.zip")],
                           capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert check.returncode == 0, check.stderr
    reloaded = json.loads(check.stdout.strip().splitlines()[-1])
    # TORCS is deterministic: the reloaded policy drives the same metres, to the same end
    assert reloaded == {k: summary[k] for k in reloaded}, (reloaded, summary)
    assert reloaded["progress_m"] != 0.0  # it drove (a policy that never moves would be stuck at 0 m)


def test_ppo_example_trains_and_evaluate_drives_its_model_the_same(tmp_path, overlay, rl_python):
    temp = tmp_path / "temp"  # the run's TMPDIR: SB3's logger left an empty SB3-date folder there each run
    temp.mkdir()
    proc = subprocess.run([rl_python, str(ROOT / "examples" / "train_ppo.py"), "--out", str(tmp_path), "--steps", "256",
                           "--n-steps", "32", "--eval-every", "128"], capture_output=True, text=True, timeout=300,
                          cwd=tmp_path, env=dict(os.environ, TMPDIR=str(temp)))
    assert proc.returncode == 0, proc.stderr
    assert not list(temp.glob("SB3-*"))
    summary = json.loads((tmp_path / "summary.json").read_text())
    # 4 envs x 32 steps a rollout: learning stops at the first whole rollout past 256 steps
    assert summary["algorithm"] == "PPO" and summary["envs"] == 4 and summary["steps"] == 256, summary
    with (tmp_path / "curve.csv").open() as f:
        assert "eval" in {r["kind"] for r in csv.DictReader(f)}  # rollouts at 128 and 256 steps
    assert (tmp_path / "curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    check = subprocess.run([rl_python, str(ROOT / "examples" / "evaluate.py"), str(tmp_path / "model.zip"),
                            "--tracks", "g-track-1"], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert check.returncode == 0, check.stderr
    reloaded = json.loads(check.stdout.strip().splitlines()[-1])
    assert reloaded["track"] == "g-track-1" and reloaded["algorithm"] == "PPO"
    # TORCS is deterministic: the reloaded policy drives the same metres, to the same end, as the last rollout
    assert {k: reloaded[k] for k in ("progress_m", "termination", "lap_completed")} == \
        {k: summary[k] for k in ("progress_m", "termination", "lap_completed")}, (reloaded, summary)


def test_bc_example_trains_from_a_recorded_dataset_then_dagger_labels_its_own_states(tmp_path, overlay, rl_python):
    """examples/train_bc.py on 200 steps `boxbox dataset` recorded, then a DAgger round: the round's
    pairs stop at the budget of labelled steps, a round selected, the policy saved (--drive drives it
    again as it drove), a rollout row per track reported; a dataset larger than the budget is refused
    with one line; --look-ahead adds the track's curvature ahead to the observation, and drives again as
    it drove."""
    env = {"MINARI_DATASETS_PATH": str(tmp_path / "minari")}
    recorded = run_boxbox("dataset", "boxbox/tiny-v0", "--steps", "200", "--noise", "0.1", env=env)
    assert recorded.returncode == 0, recorded.stderr
    command = [rl_python, str(ROOT / "examples" / "train_bc.py"), "--dataset", "boxbox/tiny-v0",
               "--out", str(tmp_path / "bc"), "--epochs", "2"]
    proc = subprocess.run([*command, "--dagger", "1", "--round-epochs", "1", "--budget", "400", "--select",
                           "--eval-tracks", "g-track-1,e-track-4"], capture_output=True, text=True,
                          timeout=300, cwd=tmp_path, env={**os.environ, **env})
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "bc" / "summary.json").read_text())
    assert summary["dataset_pairs"] == 201 and summary["dagger_pairs"] == 199, summary  # 400 labelled in all
    assert summary["labelled_steps"] == 400 and summary["rounds"][0]["total_pairs"] == 400
    assert sum(e["steps"] for e in summary["rounds"][0]["episodes"]) == 199 and summary["loss"] > 0
    laps, metres = summary["rounds"][0]["selection_score"]  # the round's rollout from g-track-1's grid
    assert summary["selected_round"] in (0, 1) and laps in (0, 1) and metres >= 0
    assert [(r["track"], r["trained_on"]) for r in summary["rollouts"]] == [("g-track-1", True), ("e-track-4", False)]
    assert all(r["episode_steps"] > 0 and {"progress_m", "lap_completed", "lap_time_s", "termination"} <= set(r)
               for r in summary["rollouts"])
    import torch

    saved = torch.load(tmp_path / "bc" / "policy.pt")
    assert saved["act_size"] == 2 and saved["env"]["action_repeat"] == 2 and saved["env"]["teacher"] == "boxbox"
    drive = subprocess.run([*command[:2], "--drive", str(tmp_path / "bc" / "policy.pt"), "--eval-tracks", "g-track-1"],
                           capture_output=True, text=True, timeout=120, cwd=tmp_path, env={**os.environ, **env})
    assert drive.returncode == 0, drive.stderr
    assert json.loads(drive.stdout.splitlines()[-1]) == summary["rollouts"][0]  # the saved policy drives as it did
    over = subprocess.run([*command, "--budget", "100"], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          env={**os.environ, **env})
    assert over.returncode == 2 and "201 labelled steps, more than --budget 100" in over.stderr, over.stderr
    # --look-ahead: the track's curvature in 10 windows up to 400 m ahead joins the observation, the data's
    # from each step's distance along the lap, the rollout's and --drive's from the env's LookAhead wrapper
    ahead = subprocess.run([*command, "--look-ahead", "--out", str(tmp_path / "ahead"), "--eval-tracks", "g-track-1"],
                           capture_output=True, text=True, timeout=300, cwd=tmp_path, env={**os.environ, **env})
    assert ahead.returncode == 0, ahead.stderr
    looked = torch.load(tmp_path / "ahead" / "policy.pt")
    assert looked["look_ahead"] and looked["obs_size"] == saved["obs_size"] + 10, looked["obs_size"]
    row = json.loads((tmp_path / "ahead" / "summary.json").read_text())["rollouts"][0]
    drive = subprocess.run([*command[:2], "--drive", str(tmp_path / "ahead" / "policy.pt"), "--eval-tracks",
                            "g-track-1"], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                           env={**os.environ, **env})
    assert drive.returncode == 0 and json.loads(drive.stdout.splitlines()[-1]) == row, drive.stderr
