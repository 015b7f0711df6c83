"""`boxbox/TORCS-v0`: a Gymnasium environment on stock TORCS, the env being the robot.

    env = gymnasium.make("boxbox/TORCS-v0", track="g-track-1", opponents=["bt:2"], laps=1)

Each `reset` starts a fresh race (a new TORCS process: a spare made ready while the last episode
ran, gym/spare.py, or one started then, ~25 ms), its track, car and the rest drawn from the options
(gym/episodes.py); each `step` answers the pending drive call with the action's controls and
returns at the next one (`action_repeat` drive calls of 0.02 s each with the same action: by
default 5, a decision every 0.1 s).  A seeded reset starts the car anywhere along the lap
(gym/start.py); the observations are scaled to [-1, 1] (their units in `info["raw_observation"]`).
Spaces: gym/spaces.py; reward and termination: gym/reward.py; sensors: gym/sensors.py;
docs/gym.md has it all with the figures.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import gymnasium
import numpy as np

from boxbox import validate
from boxbox.errors import RaceError, UsageError
from boxbox.gym import reward as rw
from boxbox.gym.assists import ASSISTS, Assists, check_assists
from boxbox.gym.cores import usable_cpus
from boxbox.gym.episodes import (
    Episode,
    Episodes,
    EpisodeStream,
    add_scr_noise,
    stream_seed,
)
from boxbox.gym.hosted import split_opponents
from boxbox.gym.pitstop import PitStop
from boxbox.gym.pixelobs import check_pixel_options
from boxbox.gym.race import MAX_STEP_TIMEOUT_S, STEP_TIMEOUT_S_DEFAULT, RaceOrder, Started, TorcsGone
from boxbox.gym.render import check_render_mode, render_fps
from boxbox.gym.sensors import SCR_TRACK_ANGLES_DEG, TrackEdges, opponent_sectors
from boxbox.gym.session import Session
from boxbox.gym.spaces import (
    ACTION_RANGES,
    DEFAULT_ACTIONS,
    PEDALS,
    ActionReader,
    ObservationLayout,
    Observer,
    RaceScale,
    action_space,
)
from boxbox.gym.spare import MAX_SPARES
from boxbox.gym.start import Start, grid_to_start_m, lap_count
from boxbox.gym.teacher import Teacher, teacher_spec
from boxbox.model import Car, PitOrder, State, Track
from boxbox.model.skill import SkillLevel
from boxbox.torcs import catalog, setup
from boxbox.torcs.checks import check_grid_position, check_race
from boxbox.torcs.raceprep import RaceConfig

MAX_ACTION_REPEAT = 1000  # 20 s of simulated time per step
# a decision every 0.1 s (5 drive steps): a lap of g-track-1 at the shipped robot's pace (41 s) is
# ~400 decisions instead of ~2,000 (docs/gym.md, "Defaults that learn")
DEFAULT_ACTION_REPEAT = 5
MAX_FUEL_L = 1000.0  # beyond any car's tank
MAX_REPAIR = 100_000.0  # damage points (the car is out at 10000)
DEFAULT_SPARES = 1  # spare races made ready ahead (docs/gym.md: one keeps resets at a few ms)


class NeedsReset(UsageError, gymnasium.error.ResetNeeded):
    """step() with no episode running (before the first reset(), or after the episode ended), as
    Gymnasium's own envs refuse it: catchable as gymnasium.error.ResetNeeded or boxbox's UsageError."""


def race_config(track: str, car: str, opponents, laps: int, skill_level: str | SkillLevel,
                grid_position: int | str | None = None, cars: int = 1) -> RaceConfig:
    """The race the env drives (`cars` learning cars: 'gym', or 'car_0'.. for the parallel env),
    checked against the installed TORCS (set up first when needed): UsageError with one line when
    something is wrong."""
    track = validate.text(track, "track name", "g-track-1", name="track")
    car = validate.text(car, "car name", "car1-trb1", name="car")
    laps = validate.laps(laps, name="laps")
    entries = validate.opponent_list(opponents, name="opponents")
    if python_robots := split_opponents(entries)[1]:
        validate.fail(f"{python_robots[0]!r}: the parallel env races TORCS robots only ('bt:2'); a Python robot "
                      "races against boxbox/TORCS-v0's one car", "opponents")
    level = skill_level if isinstance(skill_level, SkillLevel) else SkillLevel.parse(
        validate.skill_level(skill_level, name="skill_level"))
    position = validate.grid_position(grid_position, name="grid_position")
    setup.ensure_ready()
    category, opps = check_race(track, car, cars, entries, laps=laps)
    names = ["gym"] if cars == 1 else [f"car_{i}" for i in range(cars)]
    return RaceConfig(track=track, category=category, car=car, laps=laps, robots=list(names), robot_names=names,
                      opponents=opps, telemetry=False, skill_level=level,
                      grid_position=check_grid_position(position, len(opps)))


def checked_actions(actions: Any, assists: Any) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The action columns (each at most once, at least one) and the assists (each at most once),
    checked together."""
    names = _chosen(actions, tuple(ACTION_RANGES), "actions", at_least_one=True)
    if "pedal" in names and any(p in names for p in PEDALS):
        validate.fail(f"{names!r}: 'pedal' is throttle and brake in one column; give 'pedal' or 'throttle' and "
                      "'brake', not both.", "actions")
    helpers = _chosen(assists, ASSISTS, "assists", at_least_one=False)
    check_assists(helpers, names)
    return names, helpers


def _chosen(value: Any, choices: tuple[str, ...], name: str, *, at_least_one: bool) -> tuple[str, ...]:
    """Names from `choices`, each at most once (a repeat is refused, not dropped: it says the
    caller meant something else)."""
    names = validate.names(value, name, unique=False, name=name)
    for one in names:
        validate.choice(one, choices, name=name)
    if len(set(names)) != len(names) or (at_least_one and not names):
        validate.fail(f"{tuple(names)!r}: choose each of the {name} at most once"
                      f"{', at least one' if at_least_one else ''}, from {', '.join(choices)}.", name)
    return tuple(names)


def checked_fuel(initial_fuel_l: Any, pit_fuel_l: Any, pit_repair: Any) -> tuple[float | None, ...]:
    """Litres at the start and at a pit stop, damage points repaired (None: the defaults)."""
    return (None if initial_fuel_l is None else validate.finite_number(initial_fuel_l, 0, MAX_FUEL_L,
                                                                       name="initial_fuel_l"),
            None if pit_fuel_l is None else validate.finite_number(pit_fuel_l, 0, MAX_FUEL_L, name="pit_fuel_l"),
            None if pit_repair is None else validate.finite_number(pit_repair, 0, MAX_REPAIR, name="pit_repair"))


def checked_cpu(cpu: Any) -> int | None:
    if cpu is None:
        return None
    core = validate.whole_number(cpu, 0, None, name="cpu")
    if core not in usable_cpus():
        validate.fail(f"{core} is not a core this process may use; choose one of {sorted(usable_cpus())}.", "cpu")
    return core


def checked_step_timeout_s(step_timeout_s: Any) -> float:
    """How long a step waits for TORCS before a silent TORCS is a fault (seconds, above 0)."""
    return validate.finite_number(step_timeout_s, 0, MAX_STEP_TIMEOUT_S, lo_open=True, name="step_timeout_s")


def step_ends(reason: str | None) -> tuple[bool, bool]:
    """(terminated, truncated) for why a car's episode ended.  The car's own endings (out, damage,
    off the track, stuck) terminate.  A fault (TORCS died or hung) is no state of the MDP, and the
    race's end is only where the laps it was given ran out (the car could drive on): both truncate,
    so a learner bootstraps from the last observation (terminated at the line, the states before it
    would be worth only the metres left to it)."""
    return reason in rw.CAR_ENDINGS, reason in (rw.FAULT, rw.RACE_END)


def checked_reward(reward_fn: Any, reward_weights: Any) -> tuple[rw.RewardFn | None, rw.RewardWeights]:
    if reward_fn is not None and not callable(reward_fn):
        validate.fail(f"{reward_fn!r} is not callable; give reward_fn(previous_state, state, info) -> float.",
                      "reward_fn")
    if reward_weights is not None and not isinstance(reward_weights, rw.RewardWeights):
        validate.fail(f"{reward_weights!r} is not a boxbox.gym.reward.RewardWeights.", "reward_weights")
    return reward_fn, reward_weights or rw.RewardWeights()


class TorcsEnv(gymnasium.Env):
    """One car in a TORCS race, driven by the agent; TORCS's robots as opponents."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50.0}  # render_fps: this env's own (action_repeat)

    def __init__(self, track: str = "g-track-1", car: str = "car1-trb1", opponents=(), laps: int = 1, *,
                 action_repeat: int = DEFAULT_ACTION_REPEAT, actions: tuple[str, ...] = DEFAULT_ACTIONS,
                 assists: tuple[str, ...] = ("gears",), flat: bool = False,
                 track_sensor_angles_deg: tuple[float, ...] = SCR_TRACK_ANGLES_DEG,
                 reward_fn: rw.RewardFn | None = None, reward_weights: rw.RewardWeights | None = None,
                 max_damage: float | None = None, off_track_s: float | None = 2.0, stuck_s: float | None = 5.0,
                 skill_level: str | SkillLevel = "semi-pro", grid_position: int | str | None = None,
                 initial_fuel_l: float | None = None, pit_fuel_l: float | None = None, pit_repair: float | None = None,
                 cpu: int | None = None, render_mode: str | None = None, pixels: bool = False,
                 pixel_size: tuple[int, int] | None = None, spares: int = DEFAULT_SPARES,
                 sensor_noise: bool = False, step_timeout_s: float = STEP_TIMEOUT_S_DEFAULT,
                 random_start: bool = True, raw_observations: bool = False, pixels_only: bool = True,
                 dashboard: bool = False, view_ahead_m: float | None = None,
                 teacher=None) -> None:
        # every option checked before anything is set up (validate.py: the command line's checks)
        self.actions, self.assist_names = checked_actions(actions, assists)
        self.action_repeat = validate.whole_number(action_repeat, 1, MAX_ACTION_REPEAT, name="action_repeat")
        self.angles_deg = validate.angle_list(track_sensor_angles_deg, name="track_sensor_angles_deg")
        self.reward_fn, self.weights = checked_reward(reward_fn, reward_weights)
        self.watch = rw.Watch(rw.Limits(max_damage, off_track_s, stuck_s))
        _, self.pit_fuel_l, self.pit_repair = checked_fuel(None, pit_fuel_l, pit_repair)
        self.cpu = checked_cpu(cpu)
        self.step_timeout_s = checked_step_timeout_s(step_timeout_s)
        self.spares = validate.whole_number(spares, 0, MAX_SPARES, name="spares")
        self.sensor_noise = validate.flag(sensor_noise, name="sensor_noise")
        flat = validate.flag(flat, name="flat")
        random_start = validate.flag(random_start, name="random_start")
        scaled = not validate.flag(raw_observations, name="raw_observations")
        # pixels (gym/render.py, gym/pixelobs.py): render() draws the race top-down; pixels=True observes the car's view
        self.render_mode = check_render_mode(render_mode)
        self.metadata = {**self.metadata, "render_fps": render_fps(self.action_repeat)}
        self.look = check_pixel_options(pixels, pixel_size, pixels_only, dashboard, view_ahead_m, self.render_mode)
        self.pixels = self.look.size is not None
        self.drawing = self.look.drawing()
        self.steer = 0.0  # the last action's (the dashboard's)
        self.episodes = Episodes(laps, random_start, track=track, car=car, opponents=opponents,
                                 grid_position=grid_position, skill_level=skill_level, initial_fuel_l=initial_fuel_l)
        self._stream: EpisodeStream | None = None  # the episodes drawn from the seed, from the first reset
        # a robot's own action for each state, in info["teacher_action"] (gym/teacher.py)
        spec = teacher_spec(teacher)
        self.teacher = Teacher(spec, self.actions, self.episodes.laps) if spec is not None else None
        self.episode: Episode | None = None  # the episode running
        self.cfg = self.episodes.config(self.episodes.first())  # the race running (until the first reset: the first's)
        self._edges: dict[int, tuple[Track, TrackEdges]] = {}  # by track (decoded once per session)
        self.layout = ObservationLayout.make(len(self.angles_deg))
        self.observer = Observer(self.layout, flat, scaled)
        self.observation_space = self.look.space(self.layout.space(flat, scaled))
        self.action_space = action_space(self.actions)
        self.reader = ActionReader(self.actions)
        self.session: Session | None = None
        self.track: Track | None = None  # the race's track and car, known from the first reset
        self.car: Car | None = None
        self.length_m = 0.0
        self.lengths: dict[str, float] = {}  # each track's, from its first race (a start along it needs it)
        self.state: State | None = None
        self.vector: np.ndarray | None = None  # None with the pixels alone
        self.edges: TrackEdges | None = None
        self.assists: Assists | None = None
        self.pit: PitStop | None = None
        self.ended: str | None = None  # why the episode ended (step() then needs a reset())

    # --- the Gymnasium API ---------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        chosen = self.episodes.explicit(options)  # an unknown key is refused here
        super().reset(seed=seed)
        if seed is not None or self._stream is None:
            self._stream = EpisodeStream(self.episodes, stream_seed(self.np_random))
        episode = replace(self._stream.next(), **chosen)
        self.episodes.config(episode)  # an unknown track given to reset() is refused here, before TORCS
        if self.session is None:
            self.session = Session(setup.ensure_ready(), cpu=self.cpu, on_pit=self._pit_order, spares=self.spares,
                                   step_timeout_s=self.step_timeout_s)
        self.ended = None
        with self.session.pin:
            order = self._order(episode)
            assert order is not None  # (learnt the length when it had to)
            upcoming = [o for o in (self._order(e, learn=False) for e in self._stream.peek(self.spares)) if o]
            started = self._start(order, upcoming)
        self.episode, self.cfg = episode, order.cfg
        self.watch.reset(lap_count(order.cfg.laps, order.cfg.grid_to_start_m))  # as the start counts (gym/start.py)
        self.state, self.steer = started.state, 0.0
        self.vector = self._vector(started.state)
        info = self._reset_info(order, started)
        if self.teacher is not None:
            self.teacher.new_race(started.track, started.car)
            info["teacher_action"] = self.teacher.action(started.state)
        return self._observation(), info

    def step(self, action):
        if self.state is None or self.session is None:
            raise NeedsReset("call reset() before step()")
        if self.ended is not None:
            raise NeedsReset(f"the episode has ended ({self.ended}); call reset() to start a new one")
        steer, throttle, brake, clutch, gear, pit = self.reader.read(action)
        self.steer = steer
        if self.pit is not None and pit:
            self.pit.request()
        with self.session.pin:
            s, total, progress, reason, fault = self._drive(steer, throttle, brake, clutch, gear)
            self.session.advance_spares()  # the next episode's race, one message further (never waits)
        if s is not self.state:
            self.state = s
            self.vector = self._vector(s) if self.look.numbers else None  # the view alone needs no range finders
        self.ended = reason
        info = {"state": s, "progress_m": progress, "termination": reason, "fault": fault}
        if self.vector is not None:
            info["raw_observation"] = self.observer.shaped(self.vector)
        if self.pit is not None:
            info["pit"] = self.pit.phase
        if self.teacher is not None:
            info["teacher_action"] = self.teacher.action(s)
        return self._observation(), total, *step_ends(reason), info

    def _drive(self, steer: float, throttle: float, brake: float, clutch: float,
               gear: int) -> tuple[State, float, float, str | None, str | None]:
        """`action_repeat` drive steps with one action: (the last state, the reward, the progress,
        why the episode ended or None, what went wrong or None)."""
        assert self.session is not None and self.state is not None
        total, progress, reason, fault = 0.0, 0.0, None, None
        s = self.state
        for _ in range(self.action_repeat):
            controls, driving = self._controls(s, steer, throttle, brake, clutch, gear)
            try:
                nxt = self.session.drive(*controls)
            except TorcsGone as exc:
                reason, fault = rw.FAULT, str(exc)
                break
            if nxt is None:
                reason = rw.RACE_END
                break
            p = rw.progress_m(s, nxt, self.length_m)
            progress += p
            total += self._reward(s, nxt, p, driving)
            s = nxt
            reason = self.watch.update(nxt, excused=driving)
            if reason is not None:
                break
        return s, total, progress, reason, fault

    def render(self) -> np.ndarray | None:
        """With render_mode="rgb_array", the race seen from above (gym/render.py): the track, this car
        in red, every other car in blue; None without a render mode or before the first reset."""
        if self.render_mode is None:
            return None
        return self.drawing.frame(self.state, self.car, steer=self.steer)

    def close(self) -> None:
        if self.session is not None:
            self.session.close()
            self.session = None
        self.state = None
        self.ended = None

    @property
    def torcs_pid(self) -> int | None:
        """TORCS's process id while a race runs (for supervisors and tests)."""
        return self.session.pid if self.session is not None else None

    # --- pieces --------------------------------------------------------------------------------
    def _order(self, episode: Episode, learn: bool = True) -> RaceOrder | None:
        """The episode's race, its grid placed for the episode's start.  A start along a track not
        raced yet needs its length: raced once on its grid to learn it, or (`learn` off) None."""
        cfg = self.episodes.config(episode)
        if episode.start.fraction is not None and not catalog.track_sets_grid(cfg.track):
            length_m = self.lengths.get(cfg.track)
            if length_m is None:
                if not learn:
                    return None
                length_m = self._learn_length(cfg)
            slot = (cfg.grid_position or 1) - 1
            cfg = replace(cfg, grid_to_start_m=grid_to_start_m(episode.start.fraction, length_m, slot,
                                                               len(cfg.robots) + len(cfg.opponents)))
        return RaceOrder(episode, cfg, episode.initial_fuel_l, episode.start)

    def _learn_length(self, cfg: RaceConfig) -> float:
        """A track's length, from a race on its grid (TORCS sends the track at the race's start)."""
        assert self.session is not None
        self._start(RaceOrder(("length", cfg.track, cfg.car), cfg), None)  # the spares kept
        return self.lengths[cfg.track]

    def _start(self, order: RaceOrder, upcoming: list[RaceOrder] | None) -> Started:
        """The episode's race past TORCS's start countdown (the car cannot move before) and the
        start's launch (driven in the race's set-up: a spare has driven it ahead)."""
        assert self.session is not None
        for _attempt in range(2):  # a TORCS that fails to start once is tried once more
            try:
                started = self.session.start(order, upcoming)
                self._new_race(started, order.cfg)
                if self.pit is not None:
                    self.pit.reset()
                return started
            except TorcsGone as exc:
                error = str(exc)
        raise RaceError(f"TORCS could not start the race ({order.cfg.track}, {order.cfg.car}): {error}")

    def _new_race(self, started: Started, cfg: RaceConfig) -> None:
        """What the race's track and car decide, rebuilt only when they change."""
        self.lengths[cfg.track] = float(started.track.length_m)
        self.observer.use(RaceScale.of(started.track.length_m, started.car, cfg.laps))
        car_changed = started.car != self.car
        if started.track is not self.track:
            self.track = started.track
            self.length_m = float(started.track.length_m)
            if id(started.track) not in self._edges:
                self._edges[id(started.track)] = (started.track, TrackEdges(started.track, self.angles_deg))
            self.edges = self._edges[id(started.track)][1]
            if self.render_mode is not None or self.pixels:
                self.drawing.new_track(started.track)
            car_changed = True  # the pit stop is the track's too
        self.car = started.car
        if car_changed:
            self.assists = Assists(self.assist_names, started.car)
            self.pit = PitStop.for_car(started.track, started.car) if "pit" in self.actions else None

    def _reset_info(self, order: RaceOrder, started: Started) -> dict[str, Any]:
        """What reset() returns in info: the first state and what the episode's race is."""
        cfg = order.cfg
        return {"state": started.state, "track": cfg.track, "track_length_m": float(started.track.length_m),
                "car": cfg.car, "opponents": (*(f"{m}:{i}" for m, i in cfg.opponents), *cfg.robots[1:]),
                "grid_position": cfg.grid_position or 1, "skill_level": cfg.skill_level.torcs_name,
                "initial_fuel_l": float(started.state.fuel_l), "spare": started.spare,
                "start": self.episode.start if self.episode is not None else Start(),
                **({"raw_observation": self.observer.shaped(self.vector)} if self.vector is not None else {})}

    def _observation(self):
        """The numbers (Dict or flat), the car's view, or both in one Dict (gym/pixelobs.py)."""
        assert self.state is not None and self.car is not None
        image = self.drawing.observation(self.state, self.car, steer=self.steer) if self.pixels else None
        numbers = self.observer.observation(self.vector) if self.look.numbers and self.vector is not None else None
        return self.look.observation(image, numbers)

    def _vector(self, s: State) -> np.ndarray:
        assert self.edges is not None
        ranges, sectors = self.edges.ranges(s), opponent_sectors(s)
        if self.sensor_noise:
            ranges, sectors = add_scr_noise(self.np_random, ranges, sectors)
        return self.observer.vector(s, ranges, sectors, self.watch.lap_count.added)  # as the grid's race counts

    def _controls(self, s: State, steer: float, throttle: float, brake: float, clutch: float,
                  gear: int) -> tuple[tuple, bool]:
        """The drive step's controls after the assists, or the pit stop's while it drives."""
        assert self.assists is not None
        if self.pit is not None and self.pit.active(s):
            return self.pit.controls(s), True
        throttle, brake, gear = self.assists.apply(s, throttle, brake, gear)
        return (steer, throttle, brake, clutch, gear, False), False

    def _reward(self, before: State, after: State, progress: float, pit: bool) -> float:
        if self.reward_fn is not None:
            return float(self.reward_fn(before, after, {"progress_m": progress, "pit": pit}))
        return rw.default_reward(before, after, progress, self.weights, pit)

    def _pit_order(self, state: State) -> PitOrder:
        if self.pit is None:
            return PitOrder()
        return self.pit.order(state, self.pit_fuel_l, self.pit_repair)
