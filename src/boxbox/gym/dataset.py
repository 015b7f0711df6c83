"""`boxbox dataset`: a robot driving through the env, recorded as a Minari dataset (Farama's format for
offline RL and imitation, the `data` extra).

The env is made with the robot as its teacher (gym/teacher.py) and each step's action is the
teacher's action, plus Gaussian noise when asked (`noise`, in units of each column's half range,
clipped to the action space): pushed off its line, the robot's next actions bring the car back, so
the data holds recoveries (as DART does).  The dataset keeps, per step, the env's observation (its
own space: the Dict, scaled), the action the car was driven with (noise included), the reward,
terminations and truncations, and in `infos` the teacher's own action for each observation
(`teacher_action`, what a learner imitates) and the progress (`progress_m`).  Episodes go round
the chosen tracks, cars and grid slots in turn, episode i seeded with `seed + i` (its start point,
gym/start.py); the env's `spec` is in the dataset, so `dataset.recover_environment()` makes the env
again.  The dataset is written in a temporary folder beside its place and moved there whole at the
end: an interrupted or failed recording leaves nothing.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import shutil
import tempfile
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

from boxbox import validate
from boxbox.errors import UsageError

DEFAULT_DATASET = "boxbox/robot-v0"
DEFAULT_EPISODES = 10
UNLIMITED = 1 << 62  # steps, when only --episodes bounds the recording
MINARI_ROOT = "MINARI_DATASETS_PATH"  # where minari.load_dataset looks (else ~/.minari/datasets)


@dataclass(frozen=True)
class Recording:
    """What `boxbox dataset` records (each list is gone round in turn, episode by episode)."""

    dataset_id: str = DEFAULT_DATASET
    robot: str = "boxbox"
    tracks: tuple[str, ...] = ("g-track-1",)
    cars: tuple[str, ...] = ("car1-trb1",)
    grid: tuple[int | str | None, ...] = (None,)
    opponents: tuple[str, ...] = ()
    episodes: int | None = DEFAULT_EPISODES  # at most this many episodes (None: until `steps`)
    steps: int | None = None  # at most this many steps in all (None: until `episodes`)
    noise: float = 0.0
    seed: int = 0
    laps: int = 1
    action_repeat: int = validate.DATASET_ACTION_REPEAT
    env_options: dict[str, Any] = field(default_factory=dict)  # more of the env's options (tests: spares=0)

    def env_kwargs(self) -> dict[str, Any]:
        return {"track": list(self.tracks), "car": list(self.cars), "grid_position": list(self.grid),
                "opponents": list(self.opponents), "teacher": self.robot, "laps": self.laps,
                "action_repeat": self.action_repeat, **self.env_options}

    def episode_options(self) -> Iterator[dict[str, Any]]:
        """Each episode's track, car and grid slot, round the lists in turn."""
        for track, car, slot in itertools.cycle(itertools.product(self.tracks, self.cars, self.grid)):
            yield {"track": track, "car": car, "grid_position": slot}


def datasets_root(root: Path | None) -> Path:
    """The Minari datasets folder: `root`, else Minari's own (MINARI_DATASETS_PATH, else
    ~/.minari/datasets), checked as an output folder; Minari checked installed."""
    try:
        import minari  # noqa: F401
    except ImportError:
        raise UsageError("boxbox dataset writes Minari datasets and minari is not installed: install boxbox's data "
                         "extra (./boxbox installs it; pip install 'boxbox[data]')") from None
    if root is None:
        root = Path(os.environ.get(MINARI_ROOT) or Path.home() / ".minari" / "datasets")
    return validate.output_dir(root, name="dir")


def dataset_place(root: Path, dataset_id: str, replace: bool) -> Path:
    """Where the dataset goes (ROOT/ID), checked: a valid Minari id; nothing there, or with
    `replace` a Minari dataset (never a link, a file or another folder)."""
    from minari.dataset.minari_dataset import parse_dataset_id

    try:
        parse_dataset_id(dataset_id)
    except (ValueError, AttributeError, TypeError):
        raise UsageError(f"{dataset_id!r} is not a Minari dataset id; give [namespace/]name-vN, e.g. "
                         f"{DEFAULT_DATASET}") from None
    if ".." in dataset_id.split("/"):
        raise UsageError(f"{dataset_id!r} climbs out of the datasets folder; give [namespace/]name-vN")
    place = root / dataset_id
    if place.is_symlink() or (place.exists() and not place.is_dir()):
        raise UsageError(f"{place} is {'a link' if place.is_symlink() else 'not a folder'}; choose another dataset id")
    if place.exists():
        if not (place / "data" / "metadata.json").is_file():
            raise UsageError(f"{place} is a folder but not a Minari dataset; choose another dataset id")
        if not replace:
            raise UsageError(f"dataset {dataset_id} exists in {root}; give --replace to replace it, or another id")
    return place


def action_noise(rng: np.random.Generator, space: gymnasium.spaces.Box, noise: float) -> Callable[[np.ndarray],
                                                                                                np.ndarray]:
    """teacher action -> the action driven: plus N(0, noise x each column's half range), clipped."""
    half = (space.high - space.low) / 2.0

    def noisy(action: np.ndarray) -> np.ndarray:
        if not noise:
            return action
        return np.clip(action + rng.normal(0.0, noise, action.shape) * half, space.low, space.high).astype(np.float32)

    return noisy


def record_episode(env: gymnasium.Env, seed: int, options: dict, noisy: Callable[[np.ndarray], np.ndarray],
                   max_steps: int, on_step: Callable[[], None]):
    """One episode driven by the teacher (with noise), as Minari's EpisodeBuffer; cut at
    `max_steps` (truncated)."""
    from minari.data_collector import EpisodeBuffer

    obs, info = env.reset(seed=seed, options=options)
    observations, teacher, progress = [obs], [info["teacher_action"]], [0.0]
    steps: list[tuple[np.ndarray, float, bool, bool]] = []  # (action, reward, terminated, truncated)
    for _ in range(max_steps):
        action = noisy(info["teacher_action"])
        obs, reward, terminated, truncated, info = env.step(action)
        observations.append(obs)
        teacher.append(info["teacher_action"])
        progress.append(float(info["progress_m"]))  # (a list: Minari 0.5.4 cannot read a 1-D array back)
        steps.append((action, float(reward), terminated, truncated))
        on_step()
        if terminated or truncated:
            break
    actions, rewards, terminations, truncations = (list(column) for column in zip(*steps, strict=True))
    truncations[-1] = truncations[-1] or not terminations[-1]  # cut by the recording: no end of the MDP
    stacked = ({k: np.stack([o[k] for o in observations]) for k in observations[0]}
               if isinstance(observations[0], dict) else np.stack(observations))
    return EpisodeBuffer(seed=seed, options=options, observations=stacked, actions=np.stack(actions),
                         rewards=rewards, terminations=terminations, truncations=truncations,
                         infos={"teacher_action": np.stack(teacher), "progress_m": progress})


def record(rec: Recording, root: Path, replace: bool = False,
           on_step: Callable[[], None] = lambda: None) -> tuple[Path, int, int]:
    """Drive and write the dataset to ROOT/ID: (its folder, episodes, steps)."""
    import minari

    place = dataset_place(root, rec.dataset_id, replace)
    noise = validate.action_noise(rec.noise, name="noise")
    env = gymnasium.make("boxbox/TORCS-v0", **rec.env_kwargs())
    try:
        assert isinstance(env.action_space, gymnasium.spaces.Box)
        noisy = action_noise(np.random.default_rng(rec.seed), env.action_space, noise)
        buffers, steps = [], 0
        budget = rec.steps if rec.steps is not None else UNLIMITED
        for i, options in enumerate(rec.episode_options()):
            if (rec.episodes is not None and i >= rec.episodes) or steps >= budget:
                break
            left = budget - steps
            buffers.append(record_episode(env, rec.seed + i, options, noisy, left, on_step))
            steps += len(buffers[-1])
        root.mkdir(parents=True, exist_ok=True)
        with _building(root) as tmp, warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # Minari's advice to name an author and an eval env
            minari.create_dataset_from_buffers(
                rec.dataset_id, buffers, env=env, algorithm_name=f"robot {rec.robot} (boxbox dataset), noise {noise:g}",
                description=f"The boxbox robot {rec.robot} driving boxbox/TORCS-v0 on {', '.join(rec.tracks)} "
                            f"({', '.join(rec.cars)}); infos['teacher_action'] is its own action for each "
                            "observation, actions what the car was driven with.", data_format="arrow")
            _move_into_place(tmp, root, rec.dataset_id, place)
    finally:
        env.close()
    return place, len(buffers), steps


@contextlib.contextmanager
def _building(root: Path) -> Iterator[Path]:
    """A temporary datasets folder in ROOT for Minari to write in (MINARI_DATASETS_PATH while the
    block runs), removed at the end whatever happens."""
    tmp = Path(tempfile.mkdtemp(prefix=".boxbox-dataset-", dir=root))
    before = os.environ.get(MINARI_ROOT)
    os.environ[MINARI_ROOT] = str(tmp)
    try:
        yield tmp
    finally:
        if before is None:
            os.environ.pop(MINARI_ROOT, None)
        else:
            os.environ[MINARI_ROOT] = before
        shutil.rmtree(tmp, ignore_errors=True)


def _move_into_place(tmp: Path, root: Path, dataset_id: str, place: Path) -> None:
    """The finished dataset moved from the temporary folder to ROOT/ID (a dataset there, replaced),
    with its namespace's description when ROOT has none."""
    from minari.dataset.minari_dataset import parse_dataset_id

    namespace = parse_dataset_id(dataset_id)[0]
    if namespace is not None and not (root / namespace).exists():
        (root / namespace).mkdir(parents=True)
        described = tmp / namespace / "namespace_metadata.json"
        if described.is_file():
            shutil.copy2(described, root / namespace / described.name)
    place.parent.mkdir(parents=True, exist_ok=True)
    old = None
    if place.exists():
        old = tmp / ".replaced"
        os.rename(place, old)
    os.rename(tmp / dataset_id, place)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
