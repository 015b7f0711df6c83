"""`boxbox/TORCS-v0`: a Gymnasium environment on stock TORCS, the env being the robot.

    env = gymnasium.make("boxbox/TORCS-v0", track="g-track-1", opponents=["bt:2"], laps=1)

Each `reset` starts a fresh race (a new TORCS process, ~20 ms); each `step` answers the pending
drive call with the action's controls and returns at the next one (`action_repeat` drive calls
of 0.02 s each with the same action).  Spaces: gym/spaces.py; reward and termination:
gym/reward.py; sensors: gym/sensors.py; docs/gym.md has it all with the figures.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np

from boxbox.errors import RaceError, UsageError
from boxbox.gym import reward as rw
from boxbox.gym.assists import Assists, check_assists
from boxbox.gym.pitstop import PitStop
from boxbox.gym.sensors import SCR_TRACK_ANGLES_DEG, TrackEdges, opponent_sectors
from boxbox.gym.session import Session, TorcsGone, usable_cpus
from boxbox.gym.spaces import ACTION_RANGES, DEFAULT_ACTIONS, ActionReader, ObservationLayout, Observer, action_space
from boxbox.model import Car, PitOrder, State, Track
from boxbox.model.skill import SkillLevel
from boxbox.torcs import setup
from boxbox.torcs.checks import check_race
from boxbox.torcs.launch import RaceConfig


def race_config(track: str, car: str, opponents, laps: int, skill_level: str,
                grid_position: int | None) -> RaceConfig:
    """The race the env drives, checked against the installed TORCS (set up first when needed):
    UsageError with one line when something is wrong."""
    if not isinstance(laps, int) or isinstance(laps, bool) or laps < 1:
        raise UsageError(f"laps={laps!r} must be a whole number >= 1")
    try:
        level = SkillLevel.parse(skill_level)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    setup.ensure_ready()
    entries = [o if isinstance(o, str) else f"{o[0]}:{o[1]}" for o in opponents]
    category, opps = check_race(track, car, 1, entries, laps=laps)
    return RaceConfig(track=track, category=category, car=car, laps=laps, robots=["gym"], robot_names=["gym"],
                      opponents=opps, telemetry=False, skill_level=level, grid_position=grid_position)


class TorcsEnv(gymnasium.Env):
    """One car in a TORCS race, driven by the agent; TORCS's robots as opponents."""

    metadata = {"render_modes": []}

    def __init__(self, track: str = "g-track-1", car: str = "car1-trb1", opponents=(), laps: int = 1, *,
                 action_repeat: int = 1, actions: tuple[str, ...] = DEFAULT_ACTIONS,
                 assists: tuple[str, ...] = ("gears",), flat: bool = False,
                 track_sensor_angles_deg: tuple[float, ...] = SCR_TRACK_ANGLES_DEG,
                 reward_fn: rw.RewardFn | None = None, reward_weights: rw.RewardWeights | None = None,
                 max_damage: float | None = None, off_track_s: float | None = 2.0, stuck_s: float | None = 5.0,
                 skill_level: str = "semi-pro", grid_position: int | None = None,
                 initial_fuel_l: float | None = None, pit_fuel_l: float | None = None, pit_repair: float | None = None,
                 cpu: int | None = None, render_mode: str | None = None) -> None:
        self.cfg = race_config(track, car, opponents, laps, skill_level, grid_position)
        self.actions, self.assist_names = tuple(actions), tuple(assists)
        unknown = [a for a in self.actions if a not in ACTION_RANGES]
        if unknown or not self.actions or len(set(self.actions)) != len(self.actions):
            raise UsageError(f"actions {self.actions!r}: choose each at most once from {', '.join(ACTION_RANGES)}")
        check_assists(self.assist_names, self.actions)
        if not isinstance(action_repeat, int) or action_repeat < 1:
            raise UsageError(f"action_repeat={action_repeat!r} must be a whole number >= 1")
        if cpu is not None and cpu not in usable_cpus():
            raise UsageError(f"cpu={cpu!r} is not a core this process may use; choose one of {sorted(usable_cpus())}")
        self.action_repeat = action_repeat
        self.render_mode = render_mode  # accepted (tools pass "rgb_array"), but TORCS runs without a display
        self.angles_deg = tuple(float(a) for a in track_sensor_angles_deg)
        self.layout = ObservationLayout.make(len(self.angles_deg))
        self.observer = Observer(self.layout, flat)
        self.observation_space = self.layout.flat_space() if flat else self.layout.dict_space()
        self.action_space = action_space(self.actions)
        self.reward_fn, self.weights = reward_fn, reward_weights or rw.RewardWeights()
        self.watch = rw.Watch(rw.Limits(max_damage, off_track_s, stuck_s))
        self.initial_fuel_l, self.cpu = initial_fuel_l, cpu
        self.pit_fuel_l, self.pit_repair = pit_fuel_l, pit_repair
        self.reader = ActionReader(self.actions)
        self.session: Session | None = None
        self.track: Track | None = None  # the race's track and car, known from the first reset
        self.car: Car | None = None
        self.length_m = 0.0
        self.state: State | None = None
        self.vector: np.ndarray | None = None
        self.edges: TrackEdges | None = None
        self.assists: Assists | None = None
        self.pit: PitStop | None = None

    # --- the Gymnasium API ---------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        if self.session is None:
            self.session = Session(self.cfg, setup.ensure_ready(), cpu=self.cpu, initial_fuel_l=self.initial_fuel_l,
                                   on_pit=self._pit_order)
        state = self._start()
        self.watch.reset()
        self.state = state
        self.vector = self._vector(state)
        return self.observer.observation(self.vector), {"state": state}

    def step(self, action):
        if self.state is None or self.session is None:
            raise RuntimeError("call reset() before step()")
        steer, throttle, brake, clutch, gear, pit = self.reader.read(action)
        if self.pit is not None and pit:
            self.pit.request()
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
        if s is not self.state:
            self.state = s
            self.vector = self._vector(s)
        info = {"state": s, "progress_m": progress, "termination": reason, "fault": fault}
        if self.pit is not None:
            info["pit"] = self.pit.phase
        return self.observer.observation(self.vector), total, reason is not None, False, info

    def render(self) -> None:
        """Nothing to show: TORCS runs in console mode (the race's state is in `info`)."""
        return None

    def close(self) -> None:
        if self.session is not None:
            self.session.close()
            self.session = None
        self.state = None

    @property
    def torcs_pid(self) -> int | None:
        """TORCS's process id while a race runs (for supervisors and tests)."""
        return self.session.pid if self.session is not None else None

    # --- pieces --------------------------------------------------------------------------------
    def _start(self) -> State:
        """A fresh race, past TORCS's start countdown (the car cannot move before 0 s)."""
        assert self.session is not None
        for _attempt in range(2):  # a TORCS that fails to start once is tried once more
            try:
                started = self.session.start()
                if started.track is not self.track:
                    self._new_track(started)
                state: State | None = started.state
                while state is not None and state.sim_time_s < 0.0:
                    state = self.session.drive(0.0, 0.0, 0.0, 0.0, 0, False)
                if state is not None:
                    if self.pit is not None:
                        self.pit.reset()
                    return state
                error = "the race ended before it started"
            except TorcsGone as exc:
                error = str(exc)
        raise RaceError(f"TORCS could not start the race ({self.cfg.track}, {self.cfg.car}): {error}")

    def _new_track(self, started) -> None:
        self.track, self.car = started.track, started.car
        self.length_m = float(started.track.length_m)
        self.edges = TrackEdges(started.track, self.angles_deg)
        self.assists = Assists(self.assist_names, started.car)
        self.pit = PitStop.for_car(started.track, started.car) if "pit" in self.actions else None

    def _vector(self, s: State) -> np.ndarray:
        assert self.edges is not None
        return self.observer.vector(s, self.edges.ranges(s), opponent_sectors(s))

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
