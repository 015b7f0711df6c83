"""Turn-by-turn learning (boxbox.robot.learning.TurnLearner): turn detection, updates, persistence."""

import json

import pytest

from boxbox.robot.learning import CEILING_RECOVERY, MAX_FACTOR, MIN_FACTOR, TurnLearner

STEP_M = 2.0
TOP_MPS = 100.0


def learner(limits, gain=0.5):
    return TurnLearner.from_limits(limits, STEP_M, len(limits) * STEP_M, TOP_MPS, gain=gain)


# two turns: samples 10..14 and 25..27 of 30
TWO_TURNS = [100.0] * 10 + [50.0] * 5 + [100.0] * 10 + [40.0] * 3 + [100.0] * 2


# --- from_limits -------------------------------------------------------------------------------

def test_from_limits_finds_the_runs_below_top_speed():
    tl = learner(TWO_TURNS)
    assert [(t.start_m, t.end_m) for t in tl.turns] == [(20.0, 30.0), (50.0, 56.0)]
    assert tl.sample_index == [-1] * 10 + [0] * 5 + [-1] * 10 + [1] * 3 + [-1] * 2
    assert tl.length_m == 60.0
    assert all(t.factor == 1.0 and t.ceiling == MAX_FACTOR for t in tl.turns)


def test_from_limits_threshold_is_95_percent_of_top_speed():
    limits = [100.0] * 5 + [95.0] * 3 + [100.0] * 5 + [94.9] * 3 + [100.0] * 5
    tl = learner(limits)
    assert [(t.start_m, t.end_m) for t in tl.turns] == [(26.0, 32.0)]  # 95.0 is not limited, 94.9 is
    # relative to the given top speed
    tl = TurnLearner.from_limits(limits, STEP_M, len(limits) * STEP_M, 200.0)
    assert len(tl.turns) == 1 and tl.turns[0].start_m == 0.0  # everything below 190: one lap-long turn


def test_from_limits_without_turns():
    tl = learner([100.0] * 20)
    assert tl.turns == []
    assert tl.sample_index == [-1] * 20
    assert tl.factors_per_sample() == [1.0] * 20


def test_from_limits_merges_a_turn_across_the_start_line():
    # limited at samples 0..2 and 13..16 (of 17): one turn from 26 m to 6 m past the line
    limits = [50.0] * 3 + [100.0] * 10 + [50.0] * 4
    length = len(limits) * STEP_M  # 34 m
    tl = TurnLearner.from_limits(limits, STEP_M, length, TOP_MPS)
    assert len(tl.turns) == 1
    assert tl.turns[0].start_m == 26.0
    assert tl.turns[0].end_m == pytest.approx(3 * STEP_M + length)  # 40 m, past the line
    assert tl.sample_index == [0] * 3 + [-1] * 10 + [0] * 4


def test_from_limits_merge_keeps_the_other_turns_indexed():
    limits = [50.0] * 2 + [100.0] * 5 + [60.0] * 3 + [100.0] * 5 + [70.0] * 2 + [100.0] * 3 + [50.0] * 2
    length = len(limits) * STEP_M  # 22 samples, 44 m
    tl = TurnLearner.from_limits(limits, STEP_M, length, TOP_MPS)
    assert [(t.start_m, t.end_m) for t in tl.turns] == [(14.0, 20.0), (30.0, 34.0), (40.0, 4.0 + length)]
    assert tl.sample_index == ([2] * 2 + [-1] * 5 + [0] * 3 + [-1] * 5 + [1] * 2 + [-1] * 3 + [2] * 2)
    # every sample's turn covers its position (modulo the lap)
    for i, t in enumerate(tl.sample_index):
        if t >= 0:
            turn = tl.turns[t]
            pos = i * STEP_M if i * STEP_M >= turn.start_m else i * STEP_M + length
            assert turn.start_m <= pos < turn.end_m


def test_factors_per_sample():
    tl = learner(TWO_TURNS)
    tl.turns[0].factor = 1.2
    tl.turns[1].factor = 0.9
    f = tl.factors_per_sample()
    assert f == [1.0] * 10 + [1.2] * 5 + [1.0] * 10 + [0.9] * 3 + [1.0] * 2


# --- observe / end_lap ----------------------------------------------------------------------------

def drive_lap(tl, margins, damaged=()):
    """margins: {sample: margin_m}; damaged: samples where the damage went up."""
    for i, m in margins.items():
        tl.observe(i, m, i in damaged)
    return tl.end_lap()


def test_lap_with_spare_margin_raises_the_factor():
    tl = learner(TWO_TURNS)
    changed = drive_lap(tl, {10: 3.0, 12: 1.0, 14: 2.5})  # turn 0, smallest margin 1 m
    assert changed == 1
    # 1 m of room, 0.5 m of it kept as the target margin: 0.5 m spare
    assert tl.turns[0].factor == pytest.approx(1.0 * (1.0 + 0.5 * 0.05 * 0.5))
    assert tl.turns[1].factor == 1.0  # not driven: unchanged
    assert tl.turns[1].ceiling == MAX_FACTOR


def test_spare_margin_counts_up_to_2_m_and_scales_with_gain():
    tl = learner(TWO_TURNS)
    drive_lap(tl, {11: 5.0, 26: 1.5})
    assert tl.turns[0].factor == pytest.approx(1.05)  # 4.5 m beyond the target margin counts as 2 m
    assert tl.turns[1].factor == pytest.approx(1.0 + 0.5 * 0.05 * 1.0)
    tl = learner(TWO_TURNS, gain=1.0)
    drive_lap(tl, {11: 1.0})
    assert tl.turns[0].factor == pytest.approx(1.0 + 0.05 * 0.5)


def test_room_within_the_target_margin_holds_the_factor():
    tl = learner(TWO_TURNS)
    assert drive_lap(tl, {12: 0.4}) == 0  # on track, but inside the 0.5 m kept to the edge
    assert tl.turns[0].factor == 1.0


def test_zero_margin_changes_nothing():
    tl = learner(TWO_TURNS)
    assert drive_lap(tl, {12: 0.0}) == 0
    assert tl.turns[0].factor == 1.0


def test_going_slightly_off_lowers_the_factor_and_sets_a_ceiling():
    tl = learner(TWO_TURNS)
    tl.turns[0].factor = 1.2
    assert drive_lap(tl, {10: 1.0, 12: -0.5}) == 1
    assert tl.turns[0].factor == pytest.approx(1.2 * 0.98)
    assert tl.turns[0].ceiling == pytest.approx(1.2 * 0.98)
    # a lap with room to spare lifts the ceiling by 1 % only: the turn climbs back slowly
    drive_lap(tl, {12: 2.0})
    assert tl.turns[0].ceiling == pytest.approx(1.2 * 0.98 * CEILING_RECOVERY)
    assert tl.turns[0].factor == pytest.approx(1.2 * 0.98 * CEILING_RECOVERY)
    # and a few clean laps earn the speed back: one bad lap is not for good
    for _ in range(4):
        drive_lap(tl, {12: 2.0})
    assert tl.turns[0].factor > 1.2


def test_a_lap_off_the_line_does_not_lift_the_ceiling():
    tl = learner(TWO_TURNS)
    tl.turns[0].factor = 1.2
    drive_lap(tl, {12: -0.5})
    drive_lap(tl, {12: 0.2})  # clean, but inside the target margin: nothing learned
    assert tl.turns[0].ceiling == pytest.approx(1.2 * 0.98)


def test_going_far_off_or_damage_lowers_more():
    tl = learner(TWO_TURNS)
    tl.turns[0].factor = 1.2
    tl.turns[1].factor = 1.2
    drive_lap(tl, {12: -1.5, 26: 1.0}, damaged={26})
    assert tl.turns[0].factor == pytest.approx(1.2 * 0.96)
    assert tl.turns[0].ceiling == pytest.approx(1.2 * 0.98)
    assert tl.turns[1].factor == pytest.approx(1.2 * 0.96)  # damage in the turn, even with room
    assert tl.turns[1].ceiling == pytest.approx(1.2 * 0.98)


@pytest.mark.parametrize("margins, damage", [({12: -3.5}, 0.0), ({12: 1.0}, 60.0)])
def test_a_crash_costs_the_turn_ten_per_cent_at_once(margins, damage):
    """More than 3 m off, or 50 damage points in one lap, is a crash: the turn drops 10 % and stays
    capped there (a few per cent a lap let dirt-3 crash in the same turn lap after lap)."""
    tl = learner(TWO_TURNS)
    tl.turns[0].factor = 1.2
    for i, m in margins.items():
        tl.observe(i, m, 0.0)
    tl.observe(13, 1.0, damage / 2)  # the damage in two steps adds up
    tl.observe(14, 1.0, damage / 2)
    tl.end_lap()
    assert tl.turns[0].factor == pytest.approx(1.2 * 0.9)
    assert tl.turns[0].ceiling == pytest.approx(1.2 * 0.9)
    assert tl.turns[0].damage_points == 0.0  # forgotten for the next lap
    tl.turns[0].factor = 1.2
    tl.observe(12, 1.0, 40.0)  # below the crash level: the ordinary damage rule
    tl.end_lap()
    assert tl.turns[0].factor == pytest.approx(1.2 * 0.96)


def test_running_wide_by_2_to_3_m_without_damage_is_not_a_crash():
    """g-track-1's last turn ran 2.1 m wide once in a field race: a crash's 10 % there left it
    slower than the learner alone ever makes it (alone it settles after cuts of 2 %, 4 % and 2 %)."""
    tl = learner(TWO_TURNS)
    tl.turns[0].factor = 1.2
    drive_lap(tl, {12: -2.5})
    assert tl.turns[0].factor == pytest.approx(1.2 * 0.96)
    assert tl.turns[0].ceiling == pytest.approx(1.2 * 0.98)


def test_observations_outside_turns_are_ignored():
    tl = learner(TWO_TURNS)
    assert drive_lap(tl, {0: -3.0, 20: -3.0, 29: 5.0}, damaged={0, 20}) == 0
    assert [t.factor for t in tl.turns] == [1.0, 1.0]
    assert [t.ceiling for t in tl.turns] == [MAX_FACTOR, MAX_FACTOR]


def test_each_lap_starts_afresh():
    tl = learner(TWO_TURNS)
    drive_lap(tl, {12: -0.5}, damaged={12})
    after = tl.turns[0].factor
    assert tl.end_lap() == 0  # nothing observed in this lap: nothing changes
    assert tl.turns[0].factor == after
    drive_lap(tl, {12: 0.0})  # the last lap's damage and margin are forgotten
    assert tl.turns[0].factor == after


def test_factors_stay_within_bounds():
    tl = learner(TWO_TURNS)
    for _ in range(100):
        drive_lap(tl, {12: 2.0})
    assert tl.turns[0].factor == pytest.approx(MAX_FACTOR)
    assert tl.turns[0].factor <= MAX_FACTOR
    for _ in range(100):
        drive_lap(tl, {12: -5.0}, damaged={12})
    assert tl.turns[0].factor == pytest.approx(MIN_FACTOR)
    assert tl.turns[0].factor >= MIN_FACTOR
    assert tl.turns[0].ceiling >= MIN_FACTOR


# --- persistence ---------------------------------------------------------------------------------

def test_save_load_round_trip(tmp_path):
    tl = learner(TWO_TURNS)
    drive_lap(tl, {12: 1.3})
    drive_lap(tl, {26: -0.4})
    path = tmp_path / "learned" / "e-track-2--car1-trb1.json"  # the folder is created
    tl.save(path, "e-track-2", "car1-trb1")
    data = json.loads(path.read_text())
    assert data["track"] == "e-track-2" and data["car"] == "car1-trb1"
    assert len(data["turns"]) == 2
    assert not path.with_suffix(".tmp").exists()

    fresh = learner(TWO_TURNS)
    assert fresh.load(path) is True
    for a, b in zip(tl.turns, fresh.turns, strict=False):
        assert b.factor == pytest.approx(a.factor, abs=1e-4)
        assert b.ceiling == pytest.approx(a.ceiling, abs=1e-4)
    assert fresh.turns[0].factor > 1.0
    assert fresh.turns[1].factor < 1.0 and fresh.turns[1].ceiling < MAX_FACTOR


def test_load_matches_turns_by_start_within_10_m(tmp_path):
    path = tmp_path / "l.json"
    path.write_text(json.dumps({"turns": [{"start_m": 26.0, "end_m": 30.0, "factor": 1.3, "ceiling": 1.4},
                                          {"start_m": 62.0, "end_m": 70.0, "factor": 0.9}]}))
    tl = learner(TWO_TURNS)  # turns start at 20 m and 50 m
    assert tl.load(path)
    assert tl.turns[0].factor == 1.3 and tl.turns[0].ceiling == 1.4  # 6 m apart: the same turn
    assert tl.turns[1].factor == 1.0 and tl.turns[1].ceiling == MAX_FACTOR  # 12 m apart: another turn


def test_load_clamps_factors(tmp_path):
    path = tmp_path / "l.json"
    path.write_text(json.dumps({"turns": [{"start_m": 20.0, "end_m": 30.0, "factor": 9.0, "ceiling": 9.0},
                                          {"start_m": 50.0, "end_m": 56.0, "factor": 0.1, "ceiling": 0.2}]}))
    tl = learner(TWO_TURNS)
    assert tl.load(path)
    assert tl.turns[0].factor == MAX_FACTOR and tl.turns[0].ceiling == MAX_FACTOR
    assert tl.turns[1].factor == MIN_FACTOR and tl.turns[1].ceiling == MIN_FACTOR


def test_load_missing_or_broken_file(tmp_path):
    tl = learner(TWO_TURNS)
    assert tl.load(tmp_path / "nothing.json") is False
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert tl.load(bad) is False
    assert [t.factor for t in tl.turns] == [1.0, 1.0]


def drive_lap_on_a_line(tl, errors, margin=0.2):
    """A lap on a racing line: small margins everywhere (the line uses the width), given line errors."""
    for i, err in errors.items():
        tl.observe(i, margin, False, err)
    return tl.end_lap()


def test_holding_the_racing_line_raises_the_factor():
    tl = learner(TWO_TURNS)
    assert drive_lap_on_a_line(tl, {11: 0.2, 12: 0.8}) == 1  # within 1 m outside the line all through
    assert tl.turns[0].factor == pytest.approx(1.0 + 0.5 * 0.02)


def test_fighting_to_stay_near_the_line_lowers_it_and_in_between_holds():
    tl = learner(TWO_TURNS)
    drive_lap_on_a_line(tl, {11: 0.2, 12: 3.2, 26: 2.0})
    assert tl.turns[0].factor == pytest.approx(0.98)  # pushed more than 3 x 1 m outside the line
    assert tl.turns[1].factor == 1.0  # between: unchanged


def test_room_to_the_edge_does_not_raise_a_car_pushed_off_its_line():
    """Understeer on a wide track: the car runs metres outside its line yet far from the edge."""
    tl = learner(TWO_TURNS)
    drive_lap_on_a_line(tl, {11: 4.0, 26: 0.2}, margin=2.5)
    assert tl.turns[0].factor == pytest.approx(0.98)
    assert tl.turns[1].factor == pytest.approx(1.0 + 0.5 * 0.02)  # on its line: the line rule, not the margin


def test_line_errors_do_not_override_leaving_the_track():
    tl = learner(TWO_TURNS)
    drive_lap_on_a_line(tl, {12: 0.1}, margin=-0.5)
    assert tl.turns[0].factor == pytest.approx(0.98)


# --- trials judged by section time --------------------------------------------------------------

def time_lap(tl, t0_s, turn0_s):
    """Enter turn 0 at t0_s and turn 1 turn0_s later (the section of turn 0 is timed)."""
    tl.enter(0, t0_s)
    tl.enter(1, t0_s + turn0_s)


def test_a_raise_that_made_the_section_slower_is_taken_back_and_the_turn_settles():
    tl = learner(TWO_TURNS)
    time_lap(tl, 0.0, 10.0)  # turn 0's section at factor 1.0: 10 s
    drive_lap_on_a_line(tl, {11: 0.2})  # held its line: raised to 1.01
    assert tl.turns[0].factor > 1.0
    time_lap(tl, 30.0, 10.2)  # at the raised factor the section took 10.2 s
    assert tl.turns[0].factor == 1.0 and tl.turns[0].settled
    drive_lap_on_a_line(tl, {11: 0.2})  # holding the line again raises it no more
    assert tl.turns[0].factor == 1.0


def test_a_raise_that_paid_stays_and_the_next_one_is_judged_against_it():
    tl = learner(TWO_TURNS)
    time_lap(tl, 0.0, 10.0)
    drive_lap_on_a_line(tl, {11: 0.2})
    raised = tl.turns[0].factor
    time_lap(tl, 30.0, 9.9)  # faster: kept
    assert tl.turns[0].factor == raised and not tl.turns[0].settled
    assert (tl.turns[0].base_factor, tl.turns[0].base_s) == (raised, pytest.approx(9.9))


def test_a_cut_for_leaving_the_track_is_never_taken_back_and_unsettles_the_turn():
    tl = learner(TWO_TURNS)
    tl.turns[0].settled = True
    time_lap(tl, 0.0, 10.0)
    drive_lap_on_a_line(tl, {12: 0.1}, margin=-0.5)  # off the track: 0.98
    time_lap(tl, 30.0, 11.0)  # slower, but safety first
    assert tl.turns[0].factor == pytest.approx(0.98) and not tl.turns[0].settled


def test_a_spoiled_section_is_not_judged():
    tl = learner(TWO_TURNS)
    time_lap(tl, 0.0, 10.0)
    drive_lap_on_a_line(tl, {11: 0.2})
    raised = tl.turns[0].factor
    tl.enter(0, 30.0, spoiled=True)  # a pit stop in this section
    tl.enter(1, 60.0)
    assert tl.turns[0].factor == raised and not tl.turns[0].settled


def test_an_understeer_cut_that_made_the_section_slower_is_taken_back():
    """Pushed off its line (not off the track) is a pace call, judged like a raise."""
    tl = learner(TWO_TURNS)
    time_lap(tl, 0.0, 10.0)
    drive_lap_on_a_line(tl, {11: 0.2, 12: 3.2})
    assert tl.turns[0].factor == pytest.approx(0.98) and tl.turns[0].eased
    time_lap(tl, 30.0, 10.3)
    assert tl.turns[0].factor == 1.0 and tl.turns[0].settled
    drive_lap_on_a_line(tl, {11: 0.2, 12: 3.2})  # settled: no second understeer cut
    assert tl.turns[0].factor == 1.0


def test_the_line_closes_the_section_so_the_last_turn_of_a_race_is_judged_too():
    tl = learner(TWO_TURNS)
    tl.enter(1, 0.0)
    tl.close(5.0)  # the line: turn 1's section is 5 s at factor 1.0
    drive_lap_on_a_line(tl, {26: 0.2})
    assert tl.turns[1].factor > 1.0
    tl.enter(1, 30.0)
    tl.close(35.5)  # slower at the raised factor, judged at the line (the race's end)
    assert tl.turns[1].factor == 1.0 and tl.turns[1].settled
    assert tl.timing_turn == -1
