"""The env on real TORCS: the calling thread's cores are its own (only TORCS is pinned, to the
thread's core), step() outside an episode is refused as Gymnasium's envs refuse it, and reset options and
actions it cannot take are refused, not ignored."""

from __future__ import annotations

import os
import threading

import gymnasium
import numpy as np
import psutil
import pytest

import boxbox.gym
from boxbox.errors import UsageError
from boxbox.gym.env import TorcsEnv

ID = boxbox.gym.ENV_ID
BRAKE = np.array([0.0, -1.0], dtype=np.float32)  # steer, pedal: full brake


def affinity_of_a_new_thread() -> set[int]:
    seen: list[set[int]] = []
    thread = threading.Thread(target=lambda: seen.append(os.sched_getaffinity(0)))
    thread.start()
    thread.join()
    return seen[0]


def test_only_torcs_is_pinned_the_callers_threads_keep_their_cores(overlay):
    """A learner's threads started after reset() (PyTorch's pool) must not inherit TORCS's core: the
    issue's PPO ran 7x slower so."""
    original = os.sched_getaffinity(0)
    if len(original) < 2:
        pytest.skip("one core: nothing to pin away from")
    env = TorcsEnv(track="g-track-1")
    env.reset()
    assert os.sched_getaffinity(0) == original
    assert affinity_of_a_new_thread() == original
    assert set(psutil.Process(env.torcs_pid).cpu_affinity()) == {env.session.cpu}  # TORCS runs on one core
    for _ in range(50):
        env.step(BRAKE)
    assert os.sched_getaffinity(0) == original and affinity_of_a_new_thread() == original
    env.close()
    assert os.sched_getaffinity(0) == original


def test_torcs_follows_the_calling_thread_to_its_core(overlay):
    """The thread is never moved (30 us a move, twice a step, halved the steps a second): TORCS is
    moved to the thread's core when the thread has moved."""
    original = os.sched_getaffinity(0)
    if len(original) < 2:
        pytest.skip("one core: nowhere to follow to")
    env = TorcsEnv(track="g-track-1", spares=1)
    env.reset()
    try:
        for core in sorted(original)[:2]:
            os.sched_setaffinity(0, {core})  # the learner's thread moves (the test moves it)
            for _ in range(5):
                env.step(BRAKE)
            assert set(psutil.Process(env.torcs_pid).cpu_affinity()) == {core}
    finally:
        os.sched_setaffinity(0, original)
        env.close()


def test_a_chosen_cpu_pins_torcs_and_the_thread_while_it_drives(overlay):
    original = os.sched_getaffinity(0)
    core = max(original)
    env = TorcsEnv(track="g-track-1", cpu=core)
    env.reset()
    for _ in range(5):
        env.step(BRAKE)
    assert set(psutil.Process(env.torcs_pid).cpu_affinity()) == {core}
    assert os.sched_getaffinity(0) == original  # the thread's own cores back after each step
    env.close()


def test_step_outside_an_episode_needs_a_reset(overlay):
    env = TorcsEnv(track="g-track-1", stuck_s=0.1)
    with pytest.raises(gymnasium.error.ResetNeeded, match=r"call reset\(\) before step\(\)"):
        env.step(BRAKE)
    env.reset()
    for _ in range(100):
        _, reward, terminated, _, info = env.step(BRAKE)
        if terminated:
            break
    assert info["termination"] == "stuck"
    steps_before = env.state.sim_time_s
    for _ in range(2):  # the race does not go on simulating (nor rewarding) after the end
        with pytest.raises(UsageError, match=r"the episode has ended \(stuck\); call reset\(\) to start a new one"):
            env.step(BRAKE)
    assert env.state.sim_time_s == steps_before
    env.reset()
    _, _, terminated, _, _ = env.step(BRAKE)
    assert not terminated  # a reset starts a new episode
    env.close()


def test_reset_options_and_actions_it_cannot_take_are_refused(overlay):
    env = gymnasium.make(ID, track="g-track-1")
    env.reset()  # (Gymnasium's checker wants its first reset to succeed)
    with pytest.raises(UsageError, match=r"reset\(\) does not take 'laps' \(reset options: track, car, opponents"):
        env.reset(options={"laps": 2})
    env.reset(options={})
    for action in (np.zeros(8, dtype=np.float32), np.zeros(3, dtype=np.float32), "steer"):
        with pytest.raises(ValueError, match=r"give 2 numbers, shape \(2,\) \(steer, pedal\)"):
            env.unwrapped.step(action)  # past Gymnasium's checker: the env's own refusal
    _, _, terminated, _, _ = env.step(BRAKE)  # the episode goes on
    assert not terminated
    env.close()
