"""Spaces, action reading, reward and limits: plain numbers."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium
import numpy as np
import pytest

from boxbox.errors import UsageError
from boxbox.gym import reward as rw
from boxbox.gym.spaces import OBSERVATIONS, ActionReader, ObservationLayout, Observer, action_space, docs_table
from boxbox.model import State

S0 = State(*([0.0] * 42))


def state(**fields) -> State:
    return S0._replace(**fields)


def test_the_flat_vector_is_gymnasiums_flattening_of_the_dict():
    layout = ObservationLayout.make(n_track_sensors=19)
    assert set(layout.sizes) == set(OBSERVATIONS)
    dict_space, flat_space = layout.dict_space(), layout.flat_space()
    obs = Observer(layout, flat=False, scaled=False)  # the units (raw_observations=True; scaling: test_gym_defaults)
    s = state(angle_rad=0.1, damage=12.0, dist_from_start_m=345.0, rpm=500.0, fuel_l=40.0, gear=3.0, laps=2.0,
              to_middle_m=2.5, to_left_m=5.0, to_right_m=10.0, speed_x_mps=30.0, speed_y_mps=-1.0,
              spin_fr_rps=1.0, spin_fl_rps=2.0, spin_rr_rps=3.0, spin_rl_rps=4.0)
    vec = obs.vector(s, np.arange(19.0), np.full(36, 200.0))
    d = obs.observation(vec)
    assert dict_space.contains(d) and flat_space.contains(vec)
    assert np.array_equal(gymnasium.spaces.flatten(dict_space, d), vec)
    assert d["track_pos"][0] == pytest.approx(2.5 / 7.5)
    assert d["engine_rpm"][0] == pytest.approx(500.0 * 60 / (2 * math.pi), rel=1e-6)
    assert list(d["wheel_spin_radps"]) == [1.0, 2.0, 3.0, 4.0] and list(d["speed_mps"]) == [30.0, -1.0]
    assert d["lap"][0] == 2.0 and d["gear"][0] == 3.0 and list(d["track_edges_m"]) == list(range(19))


def test_each_observation_is_where_its_entry_says_and_the_docs_table_is_made_from_the_entries():
    layout = ObservationLayout.make(n_track_sensors=5)
    obs = Observer(layout, flat=False, scaled=False)
    s = state(angle_rad=0.1, damage=12.0, dist_from_start_m=345.0, fuel_l=40.0, gear=3.0, laps=2.0,
              speed_x_mps=30.0, speed_y_mps=-1.0, spin_fr_rps=1.0, spin_fl_rps=2.0, spin_rr_rps=3.0, spin_rl_rps=4.0)
    d = obs.observation(obs.vector(s, np.arange(5.0), np.arange(36.0)))
    for entry in OBSERVATIONS.values():
        if entry.state:
            want = [getattr(s, field) for field in entry.state]
        elif entry.compute is not None:
            want = [entry.compute(s)]
        else:
            want = list(range(5 if entry.sensor == "edges" else 36))
        assert list(d[entry.name]) == pytest.approx(want, rel=1e-6), entry.name
    doc = (Path(__file__).resolve().parents[3] / "docs" / "gym.md").read_text()
    assert docs_table() in doc  # regenerate docs/gym.md's table with print(docs_table())


def test_values_beyond_the_bounds_are_clipped_into_the_space():
    layout = ObservationLayout.make(3)
    obs = Observer(layout, flat=True)
    vec = obs.vector(state(speed_x_mps=1e6, to_middle_m=-1e4, to_left_m=1e4, to_right_m=-1e4 + 1),
                     np.zeros(3), np.zeros(36))
    assert layout.flat_space().contains(vec)


def test_actions_are_clipped_and_nan_reads_as_zero():
    reader = ActionReader(("steer", "throttle", "brake", "gear", "clutch", "pit"))
    assert reader.read([2.0, -1.0, 0.5, 3.4, 0.2, 0.7]) == (1.0, 0.0, 0.5, 0.2, 3, True)
    assert reader.read([math.nan, math.nan, math.nan, math.nan, math.nan, math.nan]) == (0.0, 0.0, 0.0, 0.0, 0, False)
    assert ActionReader(("steer", "throttle", "brake")).read(np.float32([-0.25, 1.0, 0.0])) == \
        (-0.25, 1.0, 0.0, 0.0, 1, False)
    space = action_space(("steer", "throttle", "brake", "gear"))
    assert list(space.low) == [-1, 0, 0, -1] and list(space.high) == [1, 1, 1, 6]


def test_progress_across_the_start_line_and_backwards():
    length = 2000.0
    assert rw.progress_m(state(dist_from_start_m=1999.0), state(dist_from_start_m=1.0), length) == pytest.approx(2.0)
    assert rw.progress_m(state(dist_from_start_m=1.0), state(dist_from_start_m=1999.0), length) == pytest.approx(-2.0)
    assert rw.progress_m(state(dist_from_start_m=10.0), state(dist_from_start_m=11.5), length) == pytest.approx(1.5)


def test_default_reward_charges_damage_and_leaving_the_track():
    w = rw.RewardWeights(damage_weight=0.1, off_track_m=1.0)
    on = state(to_left_m=3.0, to_right_m=4.0)
    assert rw.default_reward(on, on._replace(damage=50.0), 2.0, w) == pytest.approx(2.0 - 5.0)
    # off the track forward progress earns nothing (test_gym_defaults has the default's arithmetic)
    assert rw.default_reward(on, on._replace(to_left_m=-0.1), 2.0, w) == pytest.approx(-1.0)
    assert rw.default_reward(on._replace(damage=9.0), on._replace(damage=9.0), 0.5, w) == pytest.approx(0.5)


def test_limits_off_track_stuck_damage_and_race_end():
    watch = rw.Watch(rw.Limits(max_damage=100.0, off_track_s=0.1, stuck_s=0.2))
    off = state(sim_time_s=1.0, to_left_m=-1.0, to_right_m=8.0, speed_x_mps=20.0)
    assert [watch.update(off) for _ in range(6)] == [None] * 5 + ["off-track"]
    watch.reset()
    slow = state(sim_time_s=1.0, to_left_m=1.0, to_right_m=8.0, speed_x_mps=0.5)
    assert [watch.update(slow) for _ in range(11)] == [None] * 10 + ["stuck"]
    watch.reset()
    assert watch.update(slow, excused=True) is None and watch.stuck_steps == 0
    assert watch.update(slow._replace(damage=150.0)) == "damage"
    assert watch.update(slow._replace(car_state=0x100)) == "race-end"
    assert watch.update(slow._replace(car_state=0x2)) == "out"
    with pytest.raises(UsageError, match=r"Invalid value for 'off_track_s': -1.0 is not in the range x>0\."):
        rw.Limits(off_track_s=-1)
