"""bench-field's figures on plain numbers: places lap by lap, incident laps, a car's field figures."""

from __future__ import annotations

from boxbox.bench.field import car_figures, incident_laps
from boxbox.torcs.positions import positions_by_lap
from boxbox.torcs.results import DriverResult, RaceResult


def test_places_follow_the_sum_of_laps():
    # a leads lap 1, b passes on lap 2, c never finishes lap 2
    places = positions_by_lap([[40.0, 42.0], [41.0, 40.0], [45.0]])
    assert places == [[1, 2], [2, 1], [3]]


def test_a_tie_keeps_the_given_order():
    assert positions_by_lap([[40.0], [40.0]]) == [[1], [2]]


def test_incident_laps_leave_out_lap_one_and_count_slow_laps():
    assert incident_laps([48.0, 40.0, 40.2, 53.0, 40.1]) == (1, 12.85)
    assert incident_laps([48.0, 40.0, 41.9, 40.1]) == (0, 0.0)
    assert incident_laps([48.0]) == (0, 0.0)


def _driver(name, rank, laps, module="bt", idx=0):
    return DriverResult(name=name, module=module, idx=idx, car="car1-trb1", rank=rank, laps=len(laps),
                        time=sum(laps), lap_times=laps, damage=10 * rank)


def test_car_figures_from_the_back():
    winner = _driver("w", 1, [40.0, 40.0, 40.0])
    me = _driver("me", 2, [41.0, 40.0, 40.5], module="boxbox")
    slow = _driver("s", 3, [45.0, 50.0])
    result = RaceResult(track="t", category="road", car="car1-trb1", laps=3, drivers=[winner, me, slow])
    f = car_figures(result, me, start_slot=3)
    assert f["rank"] == 2 and f["gap_s"] == 1.5 and f["laps_down"] == 0
    assert f["lap1_gain"] == 1  # from slot 3 to second after lap 1
    assert f["field_damage"] == 60 and f["damage"] == 20
    lapped = car_figures(result, slow, start_slot=3)
    assert lapped["laps_down"] == 1 and lapped["gap_s"] is None


def test_no_lap_one_gain_without_every_car_s_laps():
    a = _driver("a", 1, [40.0])
    b = DriverResult(name="b", module="bt", idx=1, car="c", rank=2, laps=1, time=41.0)
    result = RaceResult(track="t", category="road", car="c", laps=1, drivers=[a, b])
    assert car_figures(result, a, start_slot=2)["lap1_gain"] is None


# --- several lengths (bench/field_grid.py) ---------------------------------------------------------

def _result(laps, ranks, damage=100, fuel_offset_l=0.0):
    """A FieldResult for two tracks: {track: (robot rank, anchor rank)}, None for a failed race."""
    from boxbox.bench.field import FieldResult, FieldSpec
    rows = []
    for track, (mine, anchor) in ranks.items():
        for role, entry, rank in (("robot", "boxbox", mine), ("anchor", "inferno:3", anchor)):
            rows.append({"track": track, "role": role, "entry": entry, "rank": rank, "damage": damage,
                         "field_damage": 0, "error": None if rank is not None else "torcs-bin hung"})
    return FieldResult(FieldSpec(tracks=list(ranks), laps=laps, fuel_offset_l=fuel_offset_l), rows)


def test_field_grid_sums_places_wins_and_damage_per_car():
    from boxbox.bench.field_grid import FieldGrid
    grid = FieldGrid([_result(8, {"a": (1, 6), "b": (3, 9)}), _result(9, {"a": (2, 5), "b": (None, 9)})])
    assert grid.lengths == [8, 9]
    assert grid.places("robot") == {"a": [1, 2], "b": [3, None]}
    assert grid.damage("robot") == {"a": 200, "b": 100}  # the failed race counts no damage
    assert grid.summary("robot") == {"races": 4, "failed": 1, "places": 6, "mean_place": 2.0, "wins": 1,
                                     "damage": 300}
    assert grid.summary("anchor") == {"races": 4, "failed": 0, "places": 29, "mean_place": 7.25, "wins": 0,
                                      "damage": 400}
    lines = grid.summary_lines()
    assert lines[0] == "boxbox: 4 races, places 6 (mean 2.0), wins 1, damage 300, 1 failed"
    assert grid.labels == ["8", "9"]
    assert lines[1].startswith("inferno:3: 4 races, places 29 (mean 7.25), wins 0")
    assert grid.table().row_count == 4 and len(grid.table().columns) == 6
    assert grid.to_json()["places"]["anchor"] == {"a": [6, 5], "b": [9, 9]}


def test_field_grid_counts_a_car_out_of_the_race_as_last():
    from boxbox.bench.field_grid import FieldGrid
    grid = FieldGrid([_result(10, {"a": (0, 6), "b": (2, 9)})])  # rank 0: out on damage, not a failed race
    assert grid.places("robot") == {"a": [10], "b": [2]}
    assert grid.summary("robot")["places"] == 12
    assert grid.summary("robot")["failed"] == 0


def test_field_grid_counts_the_racecraft_targets_over_every_race():
    from boxbox.bench.field_grid import FieldGrid
    grid = FieldGrid([_result(10, {"a": (1, 6), "b": (7, 5)}, damage=299),
                      _result(10, {"a": (2, 5), "b": (None, 9)}, damage=300)])
    # b's second race failed: no win, not ahead, no damage figure; every race counts in "races"
    assert grid.targets() == {"races": 4, "wins": 1, "low_damage": 2, "ahead_of_anchor": 2,
                              "field_damage_not_higher": 3, "every_target": 1}
    assert grid.summary_lines()[2] == ("boxbox in 4 races: wins 1/4, damage under 300 2/4, ahead of inferno:3 "
                                       "2/4, field damage no higher than with inferno:3 3/4, all four in one race 1/4")
    assert grid.to_json()["targets"]["low_damage"] == 2


def test_a_win_under_300_with_more_field_damage_than_the_anchor_misses_every_target():
    result = _result(10, {"a": (1, 6), "b": (1, 5)}, damage=10)
    result.rows[0]["field_damage"] = 1  # track a: the field took more than in inferno:3's race (0)
    assert result.summary()["wins"] == 2 and result.summary()["low_damage"] == 2
    assert result.summary()["every_target"] == 1


def test_field_grid_needs_a_length():
    import pytest

    from boxbox.bench.field import FieldSpec
    from boxbox.bench.field_grid import run_field_grid
    with pytest.raises(ValueError):
        run_field_grid(FieldSpec(tracks=["a"]), [], None, None)  # type: ignore[arg-type]


def test_field_grid_labels_repeats_of_a_length():
    from boxbox.bench.field_grid import DITHER_L, FieldGrid
    grid = FieldGrid([_result(10, {"a": (1, 6)}), _result(10, {"a": (3, 6)}, fuel_offset_l=DITHER_L),
                      _result(10, {"a": (2, 6)}, fuel_offset_l=2 * DITHER_L)])
    assert grid.labels == ["10 #1", "10 #2", "10 #3"]
    assert grid.places("robot") == {"a": [1, 3, 2]}
    assert grid.summary("robot")["mean_place"] == 2.0
    assert [c.header for c in grid.table().columns][2:5] == ["10 #1", "10 #2", "10 #3"]


def test_field_grid_repeats_raise_the_robot_s_start_fuel(monkeypatch):
    """Each repeat is the same race with DITHER_L more start fuel for the robot (its cache key differs)."""
    import boxbox.bench.field_grid as fg
    from boxbox.bench.field import FieldSpec

    seen = []
    monkeypatch.setattr(fg, "run_fields", lambda specs, overlay, console: seen.append(
        [(spec.laps, spec.fuel_offset_l) for spec in specs])
        or [_result(spec.laps, {"a": (1, 2)}, fuel_offset_l=spec.fuel_offset_l) for spec in specs])
    grid = fg.run_field_grid(FieldSpec(tracks=["a"]), [8, 9], None, None, repeats=2)  # type: ignore[arg-type]
    assert seen == [[(8, 0.0), (8, fg.DITHER_L), (9, 0.0), (9, fg.DITHER_L)]]  # one batch: every run's races at once
    assert grid.labels == ["8 #1", "8 #2", "9 #1", "9 #2"]
    import pytest
    with pytest.raises(ValueError):
        fg.run_field_grid(FieldSpec(tracks=["a"]), [8], None, None, repeats=0)  # type: ignore[arg-type]


def test_fuel_offset_counts_in_the_cache_key_only_when_given():
    from boxbox.bench import cache
    robots = [{"entry": "boxbox", "kind": "python", "version": "v"}]
    plain = cache.cache_key("t", "c", 3, robots, None, "fresh")
    assert cache.cache_key("t", "c", 3, robots, None, "fresh", fuel_offset_l=0.0) == plain
    assert cache.cache_key("t", "c", 3, robots, None, "fresh", fuel_offset_l=0.05) != plain


# --- against an earlier run (bench/field_compare.py) ------------------------------------------------

def _grid_doc(*passes, field_damage=(0, 0)):
    """A grid JSON document: one FieldResult per pass, {track: (robot rank, anchor rank)} each."""
    from boxbox.bench.field_grid import FieldGrid
    doc = FieldGrid([_result(10, ranks) for ranks in passes]).to_json()
    for run in doc["runs"]:
        for row in run["rows"]:
            row["field_damage"] = field_damage[row["role"] == "anchor"]
    return doc


def test_compare_pairs_races_and_sums_the_robot_s_figures():
    from boxbox.bench.field_compare import compare
    base = _grid_doc({"a": (1, 6), "b": (3, 9)}, {"a": (2, 6), "b": (None, 9)}, {"a": (1, 6), "b": (4, 9)})
    new = _grid_doc({"a": (1, 6), "b": (1, 9)}, {"a": (1, 6), "b": (2, 9)}, {"a": (1, 6), "b": (5, 9)},
                    field_damage=(50, 10))
    c = compare(base, new)
    # b's race of the second pass failed in the base: not paired, so 5 races of 6
    assert c.places_by_track == {"a": ([1, 2, 1], [1, 1, 1]), "b": ([3, 4], [1, 5])}
    assert (c.base.races, c.base.places, c.base.wins) == (5, 11, 2)
    assert (c.new.races, c.new.places, c.new.wins) == (5, 9, 4)
    assert c.base.pass_places == [4, 2, 5] and c.new.pass_places == [2, 1, 6]
    assert c.base.field_damage_not_higher == 5 and c.new.field_damage_not_higher == 0
    assert c.base.every_target == 2 and c.new.every_target == 0  # new's four wins: the field took more
    assert c.damage_by_track == {"a": (300, 300), "b": (200, 200)}
    # sqrt(3 var(4, 2, 5) + 3 var(2, 1, 6)) = sqrt(3 x 2.333 + 3 x 7) = 5.29
    assert abs(c.chance_places - 5.29) < 0.01
    lines = c.lines("base.json")
    assert lines[0].startswith("against base.json, 5 races paired: places 11 -> 9 (-2), wins 2 -> 4, damage 500 -> 500")
    assert lines[1].endswith("-2 is within two of them")
    assert c.table("base.json").row_count == 2


def test_compare_refuses_runs_of_other_tracks_or_lengths_and_needs_repeats_for_chance():
    import pytest

    from boxbox.bench.field_compare import compare, passes_of
    one = _grid_doc({"a": (1, 6)})
    assert compare(one, one).chance_places is None
    assert "no spread" in compare(one, one).lines("x")[1]
    with pytest.raises(ValueError, match="same --tracks"):
        compare(one, _grid_doc({"b": (1, 6)}))
    with pytest.raises(ValueError, match="same --tracks"):
        compare(one, _grid_doc({"a": (1, 6)}, {"a": (1, 6)}))
    single = _result(10, {"a": (2, 6)}).to_json()  # one run's file: rows, not runs
    assert compare(single, one).places_by_track == {"a": ([2], [1])}
    with pytest.raises(ValueError, match="not a `boxbox bench-field --json` file"):
        passes_of({"rows": None})
    with pytest.raises(ValueError, match="rows without track, role, rank"):  # caught before racing, not after
        passes_of({"runs": [{"tracks": ["a"], "rows": [{"track": "a"}]}]})


def test_against_file_is_read_and_checked_before_any_race(tmp_path):
    import json

    import click
    import pytest

    from boxbox.cli.types import FieldRunFile
    good = tmp_path / "base.json"
    good.write_text(json.dumps(_grid_doc({"a": (1, 6)})))
    path, doc = FieldRunFile().convert(str(good), None, None)
    assert path == good and doc["runs"][0]["tracks"] == ["a"]
    (tmp_path / "bad.json").write_text("{}")
    for name in ("bad.json", "missing.json"):
        with pytest.raises(click.BadParameter, match="bench-field --json"):
            FieldRunFile().convert(str(tmp_path / name), None, None)
