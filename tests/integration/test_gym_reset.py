"""Resets with a spare race (gym/spare.py) on real TORCS: the reset takes the spare made while the
episode ran, the episode is the same bit for bit as with a fresh TORCS, and nothing is left after
close, after the env is dropped, or after the env's process is killed outright."""

from __future__ import annotations

import contextlib
import gc
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium
import numpy as np
import psutil

import boxbox.gym
from boxbox.gym.env import TorcsEnv
from boxbox.gym.start import LAUNCH_MAX_STEPS
from boxbox.model.constants import DRIVE_STEP_S
from helpers import processes_mentioning

ID = boxbox.gym.ENV_ID


def actions(n: int, seed: int = 7) -> np.ndarray:
    """Steer and the one pedal (the env's default actions), mostly on the throttle."""
    rng = np.random.default_rng(seed)
    return np.clip(rng.normal([0, 0.4], 0.5, size=(n, 2)), -1, 1).astype(np.float32)


def test_a_reset_takes_the_spare_made_while_the_episode_ran(overlay):
    env = gymnasium.make(ID, track="g-track-1", stuck_s=None)  # spares=1 by default
    _, info = env.reset(seed=0)
    assert info["spare"] is False  # the first race: nothing was ready
    pool = env.unwrapped.session.pool
    spare = pool.spares[0]
    deadline = time.monotonic() + 20
    while spare.started is None and time.monotonic() < deadline:  # TORCS loads on its own meanwhile
        env.step(np.array([0.0, -1.0], np.float32))  # full brake
    assert spare.started is not None  # set up by the steps, a message at a time
    _, info = env.reset()
    assert info["spare"] is True and pool.taken == 1 and env.unwrapped.session.race is spare
    # at the start, past the countdown and the start's launch (up to LAUNCH_MAX_STEPS drive steps)
    assert 0.0 <= info["state"].sim_time_s < LAUNCH_MAX_STEPS * DRIVE_STEP_S + 0.05
    _, info = env.reset()  # no steps in between: the spare's set-up is finished by the reset
    assert info["spare"] is True and pool.taken == 2
    env.close()


def run(env, seed: int | None, n: int = 300) -> bytes:
    obs, _ = env.reset(seed=seed)
    seen = [obs]
    for a in actions(n):
        obs, reward, terminated, truncated, _ = env.step(a)
        seen += [obs, np.array([reward], dtype=np.float32)]
        if terminated or truncated:
            break
    return np.concatenate(seen).tobytes()


def test_same_seed_same_episode_with_the_spare_and_without(overlay):
    kw = dict(track="g-track-1", opponents=["bt:2"], flat=True, stuck_s=None, off_track_s=None)
    fresh = gymnasium.make(ID, spares=0, **kw)
    spared = gymnasium.make(ID, spares=1, **kw)
    first = run(fresh, 11)
    assert run(spared, 11) == first  # a fresh TORCS (the first reset)
    second = run(fresh, None)  # the next episode of the seed: another start along the lap
    assert run(spared, None) == second != first  # the spare made while the last episode ran
    assert spared.unwrapped.session.pool.taken == 1
    assert run(fresh, 11) == first
    fresh.close()
    spared.close()


def test_explicit_reset_options_discard_a_spare_made_for_another_race(overlay):
    # on the grid: every episode of g-track-1 the same race, so the spare made for the next one serves the one after
    # (a start drawn along the lap makes each episode's race its own)
    env = gymnasium.make(ID, track="g-track-1", random_start=False)
    _, info = env.reset(seed=0)
    assert (info["track"], round(info["track_length_m"])) == ("g-track-1", 2058)
    pool = env.unwrapped.session.pool
    for a in actions(20):
        env.step(a)
    made_for_g = pool.spares[0]
    _, info = env.reset(options={"track": "e-track-2"})
    assert info["track"] == "e-track-2" and info["spare"] is False
    assert round(info["track_length_m"]) == round(env.unwrapped.track.length_m) != 2058
    assert pool.spares == [made_for_g]  # kept: the next episode is on g-track-1 again
    _, info = env.reset()
    assert (info["track"], info["spare"]) == ("g-track-1", True)
    env.close()


def torcs_children(folder: Path) -> list[psutil.Process]:
    """The TORCS processes of the session in `folder` (not those of another test's env that the
    garbage collector has not collected yet)."""
    found = []
    for p in psutil.Process().children(recursive=True):
        with contextlib.suppress(psutil.Error):  # one that has just ended
            if "torcs" in (line := " ".join(p.cmdline())) and str(folder) in line:
                found.append(p)
    return found


def test_close_and_drop_leave_no_spare_behind(overlay):
    affinity = os.sched_getaffinity(0)
    env = TorcsEnv(track="g-track-1")
    env.reset()
    env.session.settle()
    folder = env.session.dir
    pids = [p.pid for p in torcs_children(folder)]
    assert len(pids) == 2  # the race and its spare
    env.close()
    assert not folder.exists() and not any(psutil.pid_exists(p) for p in pids)
    env = TorcsEnv(track="g-track-1")
    env.reset()
    env.step(np.zeros(2, np.float32))  # the spare spawned, still loading
    folder = env.session.dir
    pids = [p.pid for p in torcs_children(folder)]
    assert len(pids) == 2
    del env
    gc.collect()
    assert not folder.exists() and not any(psutil.pid_exists(p) for p in pids)
    assert os.sched_getaffinity(0) == affinity


CHILD = """
import numpy as np, gymnasium, boxbox.gym
env = gymnasium.make("boxbox/TORCS-v0", track="g-track-1")
env.reset(seed=0)
for _ in range(30):
    env.step(np.zeros(2, np.float32))
session = env.unwrapped.session
session.settle()
print(session.dir, session.pid, session.pool.spares[0].proc.pid, flush=True)
import time; time.sleep(60)
"""


def test_no_torcs_left_when_the_envs_process_is_killed(overlay):
    proc = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, text=True)
    try:
        folder, race, spare = proc.stdout.readline().split()
        assert psutil.pid_exists(int(race)) and psutil.pid_exists(int(spare))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and (psutil.pid_exists(int(race)) or psutil.pid_exists(int(spare))):
            time.sleep(0.05)
        assert not psutil.pid_exists(int(race)) and not psutil.pid_exists(int(spare))
        assert processes_mentioning(folder) == []
    finally:
        proc.kill()
        proc.wait()
