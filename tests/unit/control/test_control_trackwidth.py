"""The drivable width per sample and the surface under the car (control/trackwidth.py), on plain numbers."""

import numpy as np
import pytest

from boxbox.control.trackwidth import SideParts, drivable_width, grippy_sides, surface_friction

N = 4
HALF = np.full(N, 5.0)
CAR_W = 2.0


def side(border=1.0, outer=3.0, wall=False, border_mu=1.1, outer_mu=0.9) -> SideParts:
    return SideParts(border_width_m=np.full(N, border), border_wall=np.full(N, wall),
                     border_friction=np.full(N, border_mu), outer_width_m=np.full(N, outer),
                     outer_friction=np.full(N, outer_mu))


TURNS = np.array([0.0, 1.0, -1.0, 1.0])  # straight, left, right, left


def test_strict_keeps_the_body_between_the_edges():
    left, right = drivable_width("strict", HALF, TURNS, side(), side(), CAR_W)
    assert left.tolist() == [4.0] * N and right.tolist() == [4.0] * N


def test_torcs_reaches_the_barrier_except_on_the_inside_of_a_turn():
    left, right = drivable_width("torcs", HALF, TURNS, side(), side(), CAR_W)
    # up to the barrier: 5 + 1 + 3 - 1 (half the car) = 8; the inside of a turn: 5 + 0.7 x 2 = 6.4
    assert left.tolist() == pytest.approx([8.0, 6.4, 8.0, 6.4])
    assert right.tolist() == pytest.approx([8.0, 8.0, 6.4, 8.0])


def test_pit_exemption_and_border_walls():
    exempt = np.array([False, True, False, False])
    left, _ = drivable_width("torcs", HALF, TURNS, side(), side(), CAR_W, pit_exempt_left=exempt)
    assert left.tolist() == pytest.approx([8.0, 8.0, 8.0, 6.4])
    left, right = drivable_width("torcs", HALF, TURNS, side(wall=True), side(border=0.0, outer=0.0), CAR_W)
    assert left.tolist() == pytest.approx([4.0] * N)  # a border wall ends the width at the track's edge
    assert right.tolist() == pytest.approx([4.0] * N)


def test_surface_under_the_car():
    off = np.array([0.0, 5.5, -7.0, -5.2])
    left, right = side(border_mu=1.0, outer_mu=0.6), side(border_mu=1.1, outer_mu=0.7)
    mu = surface_friction(off, HALF, np.full(N, 1.2), left, right)
    assert mu.tolist() == pytest.approx([1.2, 1.0, 0.7, 1.1])


def test_rough_parts_count_when_the_floor_clears_their_waves():
    grippy = side(border_mu=1.3, outer_mu=1.3)
    main_mu, main_rough = np.full(N, 1.2), np.full(N, 0.005)
    # border waves 0.025 m, side waves 0.05 m high (TORCS's roughness)
    rough = (main_rough, np.full(N, 0.025), np.full(N, 0.05))
    low = grippy_sides(grippy, main_mu, rough)  # no ride height: rougher than the track is out
    assert low.border_wall.all() and not low.outer_width_m.any()
    # a 0.09 m ride height clears 0.025 m waves (0.05 crest to trough), not 0.05 m ones
    high = grippy_sides(grippy, main_mu, rough, ride_height_m=0.09)
    assert not high.border_wall.any() and not high.outer_width_m.any()
    higher = grippy_sides(grippy, main_mu, rough, ride_height_m=0.12)
    assert higher.outer_width_m.tolist() == [3.0] * N


@pytest.mark.parametrize("call", [
    lambda: drivable_width("loose", HALF, TURNS, side(), side(), CAR_W),
    lambda: drivable_width("torcs", HALF[:3], TURNS, side(), side(), CAR_W),
    lambda: drivable_width("torcs", -HALF, TURNS, side(), side(), CAR_W),
    lambda: drivable_width("torcs", HALF, TURNS, side(border=-1.0), side(), CAR_W),
    lambda: drivable_width("torcs", HALF, TURNS * np.nan, side(), side(), CAR_W),
    lambda: drivable_width("torcs", HALF, TURNS, side(), side(), 0.0),
    lambda: surface_friction(np.zeros(3), HALF, np.ones(N), side(), side()),
])
def test_bad_input_is_refused(call):
    with pytest.raises(ValueError):
        call()
