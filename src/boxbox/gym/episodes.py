"""Varied episodes: the race of each episode drawn from the env's options, and SCR's sensor noise.

Each of the options `track`, `car`, `opponents`, `grid_position`, `skill_level` and
`initial_fuel_l` takes one value (every episode the same), or the values to draw from:

- a list of values, drawn uniformly: `track=["g-track-1", "e-track-2"]` (for `opponents`, whose
  one value is itself a list, wrap the fields in `OneOf`);
- `OneOf(a, b, ..., weights=(wa, wb, ...))`, or a dict `{a: wa, b: wb}`: drawn with those weights;
- `Uniform(low, high)` for `initial_fuel_l`: litres drawn uniformly in [low, high].

With `random_start` each episode also draws where along the lap it starts (gym/start.py).
The draws come from a generator seeded from the env's `np_random` when `reset(seed=...)` seeds it
(`EpisodeStream`), one episode after another, so the same seed gives the same episodes, whatever
the sensor noise or the steps (drawn from `np_random` itself) consumed in between; the env draws
its next episodes ahead (their spare races are made while this one runs). `reset(options={...})`
chooses an episode's values explicitly, over the drawn ones.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from boxbox import validate
from boxbox.errors import UsageError
from boxbox.gym.hosted import split_opponents
from boxbox.gym.start import GRID_START, Start, draw_start
from boxbox.model.skill import SkillLevel
from boxbox.robot.base import RaceOptions
from boxbox.torcs import setup
from boxbox.torcs.checks import check_grid_position, check_race, check_robots
from boxbox.torcs.raceprep import RaceConfig

MAX_FUEL_L = 1000.0  # beyond any car's tank
# The SCR championship's noisy sensors (its server's scr_server.cpp: __NOISE_STD__, __OPP_NOISE_STD__):
# each reading is multiplied by a normal factor of mean 1, one per sensor and drive step
SCR_TRACK_NOISE = 0.1  # the range finders (not while the car is off the track: they read -1 then)
SCR_OPPONENT_NOISE = 0.02  # the opponent sectors
EPISODE_KEYS = ("track", "car", "opponents", "grid_position", "skill_level", "initial_fuel_l")


class OneOf:
    """One of `values`, drawn each episode: uniformly, or with `weights` (any positive numbers)."""

    def __init__(self, *values: Any, weights: Sequence[float] | None = None) -> None:
        self.values = values
        self.weights = weights

    def __repr__(self) -> str:
        return f"OneOf({', '.join(map(repr, self.values))}" + (f", weights={self.weights!r})" if self.weights else ")")


@dataclass(frozen=True)
class Uniform:
    """A number drawn uniformly in [low, high] each episode (`initial_fuel_l`)."""
    low: float
    high: float


@dataclass(frozen=True)
class Draw:
    """An option's candidates: values with probabilities, or a range of numbers."""
    values: tuple = ()
    p: tuple[float, ...] | None = None  # None: uniform
    span: tuple[float, float] | None = None  # Uniform(low, high)

    def pick(self, rng: np.random.Generator) -> Any:
        if self.span is not None:
            return float(rng.uniform(*self.span))
        if len(self.values) == 1:  # a fixed option draws nothing
            return self.values[0]
        return self.values[int(rng.choice(len(self.values), p=self.p))]

    @property
    def candidates(self) -> tuple:
        return self.span if self.span is not None else self.values


@dataclass(frozen=True)
class Episode:
    """One episode's race, as drawn (hashable: a spare race is made for it and matched by it)."""
    track: str
    car: str
    opponents: tuple[str, ...]
    grid_position: int | str | None
    skill_level: str
    initial_fuel_l: float | None
    start: Start = GRID_START  # where along the lap, and the launch (gym/start.py)


def parse_draw(value: Any, one: Callable[[Any], Any], name: str, *, list_is_one: bool = False,
               numbers: tuple[float, float] | None = None) -> Draw:
    """`value` as a Draw, each candidate checked with `one` (UsageError, one line, naming `name`)."""
    if isinstance(value, Uniform):
        if numbers is None:
            validate.fail(f"{value!r}: Uniform(low, high) is for numbers; give one value or a list.", name)
        low = validate.finite_number(value.low, *numbers, name=name)
        high = validate.finite_number(value.high, *numbers, name=name)
        if high < low:
            validate.fail(f"{value!r}: the range ends before it starts.", name)
        return Draw(span=(low, high))
    if isinstance(value, OneOf):
        return _weighted(value.values, value.weights, one, name)
    if isinstance(value, Mapping):
        return _weighted(tuple(value), tuple(value.values()), one, name)
    if isinstance(value, list | tuple | range) and not list_is_one:
        return _weighted(tuple(value), None, one, name)
    return Draw(values=(one(value),))


def _weighted(values: tuple, weights: Sequence[Any] | None, one: Callable[[Any], Any], name: str) -> Draw:
    if not values:
        validate.fail("nothing to draw from; give at least one value.", name)
    checked = tuple(one(v) for v in values)
    if weights is None:
        return Draw(values=checked)
    if isinstance(weights, str | bytes) or not hasattr(weights, "__len__") or len(weights) != len(values):
        validate.fail(f"{weights!r}: give one weight per value ({len(values)}).", name)
    w = [validate.finite_number(x, 0, None, name=name) for x in weights]
    if sum(w) <= 0:
        validate.fail(f"{tuple(weights)!r}: the weights add up to 0; give at least one above 0.", name)
    return Draw(values=checked, p=tuple(x / sum(w) for x in w))


def _level(value: Any) -> str:
    return value.torcs_name if isinstance(value, SkillLevel) else validate.skill_level(value, name="skill_level")


def _fuel(value: Any) -> float | None:
    return None if value is None else validate.finite_number(value, 0, MAX_FUEL_L, name="initial_fuel_l")


def _field(value: Any) -> tuple[str, ...]:
    """One field of opponents; a list of fields (a list of lists) is told to wrap them in OneOf."""
    try:
        return tuple(validate.opponent_list(value, name="opponents"))
    except UsageError as exc:
        if several("opponents", value):
            fields = ", ".join(map(repr, value))
            raise UsageError(f"{exc} A list of fields is one field here; to draw one of them per episode, wrap "
                             f"them in OneOf (boxbox.gym.episodes): opponents=OneOf({fields:.60})") from None
        raise


def several(key: str, value: Any) -> bool:
    """Whether `value` gives several candidates for the option `key` (drawn per episode)."""
    if isinstance(value, OneOf | Uniform | Mapping):
        return True
    if key == "opponents":
        return isinstance(value, list | tuple) and any(isinstance(v, list | tuple | range) and not _pair(v)
                                                       for v in value)
    return isinstance(value, list | tuple | range)


def _pair(value: Any) -> bool:
    """('bt', 2): one opponent as a pair, not a field."""
    return len(value) == 2 and isinstance(value[0], str) and not isinstance(value[1], str | list | tuple)


# the single-value check of each option (the env's checks, validate.py's words)
CHECKS: dict[str, Callable[[Any], Any]] = {
    "track": lambda v: validate.text(v, "track name", "g-track-1", name="track"),
    "car": lambda v: validate.text(v, "car name", "car1-trb1", name="car"),
    "opponents": _field,
    "grid_position": lambda v: validate.grid_position(v, name="grid_position"),
    "skill_level": _level,
    "initial_fuel_l": _fuel,
}


def check_reset_options(options: Any) -> None:
    """reset(options=...) takes the keys of EPISODE_KEYS: an unknown one is refused, not ignored."""
    if options is None:
        return
    if not isinstance(options, Mapping):
        validate.fail(f"{options!r} is not a dict of reset options.", "options")
    unknown = sorted(str(key) for key in options if key not in EPISODE_KEYS)
    if unknown:
        validate.fail(f"reset() does not take {', '.join(map(repr, unknown))} (reset options: "
                      f"{', '.join(EPISODE_KEYS)}).", "options")


class Episodes:
    """The env's episode options, checked (against the installed TORCS too), and the races they make."""

    def __init__(self, laps: int, random_start: bool = False, **options: Any) -> None:
        self.laps = validate.laps(laps, name="laps")
        self.random_start = random_start
        self.draws = {key: parse_draw(options[key], CHECKS[key], key, list_is_one=key == "opponents",
                                      numbers=(0, MAX_FUEL_L) if key == "initial_fuel_l" else None)
                      for key in EPISODE_KEYS}
        self._configs: dict[tuple, RaceConfig] = {}
        setup.ensure_ready()
        self._check_every_candidate()

    @property
    def varied(self) -> tuple[str, ...]:
        """The options drawn per episode."""
        return tuple(k for k, d in self.draws.items() if d.span is not None or len(d.values) > 1)

    def draw(self, rng: np.random.Generator) -> Episode:
        """The next episode: its options, then (with `random_start`) its start."""
        picked = {key: self.draws[key].pick(rng) for key in EPISODE_KEYS}
        return Episode(**picked, start=draw_start(rng) if self.random_start else GRID_START)

    def explicit(self, options: Any) -> dict[str, Any]:
        """reset(options=...)'s values, checked: one value per key (UsageError for an unknown key)."""
        check_reset_options(options)
        return {key: CHECKS[key](value) for key, value in (options or {}).items()}

    def config(self, episode: Episode) -> RaceConfig:
        """The episode's race, checked against the installed TORCS once (UsageError, one line)."""
        key = (episode.track, episode.car, episode.opponents, episode.grid_position, episode.skill_level)
        cfg = self._configs.get(key)
        if cfg is None:
            torcs_robots, python_robots = split_opponents(episode.opponents)  # (Python ones: gym/hosted.py)
            category, opps = check_race(episode.track, episode.car, 1 + len(python_robots), torcs_robots,
                                        laps=self.laps)
            names = check_robots(python_robots, RaceOptions(laps=self.laps), episode.track, episode.car) \
                if python_robots else []
            cfg = RaceConfig(track=episode.track, category=category, car=episode.car, laps=self.laps,
                             robots=["gym", *python_robots], robot_names=["gym", *names], opponents=opps,
                             telemetry=False,
                             skill_level=SkillLevel.parse(episode.skill_level),
                             grid_position=check_grid_position(episode.grid_position, len(opps)))
            self._configs[key] = cfg
        return cfg

    def first(self) -> Episode:
        """The first value of each option (a fuel range's low end)."""
        return Episode(**{key: d.candidates[0] for key, d in self.draws.items()})

    def _check_every_candidate(self) -> None:
        """Each track, car and field with the first of the others; each grid slot with each field."""
        base = self.first()
        for key in ("track", "car", "opponents", "skill_level"):
            for value in self.draws[key].values:
                self.config(replace(base, **{key: value}))
        for opponents in self.draws["opponents"].values:
            for slot in self.draws["grid_position"].values:
                self.config(replace(base, opponents=opponents, grid_position=slot))


class EpisodeStream:
    """The episodes one after another from one seeded generator, drawn ahead on demand."""

    def __init__(self, episodes: Episodes, rng: np.random.Generator) -> None:
        self.episodes = episodes
        self.rng = rng
        self.ahead: deque[Episode] = deque()

    def next(self) -> Episode:
        return self.ahead.popleft() if self.ahead else self.episodes.draw(self.rng)

    def peek(self, n: int) -> list[Episode]:
        """The next `n` episodes (drawn now, handed out later by `next`)."""
        while len(self.ahead) < n:
            self.ahead.append(self.episodes.draw(self.rng))
        return list(self.ahead)[:n]


def stream_seed(np_random: np.random.Generator) -> np.random.Generator:
    """The episodes' own generator, seeded from the env's when it is seeded."""
    return np.random.default_rng(int(np_random.integers(2**63)))


def add_scr_noise(rng: np.random.Generator, edges_m: np.ndarray, sectors_m: np.ndarray) -> tuple[np.ndarray, ...]:
    """SCR's noisy sensors: each range finder times N(1, 0.1) (only with the car on the track),
    each opponent sector times N(1, 0.02)."""
    if edges_m[0] >= 0.0:  # off the track every ray reads -1, noiseless as in SCR
        edges_m = edges_m * rng.normal(1.0, SCR_TRACK_NOISE, edges_m.shape)
    return edges_m, sectors_m * rng.normal(1.0, SCR_OPPONENT_NOISE, sectors_m.shape)

