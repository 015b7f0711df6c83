"""Several learning cars in one real TORCS race: PettingZoo's API test, a reward and an end per car,
SuperSuit's vectorisation, determinism and clean-up (gym/parallel.py, gym/multisession.py)."""

from __future__ import annotations

import glob
import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import psutil
import pytest
import supersuit
from pettingzoo.test import parallel_api_test

import boxbox.gym
from boxbox.errors import UsageError
from boxbox.gym.env import NeedsReset
from helpers import GRID_IN_UNITS


def middle(obs, speed_mps: float) -> np.ndarray:
    """Steer along the track axis at about speed_mps."""
    steer = 2.0 * float(obs["angle_rad"][0]) - 0.6 * float(obs["track_pos"][0])
    throttle = 0.2 * (speed_mps - float(obs["speed_mps"][0]))
    return np.array([np.clip(steer, -1, 1), np.clip(throttle, 0, 1), 0.0], dtype=np.float32)


def session_dirs() -> set[str]:
    return set(glob.glob(os.path.join(tempfile.gettempdir(), f"boxbox-gym-{os.getpid()}-*")))


def test_passes_pettingzoos_parallel_api_test(overlay):
    env = boxbox.gym.parallel_env(cars=3, track="g-track-1", opponents=["bt:2"])
    assert env.possible_agents == ["car_0", "car_1", "car_2"]
    parallel_api_test(env, num_cycles=200)
    env.close()


def test_each_car_drives_with_its_own_reward_and_one_ends_while_the_others_go_on(overlay):
    before = session_dirs()
    env = boxbox.gym.parallel_env(cars=3, track="g-track-1", off_track_s=0.2, **GRID_IN_UNITS)
    obs, infos = env.reset(seed=0)
    states = [infos[a]["state"] for a in env.agents]
    assert len({(s.x_m, s.y_m) for s in states}) == 3 and all(s.sim_time_s >= 0.0 for s in states)  # one instant
    assert len({s.sim_time_s for s in states}) == 1
    totals = dict.fromkeys(env.possible_agents, 0.0)
    ended_at = None
    for step in range(250):
        actions = {"car_0": middle(obs["car_0"], 25.0), "car_1": middle(obs["car_1"], 12.0)}
        if "car_2" in env.agents:
            actions["car_2"] = np.array([1.0, 1.0, 0.0], np.float32)  # full lock left: off the track
        obs, rewards, terminations, truncations, infos = env.step(actions)
        for agent, reward in rewards.items():
            totals[agent] += reward
        if terminations.get("car_2"):
            ended_at = step
            assert infos["car_2"]["termination"] == "off-track"
            assert not terminations["car_0"] and not terminations["car_1"]
        assert set(obs) == set(rewards) == set(terminations) == set(truncations) == set(infos)
    assert ended_at is not None and env.agents == ["car_0", "car_1"]  # car_2 left, the others went on
    assert totals["car_0"] > totals["car_1"] > 20.0  # each its own progress: the faster car gained more
    assert all(i["state"].sim_time_s == infos["car_0"]["state"].sim_time_s for i in infos.values())
    with pytest.raises(UsageError, match="no action for car_1"):
        env.step({"car_0": middle(obs["car_0"], 25.0)})
    pid = env.torcs_pid
    env.close()
    assert not psutil.pid_exists(pid) and session_dirs() == before


def test_the_same_actions_give_the_same_race(overlay):
    env = boxbox.gym.parallel_env(cars=2, track="g-track-1", opponents=["bt:2"], flat=True)
    rng = np.random.default_rng(3)
    actions = rng.uniform([-0.2, -0.1], [0.2, 1.0], size=(80, 2, 2)).astype(np.float32)  # steer, pedal
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=1)
        trace = [np.concatenate([obs[a] for a in env.possible_agents])]
        for a in actions:
            obs, rewards, *_ = env.step({agent: a[i] for i, agent in enumerate(env.agents)})
            trace.append(np.concatenate([obs[agent] for agent in sorted(obs)] + [list(rewards.values())]))
        runs.append(np.concatenate(trace))
    env.close()
    assert np.array_equal(runs[0], runs[1])


def test_supersuit_vectorises_it(overlay):
    def make():
        return supersuit.black_death_v3(boxbox.gym.parallel_env(cars=2, track="g-track-1", flat=True, stuck_s=0.5))

    vec = supersuit.concat_vec_envs_v1(supersuit.pettingzoo_env_to_vec_env_v1(make()), 2, num_cpus=0,
                                       base_class="gymnasium")
    obs, infos = vec.reset(seed=0)
    assert obs.shape == (4, vec.observation_space.shape[0])  # 2 envs x 2 cars
    dones = 0
    for _ in range(150):  # braking: stuck 0.5 s after the launch, the envs reset themselves
        obs, rewards, terminations, truncations, infos = vec.step(np.tile(np.float32([0.0, -1.0]), (4, 1)))
        dones += int(terminations.sum())
    assert obs.shape == (4, vec.observation_space.shape[0]) and np.isfinite(obs).all()
    assert dones >= 4
    vec.close()


def test_pixels_and_render_for_every_car(overlay):
    env = boxbox.gym.parallel_env(cars=2, track="g-track-1", pixels=True, render_mode="rgb_array")
    obs, _ = env.reset(seed=0)
    assert all(o.shape == (96, 96, 3) and o.dtype == np.uint8 for o in obs.values())
    assert env.observation_space("car_0").contains(obs["car_0"])
    assert not np.array_equal(obs["car_0"], obs["car_1"])  # each car's own view
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3
    env.close()


def test_step_before_reset_and_bad_options_are_refused(overlay):
    with pytest.raises(UsageError, match="cars"):
        boxbox.gym.parallel_env(cars=11)
    with pytest.raises(UsageError, match="pit"):
        boxbox.gym.parallel_env(cars=2, actions=("steer", "throttle", "brake", "pit"))
    env = boxbox.gym.parallel_env(cars=2)
    with pytest.raises(NeedsReset):
        env.step({})
    env.close()


@pytest.mark.parametrize("how", ["killed", "hung"])
def test_a_torcs_killed_or_hung_truncates_every_car(overlay, how):
    env = boxbox.gym.parallel_env(cars=2, track="g-track-1", step_timeout_s=1.0, **GRID_IN_UNITS)
    obs, _ = env.reset(seed=0)
    for _ in range(10):
        obs, *_ = env.step({agent: middle(obs[agent], 20.0) for agent in env.agents})
    pid = env.torcs_pid
    os.kill(pid, signal.SIGKILL if how == "killed" else signal.SIGSTOP)
    try:
        start = time.monotonic()
        obs, rewards, terminations, truncations, infos = env.step({a: middle(obs[a], 20.0) for a in env.agents})
        waited_s = time.monotonic() - start
    finally:
        if how == "hung":
            os.kill(pid, signal.SIGCONT)
    assert truncations == {"car_0": True, "car_1": True} and terminations == {"car_0": False, "car_1": False}
    assert all(info["termination"] == "fault" for info in infos.values()) and env.agents == []
    fault = infos["car_0"]["fault"]
    assert ("SIGKILL" in fault) if how == "killed" else ("did not answer within 1 s" in fault and waited_s < 3.0)
    env.reset()
    assert env.torcs_pid != pid and env.agents == ["car_0", "car_1"]
    env.close()
    assert not psutil.pid_exists(pid)


def test_killing_the_process_leaves_no_torcs(overlay):
    code = ("import boxbox.gym, sys\n"
            "env = boxbox.gym.parallel_env(cars=2, track='g-track-1')\n"
            "env.reset()\n"
            "print(env.torcs_pid, env.session.dir, flush=True)\n"
            "sys.stdin.read()\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    pid, folder = proc.stdout.readline().split()
    assert psutil.pid_exists(int(pid))
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 5
    while psutil.pid_exists(int(pid)) and psutil.Process(int(pid)).status() != psutil.STATUS_ZOMBIE:
        assert time.monotonic() < deadline, "TORCS outlived the env's process"
        time.sleep(0.05)
    proc.stdin.close()
    proc.stdout.close()


def test_each_car_observes_its_view_with_the_numbers_and_its_dashboard(overlay):
    env = boxbox.gym.parallel_env(cars=2, track="g-track-1", pixels=True, pixels_only=False, dashboard=True,
                                  view_ahead_m=60)
    obs, infos = env.reset(seed=0)
    for _ in range(5):
        obs, rewards, terminations, truncations, infos = env.step({a: np.float32([0.0, 1.0]) for a in env.agents})
    for agent in env.possible_agents:
        assert env.observation_space(agent).contains(obs[agent]) and obs[agent]["pixels"].shape == (96, 96, 3)
        assert "raw_observation" in infos[agent]  # the numbers computed, as without pixels
    assert not np.array_equal(obs["car_0"]["pixels"], obs["car_1"]["pixels"])
    env.close()
