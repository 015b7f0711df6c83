"""bench-tune's summary (tune/bench_tune.py) on plain numbers."""

from __future__ import annotations

from boxbox.tune.bench_tune import BenchTuneResult, summary_rows


def test_summary_of_the_generalisation_studies_alone_is_empty():
    assert summary_rows(BenchTuneResult(general=[{"track": "g-track-1"}])) == []


def test_summary_rows_per_hour_and_speed_up():
    result = BenchTuneResult(trials=8, trial_wall_s={1: 16.0, 2: 8.5}, run_wall_s={1: 18.0, 2: 10.0},
                             all_trial_wall_s={1: [16.0, 17.0], 2: [8.0, 8.5]}, storage_ms={"journal file": 6.0})
    rows = dict(summary_rows(result))
    assert rows["trials per hour, 1 worker(s)"].startswith("1800 ")
    assert rows["speed-up with 2 workers"].startswith("1.88x") and "2.00x between the fastest" in rows[
        "speed-up with 2 workers"]
    assert rows["storage per trial, journal file"].startswith("6.0 ms (0.30 %")
