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
the race, braking, while the others go on.  When the race ends every car left ends with it.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from boxbox import validate
from boxbox.errors import RaceError, UsageError
from boxbox.gym import reward as rw
from boxbox.gym.assists import Assists
from boxbox.gym.env import (
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
from boxbox.gym.race import STEP_TIMEOUT_S_DEFAULT, TorcsGone
from boxbox.gym.render import CAR_COLOURS, Drawing, check_pixel_size, check_render_mode, pixel_space, render_fps
from boxbox.gym.sensors import SCR_TRACK_ANGLES_DEG, TrackEdges, opponent_sectors
from boxbox.gym.spaces import DEFAULT_ACTIONS, ActionReader, ObservationLayout, Observer, action_space
from boxbox.model import Car, State, Track
from boxbox.model.skill import SkillLevel
from boxbox.torcs import setup
from boxbox.torcs.paths import MAX_PYTHON_CARS

# TorcsEnv's options the parallel env does not take yet (each reset starts the same race afresh)
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
                 *, action_repeat: int = 1, actions: tuple[str, ...] = DEFAULT_ACTIONS,
                 assists: tuple[str, ...] = ("gears",), flat: bool = False,
                 track_sensor_angles_deg: tuple[float, ...] = SCR_TRACK_ANGLES_DEG,
                 reward_fn: rw.RewardFn | None = None, reward_weights: rw.RewardWeights | None = None,
                 max_damage: float | None = None, off_track_s: float | None = 2.0, stuck_s: float | None = 5.0,
                 skill_level: str | SkillLevel = "semi-pro", initial_fuel_l: float | None = None,
                 cpu: int | None = None, render_mode: str | None = None, pixels: bool = False,
                 pixel_size: tuple[int, int] | None = None, step_timeout_s: float = STEP_TIMEOUT_S_DEFAULT,
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
        self.render_mode = check_render_mode(render_mode)
        self.metadata = {**self.metadata, "render_fps": render_fps(self.action_repeat)}
        self.pixels = validate.flag(pixels, name="pixels")
        self.drawing = Drawing(check_pixel_size(pixel_size, self.pixels))
        self.cfg = race_config(track, car, opponents, laps, skill_level, cars=n)
        self.layout = ObservationLayout.make(len(self.angles_deg))
        self.observer = Observer(self.layout, flat)
        self.possible_agents = [f"car_{i}" for i in range(n)]
        self.agents: list[str] = []
        space = self.layout.flat_space() if flat else self.layout.dict_space()
        obs_space = pixel_space(self.drawing.pixel_size) if self.drawing.pixel_size is not None else space
        self.observation_spaces = dict.fromkeys(self.possible_agents, obs_space)
        self.action_spaces = dict.fromkeys(self.possible_agents, action_space(self.actions))
        self.reader = ActionReader(self.actions)
        self.session: MultiSession | None = None
        self.track: Track | None = None
        self.edges: TrackEdges | None = None
        self.racers: dict[str, Racer] = {}
        self.colour_of: dict[int, tuple[int, int, int]] = {}  # TORCS car index -> colour

    @functools.cache  # noqa: B019  (PettingZoo asks for the same object each time)
    def observation_space(self, agent: str) -> spaces.Space:
        return self.observation_spaces[agent]

    @functools.cache  # noqa: B019
    def action_space(self, agent: str) -> spaces.Space:
        return self.action_spaces[agent]

    # --- the PettingZoo API --------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        """A fresh race, past the start countdown.  `seed` and `options` change nothing yet (the race
        is deterministic; PettingZoo's own test passes options it does not know)."""
        if self.session is None:
            self.session = MultiSession(self.cfg, setup.ensure_ready(), cpu=self.cpu,
                                        initial_fuel_l=self.initial_fuel_l, step_timeout_s=self.step_timeout_s)
        with self.session.pin:
            states = self._start()
        self.agents = list(self.possible_agents)
        for racer in self.racers.values():
            racer.state = states[racer.robot]
            racer.watch.reset()
        return ({name: self._observation(name) for name in self.agents},
                {name: {"state": self.racers[name].state} for name in self.agents})

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
        obs = {name: self._observation(name) for name in live}
        ends = {name: step_ends(reasons[name]) for name in live}
        infos = {name: {"state": self.racers[name].state, "progress_m": progress[name],
                        "termination": reasons[name], "fault": fault} for name in live}
        self.agents = [name for name in live if reasons[name] is None]
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
    def _start(self) -> dict[int, State]:
        """A fresh race past TORCS's start countdown: each car's state by robot."""
        assert self.session is not None
        error = ""
        for _attempt in range(2):  # a TORCS that fails to start once is tried once more
            try:
                track, cars, first = self.session.start_all()
                states: dict[int, State] | None = first
                if track is not self.track:
                    self._new_track(track)
                self.racers = {f"car_{i}": Racer(i, car, self.assist_names, self.limits) for i, car in enumerate(cars)}
                self._colours(cars, first)
                while states is not None and min(s.sim_time_s for s in states.values()) < 0.0:
                    states = self.session.drive_all({})  # cars left out brake: the countdown
                if states is not None and len(states) == len(cars):
                    return states
                error = "the race ended before it started"
            except TorcsGone as exc:
                error = str(exc)
        raise RaceError(f"TORCS could not start the race ({self.cfg.track}, {self.cfg.car}): {error}")

    def _new_track(self, track: Track) -> None:
        self.track = track
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
        if self.pixels:
            return self.drawing.observation(racer.state, racer.car)  # itself red, every other car blue
        assert self.edges is not None
        s = racer.state
        return self.observer.observation(self.observer.vector(s, self.edges.ranges(s), opponent_sectors(s)))


def parallel_env(cars: int = 2, **kwargs) -> TorcsParallelEnv:
    """`cars` learning cars in one TORCS race, as PettingZoo's own environments are made
    (`boxbox.gym.parallel_env(cars=4, track="g-track-1")`); the options are TorcsEnv's (docs/gym.md)."""
    return TorcsParallelEnv(cars=cars, **kwargs)
