import math

import numpy as np
import pytest

from boxbox.control.tyre import falls_past_peak, magic_formula, peak_slip, skid_grip_gain
from boxbox.model.skill import SkillLevel

CAR1_TRB1 = (20.0, 0.8, 0.7)  # stiffness, dynamic friction, elasticity from its car file


def test_pro_tyre_peaks_at_one_and_falls_when_sliding():
    slip = np.linspace(0.0, 1.5, 1501)
    force = magic_formula(slip, *CAR1_TRB1)
    assert force.max() == pytest.approx(1.0, abs=1e-6)
    assert 0.2 < slip[force.argmax()] < 0.3
    assert force[-1] < 0.95


def test_the_formula_by_hand_at_one_point():
    c = 2.0 - 2.0 * math.asin(0.8) / math.pi
    bx = 20.0 / c * 0.1
    expected = math.sin(c * math.atan(bx * 0.3 + 0.7 * math.atan(bx))) * (1.0 + 0.1 * 0.3)
    assert magic_formula(np.array([0.1]), *CAR1_TRB1, skid_factor=0.3)[0] == pytest.approx(expected, rel=1e-12)


def test_peak_slip_of_car1_trb1_and_of_torcs_defaults():
    assert peak_slip(*CAR1_TRB1) == pytest.approx(0.263, abs=0.002)
    # a stiffer tyre peaks at less slip
    assert peak_slip(60.0, 0.8, 0.7) < peak_slip(30.0, 0.8, 0.7)


def test_skid_gain_is_one_at_pro_and_grows_with_slip_below_it():
    assert skid_grip_gain(*CAR1_TRB1, skid_factor=0.0, usable_slip=0.5) == pytest.approx(1.0, abs=1e-6)
    at_peak = skid_grip_gain(*CAR1_TRB1, skid_factor=0.3, usable_slip=0.26)
    sliding = skid_grip_gain(*CAR1_TRB1, skid_factor=0.3, usable_slip=1.5)
    assert at_peak == pytest.approx(1.078, abs=0.003)
    assert sliding == pytest.approx(1.302, abs=0.003)
    assert skid_grip_gain(*CAR1_TRB1, skid_factor=0.4, usable_slip=0.26) > at_peak  # rookie


@pytest.mark.parametrize("bad", [dict(usable_slip=0.0), dict(usable_slip=2.0), dict(skid_factor=math.nan),
                                 dict(skid_factor=-0.1)])
def test_bad_input(bad):
    args = dict(skid_factor=0.3, usable_slip=0.3) | bad
    with pytest.raises(ValueError):
        skid_grip_gain(*CAR1_TRB1, **args)
    with pytest.raises(ValueError):
        magic_formula(np.array([0.1]), 0.0, 0.8, 0.7)


@pytest.mark.parametrize(("level", "falls"), [(SkillLevel.PRO, True), (SkillLevel.SEMI_PRO, False),
                                              (SkillLevel.AMATEUR, False), (SkillLevel.ROOKIE, False)])
def test_only_pro_loses_force_past_the_peak(level: SkillLevel, falls: bool):
    # the stock cars' tyre (dynamic friction 0.9) and the open-wheeler's (0.7) alike
    for shape in (CAR1_TRB1, (20.0, 0.9, 0.7), (20.0, 0.7, 0.7)):
        assert falls_past_peak(*shape, level.skid_factor) is falls


def test_a_small_skid_factor_still_loses_force_past_the_peak():
    # the force at slip 1.5 is 0.898 of the peak at pro: a skid factor of 0.05 adds 7.5 % there, not enough
    assert falls_past_peak(*CAR1_TRB1, 0.05)
    assert not falls_past_peak(*CAR1_TRB1, 0.3)
