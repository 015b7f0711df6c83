"""Several learning cars in one TORCS race: a PettingZoo `ParallelEnv` (docs/gym.md).

    import boxbox.gym
    env = boxbox.gym.parallel_env(cars=2, track="g-track-1", opponents=["bt:2"])
    observations, infos = env.reset(seed=0)
    while env.agents:
        actions = {agent: env.action_space(agent).sample() for agent in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)

Agents `car_0` .. `car_{n-1}` are the Python cars, in grid order; each observes, acts, is rewarded and
ends as the single env's car does (the same options, spaces, reward and limits).  One `step` moves
every car `action_repeat` drive steps: the session (gym/multisession.py) answers all the cars' drive
calls of a simulation step together.  A car whose episode ends leaves `agents`; TORCS keeps it in
the race, braking, while the others go on.  When the race ends every car left ends with it;
`max_episode_steps` truncates every car left.  A seeded reset starts the grid anywhere along the lap
(car_0 at the drawn point) and drives each car's own launch (gym/start.py), as the single env does,
and counts the laps as the grid's race (gym/start.py's LapCount).
"""

from __future__ import annotations

import functools
from dataclasses import replace
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from boxbox import validate
from boxbox.errors import RaceError, UsageError
from boxbox.gym import reward as rw
from boxbox.gym.assists import Assists
from boxbox.gym.env import (
    DEFAULT_ACTION_REPEAT,
    MAX_ACTION_REPEAT,
    NeedsReset,
    checked_actions,
    checked_cpu,
    checked_reward,
    checked_step_timeout_s,
    race_config,
    step_ends,
)
from boxbox.gym.episodes import several
from boxbox.gym.multisession import Controls, MultiSession
from boxbox.gym.pixelobs import check_pixel_options
from boxbox.gym.race import STEP_TIMEOUT_S_DEFAULT, TorcsGone
from boxbox.gym.render import CAR_COLOURS, check_render_mode, render_fps
from boxbox.gym.sensors import SCR_TRACK_ANGLES_DEG, TrackEdges, opponent_sectors
from boxbox.gym.spaces import DEFAULT_ACTIONS, ActionReader, ObservationLayout, Observer, RaceScale, action_space
from boxbox.gym.start import GRID_START, LapCount, Start, draw_start, grid_to_start_m, lap_count
from boxbox.model import Car, State, Track
from boxbox.model.skill import SkillLevel
from boxbox.torcs import catalog, setup
from boxbox.torcs.paths import MAX_PYTHON_CARS
from boxbox.torcs.raceprep import RaceConfig

# TorcsEnv's options the parallel env does not take yet (each reset starts the same race afresh, placed by the seed)
SINGLE_ENV_ONLY = ("grid_position", "pit_fuel_l", "pit_repair", "spares", "sensor_noise")
ONE_RACE = ("track", "car", "opponents", "skill_level", "initial_fuel_l")  # one value each, not drawn


def refuse_single_env_options(given: dict[str, Any], unknown: dict[str, Any]) -> None:
    """A varied option or one of the single env's own is one line saying what to do; an option no
    env takes is Python's TypeError, as for any function."""
    for key, value in given.items():
        if several(key, value):
            validate.fail(f"{value!r:.60}: the parallel env races the same race at each reset; give one value "
                          "(varied episodes are boxbox/TORCS-v0's).", key)
    for key in unknown:
        if key in SINGLE_ENV_ONLY:
            validate.fail("the parallel env does not take it yet; leave it out (or drive one car per "
                          "boxbox/TORCS-v0 env, which takes it).", key)
        raise TypeError(f"parallel_env() got an unexpected keyword argument {key!r}")


class Racer:
    """One learning car's episode: its last state, its limits, its assists."""

    def __init__(self, robot: int, car: Car, assists: tuple[str, ...], limits: rw.Limits) -> None:
        self.robot, self.car = robot, car
        self.assists = Assists(assists, car)
        self.watch = rw.Watch(limits)
        self.state: State | None = None
        self.action: tuple[float, float, float, float, int, bool] = (0.0, 0.0, 0.0, 0.0, 1, False)
        self.start = GRID_START
        self.vector: np.ndarray | None = None  # the last observation in units (None with the pixels alone)

    def launching(self, step: int) -> Controls:
        """The controls of the start's launch at its drive step `step` (coasting after it)."""
        start = self.start
        self.action = ((start.launch_steer, start.launch_throttle, 0.0, 0.0, 1, False) if step < start.launch_steps
                       else (0.0, 0.0, 0.0, 0.0, 1, False))
        return self.controls()

    def controls(self) -> Controls:
        assert self.state is not None
        steer, throttle, brake, clutch, gear, _pit = self.action
        throttle, brake, gear = self.assists.apply(self.state, throttle, brake, gear)
        return steer, throttle, brake, clutch, gear, False


class TorcsParallelEnv(ParallelEnv):
    """`cars` learning cars in one TORCS race (PettingZoo's parallel API); TORCS's robots as opponents."""

    metadata = {"name": "boxbox_torcs_v0", "render_modes": ["rgb_array"], "render_fps": 50.0,
                "is_parallelizable": True}

    def __init__(self, cars: int = 2, track: str = "g-track-1", car: str = "car1-trb1", opponents=(), laps: int = 1,
                 *, action_repeat: int = DEFAULT_ACTION_REPEAT, actions: tuple[str, ...] = DEFAULT_ACTIONS,
                 assists: tuple[str, ...] = ("gears",), flat: bool = False,
                 track_sensor_angles_deg: tuple[float, ...] = SCR_TRACK_ANGLES_DEG,
                 reward_fn: rw.RewardFn | None = None, reward_weights: rw.RewardWeights | None = None,
                 max_damage: float | None = None, off_track_s: float | None = 2.0, stuck_s: float | None = 5.0,
                 skill_level: str | SkillLevel = "semi-pro", initial_fuel_l: float | None = None,
                 cpu: int | None = None, render_mode: str | None = None, pixels: bool = False,
                 pixel_size: tuple[int, int] | None = None, step_timeout_s: float = STEP_TIMEOUT_S_DEFAULT,
                 random_start: bool = True, raw_observations: bool = False, max_episode_steps: int | None = None,
                 pixels_only: bool = True, dashboard: bool = False, view_ahead_m: float | None = None,
                 **single_env_only: Any) -> None:
        refuse_single_env_options(dict(zip(ONE_RACE, (track, car, opponents, skill_level, initial_fuel_l),
                                           strict=True)), single_env_only)
        n = validate.whole_number(cars, 1, MAX_PYTHON_CARS, name="cars")
        self.actions, self.assist_names = checked_actions(actions, assists)
        if "pit" in self.actions:
            validate.fail("the parallel env does not drive pit stops yet; leave 'pit' out of the actions.", "actions")
        self.action_repeat = validate.whole_number(action_repeat, 1, MAX_ACTION_REPEAT, name="action_repeat")
        self.angles_deg = validate.angle_list(track_sensor_angles_deg, name="track_sensor_angles_deg")
        self.reward_fn, self.weights = checked_reward(reward_fn, reward_weights)
        self.limits = rw.Limits(max_damage, off_track_s, stuck_s)
        self.initial_fuel_l = (None if initial_fuel_l is None else
                               validate.finite_number(initial_fuel_l, 0, 1000.0, name="initial_fuel_l"))
        self.cpu = checked_cpu(cpu)
        self.step_timeout_s = checked_step_timeout_s(step_timeout_s)
        flat = validate.flag(flat, name="flat")
        self.random_start = validate.flag(random_start, name="random_start")
        scaled = not validate.flag(raw_observations, name="raw_observations")
        self.max_episode_steps = (None if max_episode_steps is None else
                                  validate.whole_number(max_episode_steps, 1, None, name="max_episode_steps"))
        self.render_mode = check_render_mode(render_mode)
        self.metadata = {**self.metadata, "render_fps": render_fps(self.action_repeat)}
        # each car's view has its own dashboard; render()'s frame shows every car, so none
        self.look = check_pixel_options(pixels, pixel_size, pixels_only, dashboard, view_ahead_m, self.render_mode,
                                        frames_have_dashboard=False)
        self.pixels = self.look.size is not None
        self.drawing = self.look.drawing()
        self.cfg = race_config(track, car, opponents, laps, skill_level, cars=n)
        self.layout = ObservationLayout.make(len(self.angles_deg))
        self.observer = Observer(self.layout, flat, scaled)
        self.possible_agents = [f"car_{i}" for i in range(n)]
        self.agents: list[str] = []
        self.observation_spaces = dict.fromkeys(self.possible_agents, self.look.space(self.layout.space(flat, scaled)))
        self.action_spaces = dict.fromkeys(self.possible_agents, action_space(self.actions))
        self.reader = ActionReader(self.actions)
        self.session: MultiSession | None = None
        self.track: Track | None = None
        self.edges: TrackEdges | None = None
        self.racers: dict[str, Racer] = {}
        self.np_random: np.random.Generator | None = None  # seeded by reset(seed=...), as Gymnasium's envs
        self.length_m: float | None = None  # the track's, from its first race (a start along it needs it)
        self.steps = 0  # env steps of the episode (max_episode_steps)
        self.colour_of: dict[int, tuple[int, int, int]] = {}  # TORCS car index -> colour

    @functools.cache  # noqa: B019  (PettingZoo asks for the same object each time)
    def observation_space(self, agent: str) -> spaces.Space:
        return self.observation_spaces[agent]

    @functools.cache  # noqa: B019
    def action_space(self, agent: str) -> spaces.Space:
        return self.action_spaces[agent]

    # --- the PettingZoo API --------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        """A fresh race past the start countdown, the grid where the seed puts it, each car's launch
        driven (`options` changes nothing: PettingZoo's own test passes options it does not know)."""
        if seed is not None or self.np_random is None:
            self.np_random, _ = seeding.np_random(seed)
        starts = [draw_start(self.np_random) if self.random_start else GRID_START for _ in self.possible_agents]
        if self.session is None:
            self.session = MultiSession(self.cfg, setup.ensure_ready(), cpu=self.cpu,
                                        initial_fuel_l=self.initial_fuel_l, step_timeout_s=self.step_timeout_s)
        with self.session.pin:
            laps = self._start(starts)
        self.agents = list(self.possible_agents)
        self.steps = 0
        for racer in self.racers.values():
            racer.watch.reset(laps)  # the laps as the race's start counts them (gym/start.py)
        obs = {name: self._observation(name) for name in self.agents}
        return obs, {name: self._info(name, {"start": self.racers[name].start}) for name in self.agents}

    def step(self, actions: dict[str, Any]):
        if self.session is None or not self.racers:
            raise NeedsReset("call reset() before step()")
        live = list(self.agents)
        if not live:  # every car's episode has ended: nothing moves (PettingZoo's envs, SuperSuit's wrappers)
            return {}, {}, {}, {}, {}
        unknown = sorted(str(name) for name in actions if name not in self.racers)
        for name in live:
            if name not in actions or unknown:
                raise UsageError(f"no action for {name}; give one action for each of env.agents ({', '.join(live)})"
                                 if not unknown else f"no car is called {', '.join(unknown)}; the cars are "
                                 f"{', '.join(self.possible_agents)}")
            self.racers[name].action = self.reader.read(actions[name])  # the ended cars' actions are ignored
        with self.session.pin:
            totals, progress, reasons, fault = self._drive(live)
        self.steps += 1
        over = self.max_episode_steps is not None and self.steps >= self.max_episode_steps
        obs = {name: self._observation(name) for name in live}
        ends = {name: step_ends(reasons[name]) for name in live}
        if over:  # every car still going is truncated
            ends = {name: (term, trunc or not term) for name, (term, trunc) in ends.items()}
        infos = {name: self._info(name, {"progress_m": progress[name], "termination": reasons[name], "fault": fault})
                 for name in live}
        self.agents = [name for name in live if not any(ends[name])]
        return (obs, totals, {name: end[0] for name, end in ends.items()},
                {name: end[1] for name, end in ends.items()}, infos)

    def render(self) -> np.ndarray | None:
        """With render_mode="rgb_array", the race from above: each learning car in its own colour
        (car_0 red, car_1 blue, ...), TORCS's robots in the colours after them."""
        if self.render_mode is None or not self.racers:
            return None
        # the latest state of any car has every car where it is now (a car whose episode ended is not followed)
        latest = max(self.racers.values(), key=lambda r: r.state.sim_time_s if r.state is not None else -1e9)
        return self.drawing.frame(latest.state, latest.car, self._colour(latest.car.car_index), self._colour)

    def close(self) -> None:
        if self.session is not None:
            self.session.close()
            self.session = None
        self.agents = []

    @property
    def torcs_pid(self) -> int | None:
        return self.session.pid if self.session is not None else None

    # --- pieces --------------------------------------------------------------------------------
    def _start(self, starts: list[Start]) -> LapCount:
        """The race with the grid where car_0's start puts it (a track not raced yet raced once on
        its grid first, to learn its length), then each car's launch; the laps as that start counts them."""
        cfg = self.cfg
        if starts[0].fraction is not None and not catalog.track_sets_grid(cfg.track):
            if self.length_m is None:
                self._start_race(cfg)
            assert self.length_m is not None
            cfg = replace(cfg, grid_to_start_m=grid_to_start_m(starts[0].fraction, self.length_m, 0,
                                                               len(cfg.robots) + len(cfg.opponents)))
        self._start_race(cfg)
        for racer, start in zip(self.racers.values(), starts, strict=True):
            racer.start = start
        self._launch(max(start.launch_steps for start in starts))
        return lap_count(cfg.laps, cfg.grid_to_start_m)

    def _start_race(self, cfg: RaceConfig) -> None:
        """A fresh race past TORCS's start countdown: its racers at their first states."""
        assert self.session is not None
        error = ""
        for _attempt in range(2):  # a TORCS that fails to start once is tried once more
            try:
                track, cars, first = self.session.start_all(cfg)
                states: dict[int, State] | None = first
                if track is not self.track:
                    self._new_track(track)
                self.observer.use(RaceScale.of(track.length_m, cars[0], cfg.laps))
                self.racers = {f"car_{i}": Racer(i, car, self.assist_names, self.limits) for i, car in enumerate(cars)}
                self._colours(cars, first)
                while states is not None and min(s.sim_time_s for s in states.values()) < 0.0:
                    states = self.session.drive_all({})  # cars left out brake: the countdown
                if states is not None and len(states) == len(cars):
                    for racer in self.racers.values():
                        racer.state = states[racer.robot]
                    return
                error = "the race ended before it started"
            except TorcsGone as exc:
                error = str(exc)
        raise RaceError(f"TORCS could not start the race ({self.cfg.track}, {self.cfg.car}): {error}")

    def _launch(self, steps: int) -> None:
        """The cars' launches, `steps` drive steps (a car past its own launch coasts)."""
        assert self.session is not None
        for step in range(steps):
            states = self.session.drive_all({r.robot: r.launching(step) for r in self.racers.values()})
            if states is None:
                raise RaceError(f"the race ({self.cfg.track}) ended in the cars' launch")
            for racer in self.racers.values():
                racer.state = states.get(racer.robot, racer.state)

    def _info(self, name: str, more: dict[str, Any]) -> dict[str, Any]:
        """A car's info: its state, its observation in units (not with the pixels alone) and `more`."""
        racer = self.racers[name]
        info = {"state": racer.state, **more}
        if racer.vector is not None:
            info["raw_observation"] = self.observer.shaped(racer.vector)
        return info

    def _new_track(self, track: Track) -> None:
        self.track = track
        self.length_m = float(track.length_m)
        self.edges = TrackEdges(track, self.angles_deg)
        if self.render_mode is not None or self.pixels:
            self.drawing.new_track(track)

    def _colours(self, cars: list[Car], states: dict[int, State]) -> None:
        """Each car's colour by TORCS's car index: the learning cars first, then the robots."""
        self.colour_of = {car.car_index: CAR_COLOURS[i % len(CAR_COLOURS)] for i, car in enumerate(cars)}
        others = sorted({int(o.car_index) for s in states.values() for o in s.opponents} - set(self.colour_of))
        for k, index in enumerate(others, start=len(cars)):
            self.colour_of[index] = CAR_COLOURS[k % len(CAR_COLOURS)]

    def _colour(self, car_index: int) -> tuple[int, int, int]:
        return self.colour_of.get(car_index, CAR_COLOURS[-1])

    def _drive(self, live: list[str]) -> tuple[dict[str, float], dict[str, float], dict[str, str | None], str | None]:
        """`action_repeat` drive steps of every live car: each one's reward, progress and why its
        episode ended (None: it goes on), and what went wrong (None)."""
        assert self.session is not None
        totals, progress = dict.fromkeys(live, 0.0), dict.fromkeys(live, 0.0)
        reasons: dict[str, str | None] = dict.fromkeys(live)
        fault = None
        length = float(self.track.length_m) if self.track is not None else 1.0
        for _ in range(self.action_repeat):
            going = [name for name in live if reasons[name] is None]
            if not going:
                break
            try:
                states = self.session.drive_all({self.racers[n].robot: self.racers[n].controls() for n in going})
            except TorcsGone as exc:
                states, fault = None, str(exc)
            for name in going:
                racer = self.racers[name]
                before = racer.state
                nxt = None if states is None else states.get(racer.robot)
                if nxt is None:  # the race ended, TORCS is gone, or TORCS no longer drives the car
                    reasons[name] = rw.FAULT if fault else (rw.RACE_END if states is None else rw.OUT)
                    continue
                assert before is not None
                p = rw.progress_m(before, nxt, length)
                progress[name] += p
                totals[name] += self._reward(before, nxt, p)
                racer.state = nxt
                reasons[name] = racer.watch.update(nxt)
        return totals, progress, reasons, fault

    def _reward(self, before: State, after: State, progress: float) -> float:
        if self.reward_fn is not None:
            return float(self.reward_fn(before, after, {"progress_m": progress, "pit": False}))
        return rw.default_reward(before, after, progress, self.weights)

    def _observation(self, name: str):
        racer = self.racers[name]
        assert racer.state is not None
        s, numbers, image = racer.state, None, None
        if self.pixels:  # itself red, every other car blue
            image = self.drawing.observation(s, racer.car, steer=racer.action[0])
        if self.look.numbers:
            assert self.edges is not None
            racer.vector = self.observer.vector(s, self.edges.ranges(s), opponent_sectors(s),
                                                racer.watch.lap_count.added)
            numbers = self.observer.observation(racer.vector)
        return self.look.observation(image, numbers)


def parallel_env(cars: int = 2, **kwargs) -> TorcsParallelEnv:
    """`cars` learning cars in one TORCS race, as PettingZoo's own environments are made
    (`boxbox.gym.parallel_env(cars=4, track="g-track-1")`); the options are TorcsEnv's (docs/gym.md)."""
    return TorcsParallelEnv(cars=cars, **kwargs)
