"""The Gymnasium env on real TORCS: the checker, determinism, resets, faults, vector envs, limits."""

from __future__ import annotations

import glob
import os
import signal
import tempfile
import time

import gymnasium
import numpy as np
import psutil
import pytest
from gymnasium.utils.env_checker import check_env

import boxbox.gym
from boxbox.errors import UsageError
from boxbox.gym.env import TorcsEnv
from helpers import GRID_IN_UNITS, processes_mentioning

ID = boxbox.gym.ENV_ID


def middle_driver(obs) -> np.ndarray:
    """Steer along the track axis at about 22 m/s (slow enough for every turn of g-track-1)."""
    steer = 2.0 * float(obs["angle_rad"][0]) - 0.6 * float(obs["track_pos"][0])
    throttle = 0.2 * (22.0 - float(obs["speed_mps"][0]))
    return np.array([np.clip(steer, -1, 1), np.clip(throttle, 0, 1), 0.0], dtype=np.float32)


def random_actions(env, n: int, seed: int = 0) -> np.ndarray:
    space = env.action_space
    return np.random.default_rng(seed).uniform(space.low, space.high, size=(n, *space.shape)).astype(np.float32)


def session_dirs() -> set[str]:
    """This process's env folders (other test runs on the machine have their own)."""
    return set(glob.glob(os.path.join(tempfile.gettempdir(), f"boxbox-gym-{os.getpid()}-*")))


def test_registered_and_passes_the_gymnasium_checker(overlay):
    before = session_dirs()
    for flat in (False, True):
        env = gymnasium.make(ID, track="g-track-1", flat=flat)
        check_env(env.unwrapped, skip_render_check=True)
        obs, info = env.reset(seed=0)
        assert env.observation_space.contains(obs)
        if flat:
            assert obs.shape == (gymnasium.spaces.flatdim(env.unwrapped.layout.dict_space()),)
        env.close()
    env = TorcsEnv(track="g-track-1", render_mode="rgb_array")  # as stable-baselines3's make_vec_env asks
    env.reset()
    assert env.render().dtype == np.uint8  # the race from above (test_gym_pixels.py)
    env.close()
    assert session_dirs() == before  # every run folder removed


def test_observation_fields_at_the_start(overlay):
    env = gymnasium.make(ID, track="g-track-1", opponents=["bt:2"], **GRID_IN_UNITS)
    obs, info = env.reset(seed=0)
    state = info["state"]
    assert state.sim_time_s >= 0.0  # past the start countdown
    assert obs["track_edges_m"].shape == (19,) and obs["opponents_m"].shape == (36,)
    # the edges at -90 and +90 degrees are the distances to the left and right edges on the grid
    assert obs["track_edges_m"][0] == pytest.approx(state.to_left_m, abs=0.3)
    assert obs["track_edges_m"][-1] == pytest.approx(state.to_right_m, abs=0.3)
    assert obs["opponents_m"].min() < 30.0  # bt's car next to us on the grid
    assert obs["fuel_l"][0] > 0 and obs["damage"][0] == 0
    assert -1.0 < obs["track_pos"][0] < 1.0
    track, car = env.unwrapped.track, env.unwrapped.car
    assert (track.name, round(track.length_m)) == ("g-track-1", 2058) and car.name == "car1-trb1" and car.max_gear == 6
    env.close()


def test_same_seed_same_actions_same_observations_bit_for_bit(overlay):
    env = gymnasium.make(ID, track="g-track-1", opponents=["bt:2"], stuck_s=None, off_track_s=None)
    actions = random_actions(env, 400, seed=7)
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=11)
        seen = [gymnasium.spaces.flatten(env.observation_space, obs)]
        for a in actions:
            obs, reward, terminated, truncated, info = env.step(a)
            seen.append(gymnasium.spaces.flatten(env.observation_space, obs))
            seen.append(np.array([reward], dtype=np.float64).view(np.float32))
        runs.append(np.concatenate(seen))
    env.close()
    assert runs[0].tobytes() == runs[1].tobytes()


def test_a_lap_ends_the_race_episode(overlay):
    env = gymnasium.make(ID, track="g-track-1", laps=1, max_episode_steps=20_000, **GRID_IN_UNITS)
    obs, _ = env.reset(seed=0)
    total = 0.0
    for _ in range(20_000):
        obs, reward, terminated, truncated, info = env.step(middle_driver(obs))
        total += reward
        if terminated or truncated:
            break
    env.close()
    assert info["termination"] == "race-end" and truncated and not terminated, info  # the laps ran out: no MDP end
    assert 1800 < total < 2200  # about one lap of 2058 m of progress (from the grid, behind the line)


def test_limits_and_custom_reward(overlay):
    calls = []

    def speed_reward(before, after, info):
        calls.append(info["progress_m"])
        return after.speed_x_mps

    env = gymnasium.make(ID, track="g-track-1", reward_fn=speed_reward, stuck_s=1.0, random_start=False)
    env.reset(seed=0)
    t0 = env.unwrapped.state.sim_time_s
    steps = 0
    while True:
        _, reward, terminated, truncated, info = env.step(np.array([0.0, -1.0], dtype=np.float32))  # full brake
        steps += 1
        if terminated:
            break
    env.close()
    assert info["termination"] == "stuck"
    assert info["state"].sim_time_s - t0 == pytest.approx(1.02, abs=0.011)  # 51 drive steps of 0.02 s
    assert steps == 11 and len(calls) == 51  # 5 drive steps per env step; the reward per drive step
    assert reward == pytest.approx(0.0, abs=0.1)


def test_bad_input_is_one_line_before_torcs_starts(overlay):
    before = session_dirs()
    with pytest.raises(UsageError, match="unknown track 'g-track-9'.*g-track-1"):
        TorcsEnv(track="g-track-9")
    with pytest.raises(UsageError, match="gear is either an action or the 'gears' assist"):
        TorcsEnv(actions=("steer", "throttle", "brake", "gear"))
    with pytest.raises(UsageError, match="unknown TORCS robot"):
        TorcsEnv(opponents=["bq:2"])
    with pytest.raises(UsageError, match="opponent bt:2 is given twice"):
        TorcsEnv(opponents=["bt:2", ("bt", 2)])
    with pytest.raises(UsageError, match="Invalid value for 'cpu': 4096 is not a core this process may use"):
        TorcsEnv(cpu=4096)
    assert session_dirs() == before


def open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


@pytest.mark.parametrize("spares", [0, 1])
def test_resets_leave_nothing_behind(overlay, spares):
    """50 short episodes: the same open files, child processes (TORCS and its spare) and (nearly)
    memory as after the 5th."""
    me = psutil.Process()
    affinity = os.sched_getaffinity(0)
    env = gymnasium.make(ID, track="g-track-1", spares=spares)
    actions = random_actions(env, 20)
    marks = {}
    for episode in range(50):
        env.reset()
        for a in actions:
            env.step(a)
        if episode in (4, 49):
            env.unwrapped.session.settle()  # the spare ready, the last race collected
            marks[episode] = (open_fds(), len(me.children(recursive=True)), me.memory_info().rss)
    session = env.unwrapped.session.dir
    env.close()
    (fds5, kids5, rss5), (fds50, kids50, rss50) = marks[4], marks[49]
    assert (fds50, kids50) == (fds5, kids5) == (fds5, 1 + spares)
    assert rss50 - rss5 < 4 << 20
    assert me.children(recursive=True) == [] and open_fds() < fds5
    assert not session.exists() and processes_mentioning(str(session)) == []
    assert os.sched_getaffinity(0) == affinity  # the env's pinning undone


def test_torcs_killed_mid_episode_is_reported_and_reset_recovers(overlay):
    env = gymnasium.make(ID, track="g-track-1", **GRID_IN_UNITS)
    obs, _ = env.reset(seed=0)
    for _ in range(50):
        obs, *_ = env.step(middle_driver(obs))
    time.sleep(0.5)  # a learner may think for as long as it likes: no step budget
    obs, reward, terminated, truncated, info = env.step(middle_driver(obs))
    assert not terminated and info["fault"] is None
    pid = env.unwrapped.torcs_pid
    os.kill(pid, signal.SIGKILL)
    obs, reward, terminated, truncated, info = env.step(middle_driver(obs))
    assert truncated and not terminated and info["termination"] == "fault"  # no MDP state: not terminal
    assert "TORCS was killed by SIGKILL" in info["fault"]
    assert env.observation_space.contains(obs) and reward == 0.0
    obs, _ = env.reset()
    assert env.unwrapped.torcs_pid != pid
    for _ in range(50):
        obs, reward, terminated, truncated, info = env.step(middle_driver(obs))
    assert not terminated and reward > 0
    env.close()


def test_a_hung_torcs_truncates_the_step_after_step_timeout_s(overlay):
    env = gymnasium.make(ID, track="g-track-1", step_timeout_s=1.0, spares=0, **GRID_IN_UNITS)
    obs, _ = env.reset(seed=0)
    for _ in range(20):
        obs, *_ = env.step(middle_driver(obs))
    pid = env.unwrapped.torcs_pid
    os.kill(pid, signal.SIGSTOP)  # hung: alive, silent
    try:
        start = time.monotonic()
        obs, reward, terminated, truncated, info = env.step(middle_driver(obs))
        waited_s = time.monotonic() - start
    finally:
        os.kill(pid, signal.SIGCONT)
    assert 1.0 <= waited_s < 3.0, waited_s
    assert truncated and not terminated and info["termination"] == "fault"
    assert "did not answer within 1 s" in info["fault"] and env.observation_space.contains(obs)
    obs, _ = env.reset()  # the hung TORCS killed, a new one races
    assert env.unwrapped.torcs_pid != pid and not psutil.pid_exists(pid)
    obs, reward, terminated, truncated, info = env.step(middle_driver(obs))
    assert not (terminated or truncated)
    env.close()


@pytest.mark.parametrize("kind", ["sync", "async"])
def test_vector_envs_survive_a_crashed_sub_env(overlay, kind):
    def make():
        return gymnasium.make(ID, track="g-track-1", flat=True)

    cls = gymnasium.vector.SyncVectorEnv if kind == "sync" else gymnasium.vector.AsyncVectorEnv
    venv = cls([make, make])
    obs, _ = venv.reset(seed=[1, 2])
    assert obs.shape == (2, venv.single_observation_space.shape[0])
    pids = venv.get_attr("torcs_pid")
    assert len(set(pids)) == 2 and all(psutil.pid_exists(p) for p in pids)
    actions = random_actions(venv, 30)
    for a in actions[:20]:
        venv.step(a)
    os.kill(pids[1], signal.SIGKILL)
    obs, rewards, terminated, truncated, infos = venv.step(actions[20])
    assert list(terminated) == [False, False] and list(truncated) == [False, True]
    assert infos["termination"][1] == "fault" and "SIGKILL" in infos["fault"][1]
    for a in actions[21:]:  # the crashed sub-env is reset (a new TORCS) and steps on
        obs, rewards, terminated, truncated, infos = venv.step(a)
    new_pids = venv.get_attr("torcs_pid")
    assert new_pids[0] == pids[0] and new_pids[1] != pids[1]
    assert not terminated.any() and np.isfinite(obs).all()
    venv.close()
    assert not any(psutil.pid_exists(p) for p in new_pids)


def test_folders_of_env_processes_killed_outright_are_removed(overlay):
    stale = os.path.join(tempfile.gettempdir(), "boxbox-gym-999999999-test")  # no such process
    os.makedirs(os.path.join(stale, "local"))
    env = TorcsEnv(track="g-track-1")
    env.reset()
    assert not os.path.exists(stale)
    env.close()


def test_an_env_dropped_without_close_leaves_nothing(overlay):
    import gc

    affinity = os.sched_getaffinity(0)
    env = TorcsEnv(track="g-track-1")
    env.reset()
    folder, pid = env.session.dir, env.torcs_pid
    del env
    gc.collect()
    assert not folder.exists() and not psutil.pid_exists(pid)
    assert os.sched_getaffinity(0) == affinity
