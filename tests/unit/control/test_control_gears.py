import pytest

from boxbox.control.gears import GearBox
from trackdata import load

_, CAR = load("e-track-2")  # car1-trb1: 6 forward gears


def shift_speed(gear: int, shift: float = 0.9) -> float:
    """Road speed at `shift` of the redline in `gear`, on the rear wheels (computed independently)."""
    return CAR.rpm_redline / CAR.gear_ratios[gear + CAR.gear_offset] * CAR.wheel_radius_rr_m * shift


def test_top_gear_and_thresholds():
    box = GearBox(CAR)
    assert box.top_gear == 6
    for gear in range(1, 7):
        assert box.upshift_speed_mps[gear] == pytest.approx(shift_speed(gear), rel=1e-12)
    assert shift_speed(1) == pytest.approx(20.93, abs=0.01)


@pytest.mark.parametrize("gear", [0, -1])
@pytest.mark.parametrize("speed_mps", [0.0, 15.0, 60.0, -5.0])
def test_neutral_or_reverse_goes_to_first(gear, speed_mps):
    assert GearBox(CAR).select(gear, speed_mps) == 1


@pytest.mark.parametrize("gear", [1, 2, 3, 4, 5])
def test_upshift_just_above_shift_speed(gear):
    box = GearBox(CAR)
    v = shift_speed(gear)
    assert box.select(gear, v + 0.01) == gear + 1
    assert box.select(gear, v - 0.01) == gear


def test_no_upshift_past_top_gear():
    box = GearBox(CAR)
    assert box.select(6, shift_speed(6) + 1.0) == 6
    assert box.select(6, 200.0) == 6


@pytest.mark.parametrize("gear", [2, 3, 4, 5, 6])
def test_downshift_with_margin(gear):
    box = GearBox(CAR)
    lower = shift_speed(gear - 1)
    assert box.select(gear, lower - 4.0 - 0.01) == gear - 1
    assert box.select(gear, lower - 4.0 + 0.01) == gear  # inside the 4 m/s margin: keep
    assert box.select(gear, lower - 1.0) == gear


def test_never_down_to_neutral():
    box = GearBox(CAR)
    assert box.select(1, 0.0) == 1
    assert box.select(1, -3.0) == 1


def test_no_oscillation_after_upshift():
    box = GearBox(CAR)
    for gear in range(1, 6):
        v = shift_speed(gear) + 0.01
        new = box.select(gear, v)
        assert new == gear + 1
        assert box.select(new, v) == new
        assert box.select(new, v - 3.9) == new


def test_custom_shift_and_margin():
    box = GearBox(CAR, shift=0.8, shift_margin_mps=2.0)
    v = shift_speed(2, 0.8)
    assert box.select(2, v + 0.01) == 3
    assert box.select(2, v - 0.01) == 2
    assert box.select(3, v - 2.01) == 2
    assert box.select(3, v - 1.99) == 3


def test_fifth_shifts_into_sixth_the_top_gear():
    # car1-trb1's sixth gear (0.77 x final drive 4.5) was never used while max_gear said 5
    box = GearBox(CAR)
    assert CAR.gear_ratio(6) == pytest.approx(0.77 * 4.5, rel=1e-6)
    assert box.select(5, shift_speed(5) + 0.5) == 6
