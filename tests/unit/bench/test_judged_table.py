"""The judged table of a bench run (bench/judged_table.py) and two of them compared
(bench/judged_compare.py), on plain rows and on a slice of a real `bench --cars all --json` run
(tests/data/bench: 5 cars x 5 tracks, semi-pro, 3 laps, boxbox and every Debian robot in each car;
cars_main.json from main, cars_changed.json from a changed robot, both raced 2026-12-02)."""

from __future__ import annotations

import json
from pathlib import Path

import click
import pytest
from rich.console import Console

from boxbox.bench.judged_compare import compare_docs, mismatch
from boxbox.bench.judged_table import check_doc, is_torcs_entry, judged_tables

DATA = Path(__file__).resolve().parents[2] / "data" / "bench"


def _row(robot: str, track: str = "g-track-1", car: str = "car1-trb1", time: float = 100.0, damage: int = 0,
         laps: int = 3, error: str | None = None, category: str = "road") -> dict:
    return {"track": track, "car": car, "robot": robot, "laps": laps, "time": time, "damage": damage,
            "error": error, "category": category}


def _doc(rows: list[dict], laps: int = 3) -> dict:
    return check_doc({"laps": laps, "tracks": list(dict.fromkeys(r["track"] for r in rows)),
                      "cars": list(dict.fromkeys(r["car"] for r in rows)),
                      "robots": list(dict.fromkeys(r["robot"] for r in rows)), "skill_level": "semi-pro",
                      "rows": rows})


def _load(name: str) -> dict:
    return check_doc(json.loads((DATA / name).read_text()))


def _reasons(rows: list[dict]) -> dict[tuple[str, str], tuple[str, ...]]:
    return {k: c.reasons for k, c in judged_tables(_doc(rows))[0].cells.items()}


def test_torcs_entries_are_module_and_index():
    assert is_torcs_entry("bt:2") and is_torcs_entry("inferno:10")
    for python in ("boxbox", "my_robot.py:MyRobot", "pkg.mod:Robot", "robots/bt:2", "x.py:3"):
        assert not is_torcs_entry(python), python


def test_the_miss_rule_each_way():
    reasons = _reasons([
        _row("boxbox", track="a", time=100.0),  # passes: alone, no damage
        _row("boxbox", track="b", damage=100),  # road: damage 100 misses
        _row("boxbox", track="c", damage=99, category="oval"),  # 99 passes
        _row("boxbox", track="d", damage=5000, category="dirt"),  # dirt: damage does not count
        _row("boxbox", track="e", laps=2),  # not finished
        _row("boxbox", track="f", error="TORCS crashed"),  # an error: not finished
        _row("boxbox", track="g", time=101.0), _row("bt:2", track="g", time=100.964),  # behind a Debian robot
        _row("boxbox", track="h", time=100.0), _row("bt:2", track="h", time=100.0),  # a tie is no faster
        _row("boxbox", track="i", time=100.0), _row("bt:2", track="i", time=90.0, laps=2),  # it did not finish
    ])
    assert {t: r for (_, t), r in reasons.items() if r} == {
        "b": ("damage 100",), "e": ("not finished (2 of 3 laps)",), "f": ("not finished (3 of 3 laps, TORCS crashed)",),
        "g": ("0.036 s behind bt:2",), "h": ("0.000 s behind bt:2",)}


def test_a_debian_robot_counts_only_in_its_own_car():
    reasons = _reasons([_row("boxbox", car="p406", time=120.0), _row("bt:2", car="car1-trb1", time=100.0),
                        _row("boxbox", car="car1-trb1", time=99.0)])
    assert not any(reasons.values())


def test_cell_text_is_written_as_docs_pace_md_has_it():
    table = judged_tables(_doc([_row("boxbox", track="a", time=286.794, damage=161),
                                _row("bt:2", track="a", time=306.2),
                                _row("boxbox", track="b", laps=2, damage=10930),
                                _row("boxbox", track="a", car="p406", time=300.0, damage=12),
                                _row("boxbox", track="b", car="p406", time=200.0)]))[0]
    assert table.markdown().splitlines() == ["| car | a | b |", "|---|---|---|",
                                             "| car1-trb1 | **286.794 (161) / 306.200** | **2 laps (10930)** |",
                                             "| p406 | 300.000 (12) | 200.000 |"]


def test_the_real_slice_counts_its_misses_damage_and_sums():
    table = judged_tables(_load("cars_main.json"))[0]
    assert (table.robot, len(table.cells), len(table.misses), table.damage) == ("boxbox", 25, 7, 14585)
    assert table.cells["buggy", "mixed-2"].damage == 402 and not table.cells["buggy", "mixed-2"].miss  # dirt
    assert table.summed_s("car1-ow1") == (pytest.approx(767.742), 5)
    assert table.cells["car1-ow1", "g-track-1"].debian == "inferno:1"
    text = Console(width=300, record=True)
    text.print(table.grid())
    assert "1197" in text.export_text() and "bold red" not in text.export_text()


def test_two_runs_compared_cell_by_cell_and_in_sum():
    comparison = compare_docs(_load("cars_main.json"), _load("cars_changed.json"))[0]
    total = comparison.total
    assert (total.base_misses, total.run_misses, total.base_damage, total.run_damage) == (7, 6, 14585, 13927)
    assert [(r.car, r.track) for _, r in comparison.new_misses] == [("car1-stock1", "michigan")]  # damage 77 -> 118
    assert comparison.run.cells["buggy", "aalborg"].reasons == ("not finished (2 of 3 laps)",)  # missed before too
    cleared = [(b.car, b.track) for b, _ in comparison.cleared]
    assert cleared == [("car1-ow1", "e-track-4"), ("car1-stock2", "g-track-1")]
    buggy = next(c for c in comparison.cars if c.car == "buggy")
    assert buggy.cells == 4  # aalborg unfinished in one run: left out of both sums
    ow1 = next(c for c in comparison.cars if c.car == "car1-ow1")
    assert (ow1.base_s, ow1.run_s) == (pytest.approx(767.742), pytest.approx(767.83))
    assert total.cells == 24 and total.ratio == pytest.approx(total.run_s / total.base_s)
    moved = [(b.car, b.track) for b, _ in comparison.moved]
    assert moved[0] == ("buggy", "e-track-4") and len(moved) == 10  # -24.045 s, the largest move
    lines = comparison.lines("base.json")
    assert lines[0].startswith("against base.json (boxbox there, boxbox here): misses 7 -> 6, "
                               "table damage 14,585 -> 13,927")


def test_the_level_table_one_car_many_tracks_is_summed_over_the_tracks():
    base = _doc([_row("boxbox", track=t, time=100.0 + i) for i, t in enumerate(("a", "b", "c"))])
    run = _doc([_row("boxbox", track=t, time=99.0 + i) for i, t in enumerate(("a", "b", "c"))])
    comparison = compare_docs(base, run)[0]
    assert (comparison.total.base_s, comparison.total.run_s) == (303.0, 300.0)
    assert comparison.cars[0].ratio == pytest.approx(300.0 / 303.0)
    assert judged_tables(run)[0].markdown().splitlines()[:3] == ["| track | car1-trb1 |", "|---|---|", "| a | 99.000 |"]
    assert judged_tables(run)[0].summary_line().endswith("; summed time 300.000 s over the 3 of 3 tracks finished")


def test_runs_of_other_tracks_cars_laps_or_robots_do_not_compare():
    base = _doc([_row("boxbox", track="a"), _row("boxbox", track="b")])
    assert mismatch(base, base) is None
    assert mismatch(base, _doc([_row("boxbox", track="a"), _row("boxbox", track="b")], laps=5)) == \
        "it raced 3 laps, this run 5"
    assert mismatch(base, _doc([_row("boxbox", track="a")])) == "it raced other tracks (only there: b)"
    assert mismatch(base, _doc([_row("boxbox", track=t, car="p406") for t in "ab"])) == \
        "it raced other cars (only there: car1-trb1; only here: p406)"
    assert mismatch(base, _doc([_row("mine.py:Mine", track=t) for t in "ab"])) is None  # one robot against another
    with pytest.raises(ValueError, match="only there: b"):
        compare_docs(base, _doc([_row("boxbox", track="a")]))


def test_a_file_that_is_not_a_bench_run_is_refused_before_any_race(tmp_path):
    from boxbox.cli.types import BenchRunFile

    path, doc = BenchRunFile().convert(str(DATA / "cars_main.json"), None, None)
    assert path == DATA / "cars_main.json" and doc["laps"] == 3
    (tmp_path / "field.json").write_text(json.dumps({"runs": []}))
    (tmp_path / "torcs_only.json").write_text(json.dumps(dict(_doc([_row("boxbox"), _row("bt:2")]), robots=["bt:2"])))
    (tmp_path / "old.json").write_text(json.dumps(dict(_doc([_row("boxbox")]), rows=[{"track": "a"}])))
    for name, why in (("field.json", "no laps, tracks"), ("torcs_only.json", "no Python robot"),
                      ("old.json", "rows without"), ("missing.json", "cannot read")):
        with pytest.raises(click.BadParameter, match=why):
            BenchRunFile().convert(str(tmp_path / name), None, None)


def test_bench_table_prints_the_table_and_the_comparison_from_files():
    from click.testing import CliRunner

    from boxbox.cli import main_group

    result = CliRunner().invoke(main_group, ["bench-table", str(DATA / "cars_changed.json"), "--against",
                                             str(DATA / "cars_main.json")], terminal_width=250)
    assert result.exit_code == 0, result.output
    assert "boxbox: 6 of 25 cells miss" in result.output
    assert "misses 7 -> 6, table damage 14,585 -> 13,927" in result.output
    assert "car1-stock1 michigan: 112.476 (77) / 121.336 -> 111.386 (118) / 121.336 (damage 118)" in result.output
    markdown = CliRunner().invoke(main_group, ["bench-table", str(DATA / "cars_main.json"), "--markdown"])
    assert "| buggy | **494.799 (1767)** | 203.938 (402) |" in markdown.output


def test_bench_against_a_run_of_other_tracks_exits_2_before_any_race(tmp_path, monkeypatch):
    from click.testing import CliRunner

    import boxbox.bench.solo as solo
    import boxbox.cli.benches as benches
    from boxbox.cli import main_group

    class RaceStarted(Exception):
        pass

    def no_race(*args, **kwargs):
        raise RaceStarted

    monkeypatch.setattr(benches, "ready", lambda: None)
    monkeypatch.setattr(solo, "plan", no_race)
    monkeypatch.setattr(solo, "run_bench", no_race)
    args = ["bench", "--cars", "buggy,car1-ow1,car1-stock1,car1-stock2,car1-trb3", "--against",
            str(DATA / "cars_main.json")]
    result = CliRunner().invoke(main_group, [*args, "--tracks", "e-track-4,mixed-2,g-track-1,aalborg"])
    assert result.exit_code == 2 and "it raced other tracks (only there: michigan)" in result.output, result.output
    result = CliRunner().invoke(main_group, [*args, "--tracks", "e-track-4,mixed-2,g-track-1,aalborg,michigan"])
    assert isinstance(result.exception, RaceStarted)  # the same tracks, cars and laps: on to the race
