"""What the learning examples share: a deterministic rollout, a CSV curve that stops training once a
rollout laps, and its plot; a look-ahead of the track's curvature as more observation (LookAhead).
Used by train_ppo.py, train_sac.py and train_bc.py (run from this folder or by path)."""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path
from typing import Any, Protocol

import gymnasium
import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import configure

DRIVE_STEP_S = 0.02  # TORCS's simulation step
# the look-ahead's windows, metres ahead of the car: at 75 m/s the robot brakes for e-track-4's corner
# at 4,645 m some 190 m before it, beyond the 200 m the range finders see along a straight
LOOK_AHEAD_EDGES_M = (0, 25, 50, 75, 100, 150, 200, 250, 300, 350, 400)
TIGHTEST_RADIUS_M = 10.0  # a look-ahead of 1 (the public tracks' tightest corners are about this)


class Predicts(Protocol):
    """A policy as Stable-Baselines3's models offer it (train_bc.py's Policy too)."""

    def predict(self, observation: Any, deterministic: bool = ...) -> tuple[Any, Any]: ...


def rollout(model: Predicts, env: gymnasium.Env) -> dict:
    """One deterministic episode: did it complete the lap, how far it went, the lap time."""
    obs, _ = env.reset(seed=0)
    episode_return, progress_m, done, steps = 0.0, 0.0, False, 0
    while not done:
        obs, reward, terminated, truncated, info = env.step(model.predict(obs, deterministic=True)[0])
        episode_return, progress_m, steps = episode_return + float(reward), progress_m + info["progress_m"], steps + 1
        done = terminated or truncated
    lap = info["termination"] == "race-end"
    lap_time_s = info["state"].last_lap_time_s  # 0 where TORCS ended the race before it sent the state past the line
    return {"lap_completed": lap, "episode_return": round(episode_return, 1), "progress_m": round(progress_m, 1),
            "termination": info["termination"] or "time-limit", "episode_steps": steps,
            "lap_time_s": round(lap_time_s, 3) if lap and lap_time_s > 0 else None}


def curvature_by_metre(track: Any) -> np.ndarray:
    """A boxbox Track's signed curvature (1/m, + for left turns, 0 on straights) at each whole metre
    from its start line."""
    metres = np.arange(int(np.ceil(track.length_m)))
    segment = np.searchsorted(track.seg["start_dist_m"], metres, side="right") - 1
    return track.curvature()[np.maximum(segment, 0)]


def look_ahead(curvature: np.ndarray, dist_m: np.ndarray) -> np.ndarray:
    """For each distance from the start line (n of them), the tightest signed curvature in each window
    of LOOK_AHEAD_EDGES_M ahead, as sign x sqrt(curvature x TIGHTEST_RADIUS_M) clipped to [-1, 1]: a
    corner's speed goes as the square root of its radius, so the root spreads the radii that set the
    speed (10 m: 1, 40 m: 0.5, 250 m: 0.2) instead of crowding all but hairpins near 0.  (n, K) float32."""
    metres = np.floor(np.asarray(dist_m, dtype=np.float64)).astype(np.int64)
    ahead = curvature[(metres[:, None] + np.arange(LOOK_AHEAD_EDGES_M[-1])[None]) % len(curvature)]
    windows = []
    for low, high in zip(LOOK_AHEAD_EDGES_M[:-1], LOOK_AHEAD_EDGES_M[1:], strict=True):
        window = ahead[:, low:high]
        windows.append(window[np.arange(len(window)), np.abs(window).argmax(axis=1)])
    k = np.stack(windows, axis=1)
    return (np.sign(k) * np.sqrt(np.minimum(np.abs(k) * TIGHTEST_RADIUS_M, 1.0))).astype(np.float32)


class LookAhead(gymnasium.ObservationWrapper):
    """The env's observation plus the track's curvature ahead of the car (`look_ahead`, above): a
    Dict observation gains the key `look_ahead`, a flat one K more numbers at its end.  Each track's
    curvature is computed once, at its first reset (`curvatures` and `lengths_m`, by track name)."""

    KEY = "look_ahead"

    def __init__(self, env: gymnasium.Env) -> None:
        super().__init__(env)
        size = len(LOOK_AHEAD_EDGES_M) - 1
        space = env.observation_space
        box = gymnasium.spaces.Box(-1.0, 1.0, (size,), np.float32)
        if isinstance(space, gymnasium.spaces.Dict):
            self.observation_space = gymnasium.spaces.Dict({**space.spaces, self.KEY: box})
        else:
            assert isinstance(space, gymnasium.spaces.Box)
            self.observation_space = gymnasium.spaces.Box(np.concatenate([space.low, box.low]),
                                                          np.concatenate([space.high, box.high]), dtype=np.float32)
        self.curvatures: dict[str, np.ndarray] = {}
        self.lengths_m: dict[str, float] = {}
        self.curvature = np.zeros(1)
        self.dist_m = 0.0

    def reset(self, **kwargs):  # type: ignore[override]
        obs, info = self.env.reset(**kwargs)
        track = self.env.unwrapped.track  # type: ignore[attr-defined]
        if track.name not in self.curvatures:
            self.curvatures[track.name] = curvature_by_metre(track)
            self.lengths_m[track.name] = float(track.length_m)
        self.curvature, self.dist_m = self.curvatures[track.name], info["state"].dist_from_start_m
        return self.observation(obs), info

    def step(self, action):  # type: ignore[override]
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.dist_m = info["state"].dist_from_start_m
        return self.observation(obs), reward, terminated, truncated, info

    def observation(self, observation: Any) -> Any:
        ahead = look_ahead(self.curvature, np.array([self.dist_m]))[0]
        if isinstance(observation, dict):
            return {**observation, self.KEY: ahead}
        return np.concatenate([observation, ahead]).astype(np.float32)


class Curve(BaseCallback):
    """A CSV row per training episode (of every env of a vector env) and per deterministic rollout
    from the grid (every `eval_every` env steps); training stops once a rollout laps."""

    COLUMNS = ["steps", "wall_s", "kind", "episode_return", "progress_m", "lap_completed", "termination",
               "lap_time_s"]

    def __init__(self, path: Path, eval_env: gymnasium.Env, eval_every: int):
        super().__init__()
        self.file = path.open("w", newline="")
        self.rows = csv.DictWriter(self.file, self.COLUMNS, extrasaction="ignore")
        self.rows.writeheader()
        self.eval_env, self.eval_every, self.next_eval = eval_env, eval_every, eval_every
        self.started = time.perf_counter()
        self.returns: list[float] = []
        self.progress: list[float] = []
        self.final: dict | None = None
        self.best_progress_m = 0.0

    def write(self, kind: str, row: dict) -> None:
        row = {**row, "steps": self.num_timesteps, "wall_s": round(time.perf_counter() - self.started, 2),
               "kind": kind, "lap_completed": int(row["lap_completed"])}
        self.rows.writerow(row)
        self.file.flush()
        if kind == "eval":
            print(f"{row['steps']} steps, {row['wall_s']:.0f} s, rollout: {row['progress_m']:.0f} m "
                  f"({row['termination']}, lap {row.get('lap_time_s')})", flush=True)

    def _on_step(self) -> bool:
        infos, rewards, dones = self.locals["infos"], self.locals["rewards"], self.locals["dones"]
        if not self.returns:
            self.returns, self.progress = [0.0] * len(infos), [0.0] * len(infos)
        for i, info in enumerate(infos):
            self.returns[i] += float(rewards[i])
            self.progress[i] += info["progress_m"]
            if dones[i]:
                self.write("train", {"episode_return": round(self.returns[i], 1),
                                     "progress_m": round(self.progress[i], 1),
                                     "lap_completed": info["termination"] == "race-end",
                                     "termination": info["termination"] or "time-limit"})
                self.returns[i] = self.progress[i] = 0.0
        if self.num_timesteps >= self.next_eval:
            self.next_eval = self.num_timesteps + self.eval_every
            result = rollout(self.model, self.eval_env)
            self.best_progress_m = max(self.best_progress_m, result["progress_m"])
            self.write("eval", result)
            if result["lap_completed"]:
                self.final = result
                return False
        return True

    def _on_training_end(self) -> None:
        self.file.close()


def plot(csv_path: Path, png_path: Path, lap_m: float, title: str, action_repeat: int) -> None:
    """The curve: progress of each training episode and each rollout against env steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with csv_path.open() as f:
        rows = list(csv.DictReader(f))
    fig, ax = plt.subplots(figsize=(7, 3.6), dpi=110)
    for kind, style, label in (("train", ".", "training episode"), ("eval", "x", "deterministic rollout")):
        steps = [int(r["steps"]) for r in rows if r["kind"] == kind]
        ax.plot(steps, [float(r["progress_m"]) for r in rows if r["kind"] == kind], style, ms=3, label=label)
    ax.axhline(lap_m, color="grey", ls="--", lw=1, label=f"a lap ({lap_m:.0f} m)")
    ax.set(xlabel=f"env steps (an action every {DRIVE_STEP_S * action_repeat:.2f} s of race)",
           ylabel="progress in the episode (m)", title=title)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path)
    plt.close(fig)


def train(model: BaseAlgorithm, eval_env: gymnasium.Env, out: Path, steps: int, eval_every: int,
          about: dict, title: str) -> dict:
    """Train until a rollout laps or for `steps` env steps, then write into `out` the model
    (model.zip), the curve (curve.csv, curve.png) and summary.json (`about`, the steps, the wall time,
    the last rollout); print its line and return the summary."""
    curve = Curve(out / "curve.csv", eval_env, eval_every)
    # SB3's own logger, left to itself, makes an empty folder in /tmp each run (SB3-date): this one
    # writes nothing (verbose=0) and its folder is `out`
    model.set_logger(configure(str(out), []))
    started = time.perf_counter()
    model.learn(total_timesteps=steps, callback=curve)
    wall_s = time.perf_counter() - started
    model.save(out / "model.zip")
    final = curve.final or rollout(model, eval_env)
    summary = {**about, "steps": model.num_timesteps, "wall_s": round(wall_s, 1),
               "best_rollout_progress_m": curve.best_progress_m, **final}
    plot(out / "curve.csv", out / "curve.png", float(eval_env.unwrapped.track.length_m),  # type: ignore[attr-defined]
         f"{title}: {model.num_timesteps:,} steps, {wall_s / 60:.1f} min",
         eval_env.unwrapped.action_repeat)  # type: ignore[attr-defined]
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(f"lap completed: {final['lap_completed']} after {model.num_timesteps} steps ({wall_s:.0f} s); "
          f"deterministic rollout {final['progress_m']:.0f} m, lap time {final['lap_time_s']} s")
    return summary
