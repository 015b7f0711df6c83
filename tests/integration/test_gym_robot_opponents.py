"""Python robots as the env's opponents on real TORCS: the shipped robot races beside the learner (its
robot host relayed by the env), and a robot that raises or hangs is the line `boxbox race` gives,
with nothing left running."""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np
import pytest

import boxbox.gym
from boxbox.errors import RaceError
from helpers import processes_mentioning

pytestmark = pytest.mark.torcs
FAULTY = Path(__file__).resolve().parents[1] / "robots" / "faulty.py"


def test_the_shipped_robot_races_as_an_opponent_beside_a_torcs_robot():
    env = gymnasium.make(boxbox.gym.ENV_ID, track="g-track-1", opponents=["boxbox", "bt:1"], teacher="boxbox",
                         action_repeat=2, random_start=False, spares=0)
    try:
        _, info = env.reset(seed=0)
        assert info["opponents"] == ("bt:1", "boxbox")
        for _ in range(500):  # 20 s
            _, _, terminated, truncated, info = env.step(info["teacher_action"])
            assert not (terminated or truncated), info["termination"]
        ahead = {int(o.car_index): o.dist_raced_m for o in info["state"].opponents}
        assert len(ahead) == 2 and min(ahead.values()) > 300.0, ahead  # both drove: the robot is served
    finally:
        env.close()


@pytest.mark.parametrize(("robot", "words"), [
    ("RaisesInDrive", "' (middle 1) failed: ValueError: deliberate failure in drive (in drive, step "),
    ("HangsForever", "' (middle 1) did not answer within its step budget of 200 ms (step "),
])
def test_a_python_opponent_that_fails_is_the_race_line(robot, words):
    env = gymnasium.make(boxbox.gym.ENV_ID, track="g-track-1", opponents=[f"{FAULTY}:{robot}"], random_start=False,
                         spares=0)
    try:
        env.reset(seed=0)
        folder = str(env.unwrapped.session.dir)
        with pytest.raises(RaceError) as failed:
            for _ in range(100):  # 10 s; the robot fails after 1 s
                env.step(np.float32([0.0, 0.3]))
        assert str(failed.value).startswith(f"robot '{FAULTY}:{robot}") and words in str(failed.value), failed.value
        assert "faulty.py" in str(failed.value)  # its traceback, or where it was stuck
        *_, terminated, truncated, info = env.step(np.float32([0.0, 0.3]))  # the race is over, not hung
        assert truncated and not terminated and info["termination"] == "race-end"
    finally:
        env.close()
    assert processes_mentioning(folder) == []
