"""`boxbox dataset` on real TORCS: 200 steps of the shipped robot with action noise, written as a Minari
dataset that minari.load_dataset reads back in the env's own spaces, replaced only with --replace."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

from helpers import run_boxbox

pytestmark = pytest.mark.torcs
STEPS = 200


def test_the_robot_recorded_with_noise_loads_back_as_a_minari_dataset(tmp_path, monkeypatch):
    minari = pytest.importorskip("minari")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    args = ("dataset", "boxbox/test-v0", "--steps", str(STEPS), "--noise", "0.1", "--seed", "3")
    proc = run_boxbox(*args, env={"MINARI_DATASETS_PATH": str(tmp_path)})
    assert proc.returncode == 0, proc.stderr
    assert f"boxbox/test-v0: 1 episode(s), {STEPS} steps of boxbox" in proc.stdout
    data = minari.load_dataset("boxbox/test-v0")
    assert data.total_steps == STEPS and data.total_episodes == 1
    env = data.recover_environment()
    try:
        assert env.spec.kwargs["teacher"] == "boxbox" and env.spec.kwargs["action_repeat"] == 2
        episode = next(data.iterate_episodes())
        assert episode.actions.shape == (STEPS, 2) and episode.infos["teacher_action"].shape == (STEPS + 1, 2)
        first = {k: v[0] for k, v in episode.observations.items()}
        assert env.observation_space.contains(first)
        # the noise: the actions driven are not the robot's own, but near them
        driven, taught = episode.actions, episode.infos["teacher_action"][:-1]
        assert 0.02 < np.std(driven - taught) < 0.2
        assert sum(episode.infos["progress_m"]) > 100.0 and episode.truncations[-1] and not episode.terminations[-1]
        assert episode.id == 0 and gymnasium.spaces.Box(-1, 1, (2,)).contains(taught[0])
    finally:
        env.close()
    again = run_boxbox(*args, env={"MINARI_DATASETS_PATH": str(tmp_path)})
    assert again.returncode == 2 and "give --replace" in again.stderr
    assert run_boxbox(*args[:3], "10", "--replace", env={"MINARI_DATASETS_PATH": str(tmp_path)}).returncode == 0
    assert minari.load_dataset("boxbox/test-v0").total_steps == 10
    assert sorted(p.name for p in tmp_path.iterdir()) == ["boxbox"]  # no temporary folder left
