"""The limit lap (bench/limit.py) on the tracks and car recorded in tests/data, without TORCS."""

import numpy as np
import pytest

from boxbox.bench.limit import gap_percent, limit_lap, point_mass_car
from boxbox.model.skill import SkillLevel
from boxbox.torcs.wire import SIDE_PART_FIELDS
from trackdata import load


@pytest.fixture(scope="module")
def aalborg():
    """tests/data's aalborg, recorded before the bridge sent the sides' parts: its first part beside
    the track (`*_side_*`) stands in for the side, with no border."""
    track, car = load("aalborg")
    seg, zeros = track.seg, np.zeros(track.n_segments)
    for side in ("left", "right"):
        for name in SIDE_PART_FIELDS:
            seg.setdefault(f"{side}_{name}", zeros.copy())
        seg[f"{side}_outer_start_width_m"] = seg[f"{side}_outer_end_width_m"] = seg[f"{side}_side_width_m"]
        seg[f"{side}_outer_friction"] = seg[f"{side}_side_friction"]
    return track, car


def test_more_room_and_more_grip_are_never_slower(aalborg):
    track, car = aalborg
    strict = limit_lap(track, car, SkillLevel.SEMI_PRO, "strict", step_m=10.0)
    torcs = limit_lap(track, car, SkillLevel.SEMI_PRO, "torcs", step_m=10.0)
    pro = limit_lap(track, car, SkillLevel.PRO, "strict", step_m=10.0)
    assert torcs.lap_time_s <= strict.lap_time_s < pro.lap_time_s  # semi-pro's tyres grip more
    assert np.all(strict.offset_m <= strict.left_m + 1e-6) and np.all(strict.offset_m >= -strict.right_m - 1e-6)
    # the lap's time is its distance over its speeds: between the slowest and fastest average
    assert track.length_m / strict.speed_mps.max() < strict.lap_time_s < track.length_m / strict.speed_mps.min()
    assert 50.0 < torcs.lap_time_s < 66.96  # below the championship robot's best aalborg lap (anchors)


def test_the_point_mass_car_of_car1_trb1(aalborg):
    _, car = aalborg
    pm = point_mass_car(car, SkillLevel.SEMI_PRO)
    assert pm.mass_kg == car.mass_kg and pm.gear_ratios[0] == pytest.approx(13.5) and len(pm.gear_ratios) == 6
    assert pm.mu == pytest.approx(1.6 * 1.08, rel=0.01)  # tyre mu with semi-pro's gain at the peak slip
    assert pm.load_factor_max == pytest.approx(1.6) and pm.load_factor_min == pytest.approx(0.8)


def test_gap_percent():
    assert gap_percent(110.0, 100.0) == pytest.approx(10.0)
    assert gap_percent(95.0, 100.0) == pytest.approx(-5.0)
    assert np.isnan(gap_percent(95.0, 0.0))
