"""`boxbox bench-telemetry`: what recording telemetry costs the drive step (races with it on and off)."""

from __future__ import annotations

import shutil
import statistics
import tempfile
from pathlib import Path

from rich.table import Table

from boxbox.errors import RaceError
from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.robot.loader import load_robot_class
from boxbox.torcs import catalog, launch
from boxbox.torcs.telemetry import FILE_NAME


def _bench_race(result, mode: str) -> dict:
    """One race's figures."""
    if result.error:
        raise RaceError(f"bench-telemetry, race with telemetry {mode}: {result.error.splitlines()[0]}")
    d = result.drivers[0]
    tel_file = Path(result.run_dir) / FILE_NAME
    return {"mode": mode, "step_us_median": d.step_us_median, "step_us_p99": d.step_us_p99,
            "wall_s": result.wall_s, "laps": d.laps,
            "telemetry_bytes": tel_file.stat().st_size if tel_file.exists() else 0}


def run_telemetry_bench(overlay, track: str, laps: int, runs: int, robot: str, progress=None,
                        skill_level: SkillLevel = DEFAULT_SKILL_LEVEL) -> dict:
    """Per run: a race with telemetry and one without, back to back (on/off, then off/on, ...).
    Returns every race's drive step median and p99 (µs), the ratio on/off of the medians over the
    races, and the back-to-back pairs' ratios (less exposed to the machine's drift)."""
    category = catalog.check_track(track)
    load_robot_class(robot)
    races = []
    for k in range(runs):
        for mode in ("on", "off") if k % 2 == 0 else ("off", "on"):
            run_dir = Path(tempfile.mkdtemp(prefix="boxbox-bench-telemetry-"))  # removed after reading
            cfg = launch.RaceConfig(track=track, category=category, laps=laps, robots=[robot], run_dir=run_dir,
                                    telemetry=mode == "on",
                                    skill_level=skill_level)
            try:
                result = launch.run_race(cfg, overlay)
                race = _bench_race(result, mode)
            finally:
                shutil.rmtree(run_dir, ignore_errors=True)
            races.append(race)
            if progress:
                progress()
    med = {m: statistics.median(r["step_us_median"] for r in races if r["mode"] == m) for m in ("on", "off")}
    # each run's on and off races ran back to back: their ratio is less exposed to the machine's drift
    pairs = []
    for k in range(runs):
        run = {r["mode"]: r for r in races[2 * k: 2 * k + 2]}
        pairs.append(run["on"]["step_us_median"] / run["off"]["step_us_median"])
    return {"track": track, "laps": laps, "runs": runs, "robot": robot, "skill_level": skill_level.torcs_name,
            "races": races,
            "step_us_median_on": med["on"], "step_us_median_off": med["off"], "ratio": med["on"] / med["off"],
            "pair_ratios": pairs, "pair_ratio_median": statistics.median(pairs)}


def table(res: dict) -> Table:
    """Per mode (on, off): the drive step's median and p99, wall time and file size."""
    out = Table(title=f"bench-telemetry: {res['robot']} on {res['track']}, {res['laps']} laps, "
                      f"{res['runs']} races each, skill level {res.get('skill_level', 'semi-pro')}")
    for col in ("telemetry", "step median us", "per race", "step p99 us", "wall s", "file MB"):
        out.add_column(col, justify="right")
    for mode in ("on", "off"):
        rows = [r for r in res["races"] if r["mode"] == mode]
        out.add_row(mode, f"{statistics.median(r['step_us_median'] for r in rows):.2f}",
                    " ".join(f"{r['step_us_median']:.2f}" for r in rows),
                    f"{statistics.median(r['step_us_p99'] for r in rows):.1f}",
                    f"{statistics.median(r['wall_s'] for r in rows):.2f}",
                    f"{statistics.median(r['telemetry_bytes'] for r in rows) / 1e6:.2f}")
    return out


def summary_lines(res: dict) -> list[str]:
    lines = [f"step median with telemetry {res['step_us_median_on']:.2f} us, "
             f"without {res['step_us_median_off']:.2f} us",
             f"step time ratio, telemetry on / off: {res['ratio']:.3f} (medians over the races); "
             f"per pair of back-to-back races: median {res['pair_ratio_median']:.3f}, "
             f"range {min(res['pair_ratios']):.3f}-{max(res['pair_ratios']):.3f}"]
    return lines
