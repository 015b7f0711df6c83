"""The race results table, each column once (report/tables.py): the console's and the HTML
report's tables come out byte for byte as the files in tests/data/tables, which the tables wrote
when each table paired its headers and cells by position; DriverResult.from_json checks the types
a result.json may hold from DriverResult's own fields."""

import io
import json
from pathlib import Path

import pytest
from rich.console import Console

from boxbox.report.race_report import _results_table, result_problem
from boxbox.report.tables import COLUMNS, CONSOLE_RESULTS, HTML_RESULTS, results_table
from boxbox.torcs.results import DriverResult, RaceResult

DATA = Path(__file__).parent.parent / "data" / "tables"


def _json(name: str) -> dict:
    return json.loads((DATA / name).read_text())


def test_the_console_table_is_unchanged_byte_for_byte():
    buf = io.StringIO()
    console = Console(file=buf, width=200, force_terminal=True, color_system="truecolor")
    console.print(results_table(RaceResult.from_json(_json("result.json"))))
    assert buf.getvalue() == (DATA / "result_console.txt").read_text()


@pytest.mark.parametrize("name", ["result", "result_partial"])
def test_the_html_table_is_unchanged_byte_for_byte(name):
    assert _results_table(_json(f"{name}.json")) == (DATA / f"{name}_html.txt").read_text()


def test_each_table_names_columns_that_exist():
    assert set(CONSOLE_RESULTS) <= set(COLUMNS) and set(HTML_RESULTS) <= set(COLUMNS)


def test_the_result_round_trips_through_json():
    result = RaceResult.from_json(_json("result.json"))
    assert RaceResult.from_json(json.loads(json.dumps(result.to_json()))) == result


@pytest.mark.parametrize(("driver", "problem"), [
    ({"laps": "3"}, 'drivers[0].laps is "3", not int'),
    ({"time": True}, "drivers[0].time is true, not int or float"),
    ({"step_us_median": "x"}, 'drivers[0].step_us_median is "x", not int or float or null'),
    ({"report": []}, "drivers[0].report is [], not dict"),
    ({"idx": 1.5}, "drivers[0].idx is 1.5, not int"),
    ({"lap_times": ["a"]}, "drivers[0].lap_times holds something other than numbers"),
    ({"pit_events": [1]}, "drivers[0].pit_events holds something other than objects"),
    ({"name": None}, "drivers[0].name is null, not str"),
    # fields the hand-kept list of types left out: now checked as DriverResult declares them
    ({"start_fuel_l": "x"}, 'drivers[0].start_fuel_l is "x", not int or float or null'),
    ({"missed_pit_stops": {}}, "drivers[0].missed_pit_stops is {}, not list"),
])
def test_a_driver_of_the_wrong_type_is_named(driver, problem):
    assert result_problem({"drivers": [driver]}) == problem
    with pytest.raises(ValueError, match="is |holds"):
        DriverResult.from_json({"name": "a", "module": "b", "idx": 0, "car": "c", **driver})


def test_a_race_of_the_wrong_type_is_named():
    assert result_problem({"wall_s": "x"}) == 'wall_s is "x", not int or float'
    assert result_problem({"error": 3}) == "error is 3, not str or null"
    assert result_problem({"drivers": [{"name": "a", "laps": 2, "penalty_time": 1}]}) is None
    with pytest.raises(ValueError, match="laps is true"):
        RaceResult.from_json({"track": "t", "category": "road", "car": "c", "laps": True})
