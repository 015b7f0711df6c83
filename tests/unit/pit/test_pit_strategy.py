"""robot.strategy: fuel arithmetic, stop decisions, orders and the number of stops."""

from __future__ import annotations

import itertools
import math

import pytest

from boxbox.robot.strategy import (
    FUEL_PER_M_L,
    FUEL_RATE_LPS,
    REPAIR_S_PER_POINT,
    STOP_BASE_S,
    PitStrategy,
    laps_after_box,
    pit_lane_loss_s,
    plan_stops,
)

LENGTH_M = 5380.5  # e-track-2
TANK_L = 94.0


def strat(**kw) -> PitStrategy:
    return PitStrategy(LENGTH_M, TANK_L, **kw)


def test_first_estimate_from_fuel_per_metre():
    st = strat()
    assert st.fuel_per_lap_l == pytest.approx(FUEL_PER_M_L * LENGTH_M)
    assert strat(fuel_per_m_l=0.001).fuel_per_lap_l == pytest.approx(5.3805)


def test_fuel_per_lap_measured_each_lap():
    st = strat()
    st.on_lap(0, 94.0, 0.0)  # race start: the reference
    assert st.measured_l == []
    st.on_lap(0, 93.0, 0.0)  # same lap again: nothing
    st.on_lap(1, 89.0, 0.0)
    assert st.fuel_per_lap_l == pytest.approx(5.0)  # the first lap, until another is measured
    st.on_lap(2, 85.0, 0.0)
    st.on_lap(3, 80.5, 0.0)
    st.on_lap(4, 76.3, 0.0)
    assert st.first_lap_l == pytest.approx(5.0)
    assert st.measured_l == pytest.approx([4.0, 4.5, 4.2])
    # the largest from lap 2 on (running dry costs the race); the standing start's lap is left out
    assert st.fuel_per_lap_l == pytest.approx(4.5)


def test_lap_with_ordered_fuel_is_measured_with_the_fuel_added():
    st = strat()
    st.on_lap(0, 20.0, 0.0)
    st.on_lap(1, 16.0, 0.0)  # 4 l/lap
    fuel, _ = st.order(remaining_laps=30, fuel_l=14.0, damage=0.0, tank_l=TANK_L)  # 2 l used so far
    assert fuel == pytest.approx(15.3 * 4.0 - 14.0)  # 30 laps in two even stints (23 fit in the tank)
    st.on_lap(2, 14.0 + fuel - 2.0, 0.0)  # 2 more after the stop
    assert st.measured_l[-1] == pytest.approx(4.0)


def test_unexplained_refuel_and_skipped_laps_are_not_measured():
    st = strat()
    st.on_lap(0, 50.0, 0.0)
    st.on_lap(1, 80.0, 0.0)  # fuel went up without an order
    st.on_lap(3, 70.0, 0.0)  # two laps at once
    assert st.measured_l == []


def test_wants_stop_for_fuel_needs_both_conditions():
    st = strat()
    st.on_lap(0, 94.0, 0.0)
    st.on_lap(1, 90.0, 0.0)  # 4 l/lap
    assert not st.wants_stop(1, 10, 30.0, 0.0)  # not enough to finish, but 7.5 laps in the tank
    assert not st.wants_stop(1, 1, 5.0, 0.0)  # < 1.5 laps left, but enough to finish
    assert st.wants_stop(1, 10, 5.0, 0.0)  # 1.25 laps left, 10 to go
    assert not st.wants_stop(1, 0, 0.5, 0.0)  # the race ends here


def test_wants_stop_for_damage_and_requested_laps():
    st = strat(pit_laps=[5])
    assert not st.wants_stop(3, 10, 80.0, 5001.0)  # no damage taken per lap so far: it reaches the end
    assert st.wants_stop(3, 10, 80.0, 8501.0)  # too near TORCS's 10000 for one more crash
    st.on_lap(0, 94.0, 0.0)
    st.on_lap(1, 90.0, 600.0)  # 600 points a lap
    assert st.wants_stop(3, 10, 80.0, 5001.0)  # 5001 + 10 x 600 > 8500
    assert not st.wants_stop(3, 10, 80.0, 5000.0)
    assert not st.wants_stop(7, 2, 80.0, 6568.0)  # 6568 + 2 x 600 < 8500: finish without a stop
    assert st.wants_stop(4, 10, 80.0, 0.0)  # driving lap 5
    assert not st.wants_stop(5, 10, 80.0, 0.0)


def test_wants_stop_when_the_damage_costs_more_lap_time_than_a_repair():
    st = strat(s_per_lap_per_damage=0.001, pit_loss_s=15.0)
    # 3000 points cost 3 s a lap: over 20 laps 60 s against 15 + 2 + 21 s for the stop and repair
    assert st.wants_stop(3, 20, 80.0, 3000.0)
    assert not st.wants_stop(3, 10, 80.0, 3000.0)  # 30 s against 38 s
    assert not strat().wants_stop(3, 20, 80.0, 3000.0)  # damage that costs no time: no stop


def test_no_second_stop_in_the_same_lap():
    st = strat(pit_laps=[5])
    st.on_lap(4, 80.0, 0.0)
    assert st.wants_stop(4, 10, 80.0, 0.0)
    st.order(10, 80.0, 0.0, TANK_L)
    assert not st.wants_stop(4, 10, 94.0, 0.0)


def test_order_refuels_only_what_is_needed_plus_margin():
    st = strat(margin_laps=0.3)
    st.on_lap(0, 94.0, 0.0)
    st.on_lap(1, 90.0, 0.0)  # 4 l/lap
    fuel, repair = st.order(remaining_laps=5, fuel_l=3.0, damage=0.0, tank_l=TANK_L)
    assert fuel == pytest.approx(5.3 * 4.0 - 3.0)
    assert repair == 0.0
    # enough already: nothing
    assert st.order(remaining_laps=5, fuel_l=30.0, damage=0.0, tank_l=TANK_L)[0] == 0.0


def test_order_bounded_by_tank_and_split_over_stops():
    st = strat(margin_laps=0.3, pit_loss_s=15.0)
    st.on_lap(0, 94.0, 0.0)
    st.on_lap(1, 90.0, 0.0)  # 4 l/lap: a full tank lasts 23 laps
    fuel, _ = st.order(remaining_laps=40, fuel_l=2.0, damage=0.0, tank_l=TANK_L)
    # two stints of 20 laps beat a full tank (23) + a short stint: less weight, same stops
    assert fuel == pytest.approx(20.3 * 4.0 - 2.0)
    assert st.plan(40, at_stop=True).stint_laps == (20, 20)
    fuel, _ = st.order(remaining_laps=40, fuel_l=2.0, damage=0.0, tank_l=50.0)
    assert fuel <= 50.0 - 2.0 + 1e-9


def test_repair():
    st = strat()
    assert st.order(5, 50.0, 800.0, TANK_L)[1] == 0.0  # below the level we keep: not worth 5.6 s
    assert st.order(5, 50.0, 6000.0, TANK_L)[1] == pytest.approx(1000.0)  # down to 5000
    # when damage costs lap time, repairing everything pays
    costly = strat(s_per_lap_per_damage=0.01)
    assert costly.order(5, 50.0, 6000.0, TANK_L)[1] == pytest.approx(6000.0)


def test_repair_enough_to_avoid_a_second_damage_stop():
    st = strat()
    st.on_lap(0, 94.0, 0.0)
    st.on_lap(1, 90.0, 400.0)
    st.on_lap(2, 86.0, 800.0)  # 400 points a lap
    assert st.damage_per_lap == pytest.approx(400.0)
    # 20 laps to go: 1.5 x 8000 more expected -> repair everything (no damage may be kept)
    assert st.order(20, 50.0, 5500.0, TANK_L)[1] == pytest.approx(5500.0)
    # 11 laps to go: 1.5 x 4400 more expected -> keep at most 1900 (8500 - 6600), not the usual 5000
    assert st.order(11, 50.0, 5500.0, TANK_L)[1] == pytest.approx(3600.0)
    assert st.order(2, 50.0, 5500.0, TANK_L)[1] == pytest.approx(500.0)  # few laps: keep 5000
    # a lap with a repair does not count as damage taken
    st.on_lap(3, 82.0, 100.0)
    assert st.damage_per_lap == pytest.approx(400.0)


def brute_force_time(laps: int, fpl: float, tank: float, stops: int, pit_loss: float, k: float,
                     margin: float, first_free: bool = True) -> float:
    """Best time cost over every split of laps into stops + 1 stints (independent of plan_stops)."""
    best = math.inf
    for cut in itertools.combinations(range(1, laps), stops):
        bounds = (0, *cut, laps)
        stints = [b - a for a, b in zip(bounds, bounds[1:], strict=False)]
        if max(stints) + margin > tank / fpl + 1e-9:
            continue
        refuel = sum(stints[1:] if first_free else stints) * fpl / FUEL_RATE_LPS
        weight = sum(n * (n / 2.0 + margin) * fpl * k for n in stints)
        best = min(best, stops * (pit_loss + STOP_BASE_S) + refuel + weight)
    return best


@pytest.mark.parametrize("laps,fpl,loss,k", [(10, 4.3, 15.0, 0.03), (30, 4.3, 15.0, 0.03),
                                             (20, 4.3, 3.0, 0.1), (25, 8.0, 20.0, 0.03),
                                             (12, 10.0, 1.0, 0.2)])
def test_plan_stops_minimises_time(laps: int, fpl: float, loss: float, k: float):
    plan = plan_stops(laps, fpl, TANK_L, pit_loss_s=loss, s_per_lap_per_kg=k, margin_laps=0.3)
    # every split with up to two stops more than the plan's (a wider search gets slow)
    times = {n: brute_force_time(laps, fpl, TANK_L, n, loss, k, 0.3) for n in range(0, min(laps, plan.stops + 3))}
    assert plan.time_cost_s == pytest.approx(min(times.values()))
    assert times[plan.stops] == pytest.approx(min(times.values()))
    assert len(plan.stint_laps) == len(plan.fuel_per_stint_l) == plan.stops + 1
    assert sum(plan.stint_laps) == laps
    assert max(plan.fuel_per_stint_l) <= TANK_L
    assert plan.fuel_per_stint_l == pytest.approx([(n + 0.3) * fpl for n in plan.stint_laps])


@pytest.mark.parametrize("laps", [30, 45])
def test_plan_at_a_stop_minimises_time_too(laps: int):
    plan = plan_stops(laps, 4.3, TANK_L, s_per_lap_per_kg=0.03, first_stint_fuelled=False)
    times = {n: brute_force_time(laps, 4.3, TANK_L, n, 15.0, 0.03, 0.3, first_free=False)
             for n in range(0, plan.stops + 2)}
    assert plan.time_cost_s == pytest.approx(min(times.values()))
    # everything is refuelled: even stints carry the least weight
    assert max(plan.stint_laps) - min(plan.stint_laps) <= 1


def test_first_stint_is_longer_when_its_fuel_is_free():
    plan = plan_stops(40, 4.0, TANK_L, first_stint_fuelled=True)
    assert plan.stops == 1 and plan.stint_laps[0] > plan.stint_laps[1]


def test_plan_stops_cases():
    assert plan_stops(10, 4.3, TANK_L).stops == 0  # fits in the tank
    assert plan_stops(30, 4.3, TANK_L).stops == 1  # a full tank lasts 21 laps
    # a cheap pit lane and a heavy car: more, shorter stints
    assert plan_stops(30, 4.3, TANK_L, pit_loss_s=0.0, s_per_lap_per_kg=0.2).stops > 1
    with pytest.raises(ValueError):
        plan_stops(10, 100.0, TANK_L)
    assert plan_stops(0, 4.3, TANK_L).stops == 0


def test_stop_cost_figures():
    # TORCS race defaults (TORCS.md): 2 s + fuel / 8 l/s + repair * 0.007 s
    assert (STOP_BASE_S, FUEL_RATE_LPS, REPAIR_S_PER_POINT) == (2.0, 8.0, 0.007)
    loss = pit_lane_loss_s(644.0, 24.5, 60.0)
    assert 644.0 / 24.5 - 644.0 / 60.0 < loss < 40.0


def test_part_lap_left_is_fuelled_as_a_part():
    # at a stop 12.4 laps are left (the rest of this lap + 12): 13 whole laps are planned, but the
    # last stint carries fuel for 12.4 (+ margin), not for 13
    plan = plan_stops(12.4, 4.0, TANK_L, margin_laps=0.3, first_stint_fuelled=False)
    assert plan.stint_laps == (13,)
    assert plan.fuel_per_stint_l[0] == pytest.approx(12.7 * 4.0)
    two = plan_stops(40.5, 4.0, TANK_L, margin_laps=0.3, first_stint_fuelled=False)
    assert two.stint_laps == (20, 21)
    assert two.fuel_per_stint_l == pytest.approx((20.3 * 4.0, 20.8 * 4.0))  # only the last is short
    st = strat(margin_laps=0.3)
    st.on_lap(0, 94.0, 0.0)
    st.on_lap(1, 90.0, 0.0)  # 4 l/lap
    fuel, _ = st.order(remaining_laps=12.4, fuel_l=3.0, damage=0.0, tank_l=TANK_L)
    assert fuel == pytest.approx(12.7 * 4.0 - 3.0)


def test_laps_after_box_counts_the_rest_of_the_lap_from_a_box_ahead():
    # box at 1000 m of a 5000 m lap, car at 400 m with 3 laps after this one
    assert laps_after_box(3, 400.0, 1000.0, 5000.0) == pytest.approx(3.8)


def test_no_stop_on_the_last_lap_for_a_box_beyond_the_line():
    # aalborg: the box just past the line; deciding 300 m before the line on the last lap, the box
    # would come in a lap the race does not have
    left = laps_after_box(0, 3500.0, 100.0, 3800.0)
    assert left < 0.0
    st = strat()
    st.on_lap(9, 1.0, 0.0)  # 1 l left, far less than a lap: still no stop, the race ends first
    assert not st.wants_stop(9, left, 1.0, 0.0)
    # the lap before, the same place: the box comes on the last lap, with most of that lap after it
    assert laps_after_box(1, 3500.0, 100.0, 3800.0) == pytest.approx(1.0 - 100.0 / 3800.0)
