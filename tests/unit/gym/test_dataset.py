"""`boxbox dataset`'s pieces without TORCS: the action noise, the episodes' turns, and where a dataset
may go (a Minari id; never over a link, a file, another folder, or a dataset without --replace)."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

from boxbox.errors import UsageError
from boxbox.gym.dataset import Recording, action_noise, dataset_place, datasets_root


def test_the_noise_is_in_each_columns_half_range_and_stays_in_the_space():
    space = gymnasium.spaces.Box(np.float32([-1, 0, -1]), np.float32([1, 1, 6]))
    teacher = np.float32([0.9, 0.5, 3.0])
    assert action_noise(np.random.default_rng(0), space, 0.0)(teacher) is teacher
    noisy = action_noise(np.random.default_rng(0), space, 0.1)
    actions = np.stack([noisy(teacher) for _ in range(4000)])
    assert actions.dtype == np.float32 and space.contains(actions[0])
    assert np.all(actions >= space.low) and np.all(actions <= space.high)
    # the half ranges: 1, 0.5 and 3.5, times 0.1 (the steer's clipped at 1, 0.1 above the teacher's)
    assert np.std(actions[:, 1]) == pytest.approx(0.05, rel=0.1)
    assert np.std(actions[:, 2]) == pytest.approx(0.35, rel=0.1)
    assert np.mean(actions[:, 0] == 1.0) == pytest.approx(0.16, abs=0.03)


def test_episodes_go_round_the_tracks_cars_and_grid_slots_in_turn():
    rec = Recording(tracks=("a", "b"), cars=("c",), grid=(1, "last"))
    turns = [o for _, o in zip(range(5), rec.episode_options(), strict=False)]
    assert [(o["track"], o["grid_position"]) for o in turns] == [("a", 1), ("a", "last"), ("b", 1), ("b", "last"),
                                                               ("a", 1)]
    kwargs = rec.env_kwargs()
    assert kwargs["teacher"] == "boxbox" and kwargs["track"] == ["a", "b"] and kwargs["action_repeat"] == 2


def test_a_dataset_goes_to_a_new_place_or_replaces_a_dataset_only_when_asked(tmp_path, monkeypatch):
    assert dataset_place(tmp_path, "boxbox/robot-v0", replace=False) == tmp_path / "boxbox" / "robot-v0"
    for bad in ("robot", "bad id", "../x-v0", "a/../../x-v0", ""):
        with pytest.raises(UsageError, match="Minari dataset id|climbs out"):
            dataset_place(tmp_path, bad, replace=True)
    made = tmp_path / "boxbox" / "made-v0" / "data"
    made.mkdir(parents=True)
    (made / "metadata.json").write_text("{}")
    with pytest.raises(UsageError, match="exists in .*; give --replace"):
        dataset_place(tmp_path, "boxbox/made-v0", replace=False)
    assert dataset_place(tmp_path, "boxbox/made-v0", replace=True) == made.parent
    (tmp_path / "other-v0").mkdir()
    (tmp_path / "file-v0").write_text("mine")
    (tmp_path / "link-v0").symlink_to(made.parent)
    for name, words in (("other-v0", "not a Minari dataset"), ("file-v0", "not a folder"), ("link-v0", "a link")):
        with pytest.raises(UsageError, match=words):
            dataset_place(tmp_path, name, replace=True)
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    assert datasets_root(None) == tmp_path / "minari"
    with pytest.raises(UsageError, match="is a file"):
        datasets_root(tmp_path / "file-v0")
