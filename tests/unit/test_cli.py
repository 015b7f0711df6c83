"""The command line without TORCS: option types, and the set-up before the name checks."""

from __future__ import annotations

import importlib

import click
import pytest
from click.testing import CliRunner

from boxbox.cli import main_group
from boxbox.cli.types import LAP_LIST, FiniteFloatRange, LapLengths, OutputDir, OutputFile
from boxbox.torcs import catalog
from boxbox.torcs import setup as torcs_setup


@pytest.fixture
def no_torcs(tmp_path, monkeypatch):
    """A machine without TORCS: the paths torcs/paths.py reads point at empty folders."""
    monkeypatch.setenv("BOXBOX_TORCS_LIB", str(tmp_path / "lib"))
    monkeypatch.setenv("BOXBOX_TORCS_DATA", str(tmp_path / "data"))
    caches = (catalog.tracks, catalog.cars, catalog.robot_modules, catalog.robot_indices, catalog.has_pit_lane)
    for cached in caches:
        cached.cache_clear()
    yield tmp_path / "data"
    for cached in caches:
        cached.cache_clear()


class RaceStarted(Exception):
    pass


def test_race_sets_up_torcs_before_checking_names(no_torcs, monkeypatch):
    """On a fresh machine `boxbox race` installs TORCS first: checking the track before that could
    only say 'no TORCS tracks found'."""
    order = []

    def fake_setup(report=None):  # stands in for the package install and the bridge build
        order.append("setup")
        for folder, name in (("tracks/road/g-track-1", "g-track-1"), ("cars/car1-trb1", "car1-trb1")):
            (no_torcs / folder).mkdir(parents=True)
            (no_torcs / folder / f"{name}.xml").write_text("<params/>")
        return "overlay"

    real_check_track = catalog.check_track

    def check_track(name):
        order.append("check track")
        return real_check_track(name)

    def run(cfg, overlay, quiet=False):
        order.append(f"race {cfg.track} ({cfg.category}) on {overlay}")
        raise RaceStarted

    monkeypatch.setattr(torcs_setup, "ensure_ready", fake_setup)
    monkeypatch.setattr(catalog, "check_track", check_track)
    monkeypatch.setattr(importlib.import_module("boxbox.cli.race"), "run_with_progress", run)
    result = CliRunner().invoke(main_group, ["race", "--track", "g-track-1", "--laps", "1"])
    assert isinstance(result.exception, RaceStarted), result.output
    assert order == ["setup", "check track", "race g-track-1 (road) on overlay"]


def test_a_bad_option_fails_before_the_setup(no_torcs, monkeypatch):
    monkeypatch.setattr(torcs_setup, "ensure_ready", lambda report=None: pytest.fail("set-up ran"))
    result = CliRunner().invoke(main_group, ["race", "--laps", "2147483647"])
    assert result.exit_code == 2 and "not in the range 1<=x<=10000" in result.output


def convert(param_type: click.ParamType, text: str):
    return param_type.convert(text, None, None)


def test_number_types_refuse_nan_and_out_of_range():
    budget = FiniteFloatRange(0.1, 3600)
    assert convert(budget, "2.5") == 2.5
    for bad in ("nan", "inf", "1e12", "0", "x"):
        with pytest.raises(click.BadParameter):
            convert(budget, bad)
    assert convert(LAP_LIST, "7, 3,3") == [7, 3]
    with pytest.raises(click.BadParameter):
        convert(LAP_LIST, "0")


def test_race_lengths_are_one_a_list_or_a_range():
    assert convert(LapLengths(), "10") == [10]
    assert convert(LapLengths(), "8,10,12") == [8, 10, 12]
    assert convert(LapLengths(), "6-9") == [6, 7, 8, 9]
    for bad in ("", "0", "9-6", "x-3", "3-", "nan"):
        with pytest.raises(click.BadParameter):
            convert(LapLengths(), bad)


def test_output_paths_are_absolute_and_writable(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert convert(OutputFile(), "r.json") == tmp_path / "r.json"
    assert convert(OutputDir(), "out/r1") == tmp_path / "out" / "r1"
    assert not (tmp_path / "out").exists()  # checked, not made
    assert list(tmp_path.iterdir()) == []  # the write probe leaves nothing behind
    for param_type, text in ((OutputFile(), "missing/r.json"), (OutputFile(), str(tmp_path)),
                             (OutputFile(), "/proc/nope.json"), (OutputDir(), "/proc/nope")):
        with pytest.raises(click.BadParameter):
            convert(param_type, text)
    (tmp_path / "file").write_text("")
    with pytest.raises(click.BadParameter, match="is a file"):
        convert(OutputDir(), "file/run")
