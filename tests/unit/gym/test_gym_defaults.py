"""The env's defaults that learn, on plain numbers: the scaled observations, the one pedal column,
the reward's arithmetic, and where a seeded start puts the car on the grid's geometry."""

from __future__ import annotations

import numpy as np
import pytest

from boxbox.errors import UsageError
from boxbox.gym import reward as rw
from boxbox.gym.env import DEFAULT_ACTION_REPEAT, TorcsEnv, step_ends
from boxbox.gym.spaces import (
    DEFAULT_ACTIONS,
    ActionReader,
    ObservationLayout,
    Observer,
    RaceScale,
    action_space,
    pedal_split,
)
from boxbox.gym.start import EDGE_MARGIN_M, LAUNCH_MAX_STEPS, LapCount, draw_start, grid_to_start_m, lap_count
from boxbox.model import State
from boxbox.model.constants import DRIVE_STEP_S
from boxbox.torcs.racefile import GRID_TO_START_M, grid_offset_m

S0 = State(*([0.0] * 42))
RACE = RaceScale(track_length_m=2000.0, redline_rpm=9000.0, tank_l=60.0, top_gear=6, laps=2)


def scaled(**fields) -> dict[str, np.ndarray]:
    observer = Observer(ObservationLayout.make(3), flat=False)
    observer.use(RACE)
    s = S0._replace(**fields)
    return observer.observation(observer.vector(s, np.array([-1.0, 100.0, 200.0]), np.full(36, 50.0)))


def test_each_observation_is_scaled_from_the_range_it_takes_in_the_race():
    radps_per_rpm = 2.0 * np.pi / 60.0
    d = scaled(dist_from_start_m=1500.0, rpm=9000.0 * radps_per_rpm, fuel_l=15.0, gear=6.0, laps=1.0,
               speed_x_mps=50.0, speed_y_mps=-2.0, angle_rad=-0.25 * np.pi, to_middle_m=2.5, to_left_m=5.0,
               to_right_m=10.0, damage=2500.0, spin_fr_rps=200.0)
    assert d["dist_from_start_m"][0] == pytest.approx(0.5)  # 1500 m of a 2000 m lap
    assert d["engine_rpm"][0] == pytest.approx(1.0, abs=1e-5)  # at the redline
    assert d["fuel_l"][0] == pytest.approx(-0.5)  # a quarter of the tank
    assert d["gear"][0] == pytest.approx(1.0) and d["lap"][0] == pytest.approx(0.0)
    assert list(d["speed_mps"]) == pytest.approx([0.5, -0.02])
    assert d["angle_rad"][0] == pytest.approx(-0.5) and d["track_pos"][0] == pytest.approx(1 / 6)
    assert d["damage"][0] == pytest.approx(-0.5) and d["wheel_spin_radps"][0] == pytest.approx(0.5)
    assert list(d["track_edges_m"]) == pytest.approx([-1.0, 0.0, 1.0])  # off the track (-1 m) reads -1
    assert list(d["opponents_m"]) == pytest.approx([-0.5] * 36)


def test_scaled_observations_stay_in_their_space_whatever_the_state():
    layout = ObservationLayout.make(3)
    observer = Observer(layout, flat=True)
    observer.use(RACE)
    wild = S0._replace(speed_x_mps=1e6, dist_from_start_m=1e5, rpm=1e9, damage=1e9, angle_rad=3.0, to_middle_m=-1e4,
                       to_left_m=1e4, to_right_m=-1e4 + 1)
    obs = observer.observation(observer.vector(wild, np.zeros(3), np.zeros(36)))
    space = layout.space(flat=True, scaled=True)
    assert space.contains(obs) and obs.min() >= -1.0 and obs.max() <= 1.0
    assert list(space.low) == [-1.0] * layout.size and list(space.high) == [1.0] * layout.size
    raw = Observer(layout, flat=True, scaled=False)
    assert raw.observation(raw.vector(S0._replace(speed_x_mps=50.0), np.zeros(3), np.zeros(36))).max() == 50.0


def test_one_pedal_column_is_throttle_above_zero_and_brake_below():
    assert pedal_split(0.7) == (0.7, 0.0) and pedal_split(-0.4) == (0.0, 0.4) and pedal_split(0.0) == (0.0, 0.0)
    assert DEFAULT_ACTIONS == ("steer", "pedal")
    reader = ActionReader(DEFAULT_ACTIONS)
    assert reader.read([0.1, -2.0]) == (0.1, 0.0, 1.0, 0.0, 1, False)  # clipped to full brake
    assert reader.read([-0.3, 0.25]) == (-0.3, 0.25, 0.0, 0.0, 1, False)
    assert reader.read([np.nan, np.nan]) == (0.0, 0.0, 0.0, 0.0, 1, False)
    space = action_space(DEFAULT_ACTIONS)
    assert list(space.low) == [-1.0, -1.0] and list(space.high) == [1.0, 1.0]
    # a uniform random policy: never both pedals, and on the throttle half the time
    throttles, brakes = zip(*(pedal_split(p) for p in np.random.default_rng(0).uniform(-1, 1, 10_000)), strict=True)
    assert not any(t > 0 and b > 0 for t, b in zip(throttles, brakes, strict=True))
    assert 0.45 < np.mean(np.array(throttles) > 0) < 0.55


def test_the_off_track_cost_does_not_make_standing_still_optimal():
    """docs/gym.md's arithmetic: an env step (5 drive steps, 0.1 s) at 20 m/s earns 2 m on the
    track; off it, no forward progress and 0.02 m a drive step, so the longest spell off the track
    (off_track_s = 2 s, 100 drive steps) costs 2 m: a learner that drives 0.1 s before it leaves
    the track has done as well as one standing still (0), where the old cost (1 m a drive step)
    took 100 m of driving to make up."""
    w = rw.RewardWeights()
    on = S0._replace(to_left_m=3.0, to_right_m=4.0)
    off = on._replace(to_left_m=-0.5)
    per_drive_step_m = 20.0 * DRIVE_STEP_S
    env_step_on = sum(rw.default_reward(on, on, per_drive_step_m, w) for _ in range(DEFAULT_ACTION_REPEAT))
    assert env_step_on == pytest.approx(2.0)
    spell_steps = round(2.0 / DRIVE_STEP_S)
    spell_off = sum(rw.default_reward(on, off, per_drive_step_m, w) for _ in range(spell_steps))
    assert spell_off == pytest.approx(-2.0)  # forward progress off the track earns nothing
    assert env_step_on + spell_off == pytest.approx(0.0)  # 0.1 s of driving, then the longest spell off: as still
    assert rw.default_reward(on, off, -1.0, w) == pytest.approx(-1.02)  # backwards still counts
    raw = rw.RewardWeights(off_track_m=1.0, off_track_progress=1.0)  # the raw form: progress off counts
    assert sum(rw.default_reward(on, off, 0.0, raw) for _ in range(spell_steps)) == pytest.approx(-100.0)
    assert rw.default_reward(on, off, per_drive_step_m, raw) == pytest.approx(0.4 - 1.0)
    assert rw.default_reward(on, off, 0.4, w, excused=True) == pytest.approx(0.4)  # the pit lane, driven by the env


def test_the_car_s_own_endings_terminate_and_the_race_s_end_truncates():
    """A learner bootstraps past the line: the race's end (its laps ran out) and a fault are no
    state of the car, so they truncate; what the car did terminates; a step that ends nothing, neither."""
    for reason in (rw.OUT, rw.DAMAGE, rw.OFF_TRACK, rw.STUCK):
        assert step_ends(reason) == (True, False), reason
    for reason in (rw.RACE_END, rw.FAULT):
        assert step_ends(reason) == (False, True), reason
    assert step_ends(None) == (False, False)


def test_a_start_along_the_lap_counts_the_laps_as_the_grid_s_race_does():
    """TORCS says lap 0 until the line for a car put down along the lap: the env observes it on lap 1
    (as the grid's car is there) and ends its race (truncated) at the line that ends its last lap."""
    assert lap_count(2, GRID_TO_START_M) == LapCount(2, along=False)
    along = lap_count(2, GRID_TO_START_M + 700.0)
    assert along == LapCount(2, along=True)
    after_line = S0._replace(laps=1.0)
    assert along.added == 1.0 and LapCount(2).added == 0.0  # the grid: TORCS's own count
    assert not along.over(after_line) and along.over(S0._replace(laps=2.0))
    assert not LapCount(2).over(S0._replace(laps=2.0))  # the grid: TORCS's own end (its finish flag)
    watch = rw.Watch(rw.Limits())
    watch.reset(LapCount(1, along=True))
    moving = S0._replace(sim_time_s=1.0, to_left_m=3.0, to_right_m=4.0, speed_x_mps=20.0)
    assert watch.update(moving) is None and watch.update(moving._replace(laps=1.0)) == rw.RACE_END
    watch.reset()
    assert watch.update(moving._replace(laps=1.0)) is None


def test_a_start_along_the_lap_keeps_every_car_of_the_grid_on_the_track():
    length = 2057.56
    # alone: the car anywhere from 1 m past the line to 1 m before it
    assert grid_to_start_m(0.0, length, 0, 1) == pytest.approx(length - EDGE_MARGIN_M)
    assert grid_to_start_m(1.0, length, 0, 1) == pytest.approx(EDGE_MARGIN_M)
    assert grid_to_start_m(None, length, 0, 1) == GRID_TO_START_M
    assert [grid_offset_m(i) for i in range(5)] == [0.0, 10.0, 20.0, 30.0, 40.0]
    for fraction in (0.0, 0.3, 1.0):  # third of five cars: every car between the margins
        to_start = grid_to_start_m(fraction, length, 2, 5)
        places = [length - to_start - grid_offset_m(i) for i in range(5)]
        assert min(places) >= EDGE_MARGIN_M - 1e-9 and max(places) <= length - EDGE_MARGIN_M + 1e-9
    assert grid_to_start_m(0.5, 30.0, 0, 5) == GRID_TO_START_M  # a grid longer than the track: its own place


def test_starts_come_from_the_seed():
    a = [draw_start(np.random.default_rng(0)) for _ in range(2)]
    b = draw_start(np.random.default_rng(1))
    assert a[0] == a[1] and a[0] != b
    starts = [draw_start(np.random.default_rng(seed)) for seed in range(200)]
    assert all(0.0 <= s.fraction < 1.0 and 0 <= s.launch_steps <= LAUNCH_MAX_STEPS for s in starts)
    assert np.std([s.fraction for s in starts]) > 0.25  # spread over the lap


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"actions": ("steer", "pedal", "brake")}, "give 'pedal' or 'throttle' and 'brake', not both"),
    ({"random_start": "yes"}, "'random_start': 'yes' is not True or False"),
    ({"raw_observations": 1}, "'raw_observations': 1 is not True or False"),
])
def test_the_new_options_refuse_bad_input_in_one_line(kwargs, words):
    with pytest.raises(UsageError) as refused:
        TorcsEnv(**kwargs)
    assert words in str(refused.value) and "\n" not in str(refused.value)
