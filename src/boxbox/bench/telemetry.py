"""`boxbox bench-telemetry`: what recording telemetry costs the drive step (races with it on, off, alternating)."""

from __future__ import annotations

import json
import shutil
import statistics
import tempfile
from pathlib import Path

from rich.table import Table

from boxbox.errors import RaceError
from boxbox.model.skill import DEFAULT_SKILL_LEVEL, SkillLevel
from boxbox.robot.loader import load_robot_class
from boxbox.torcs import catalog, launch
from boxbox.torcs.telemetry import FILE_NAME, METADATA_KEY


def _bench_race(result, mode: str) -> dict:
    """One race's figures; for a race recording odd laps only, the recorded and unrecorded laps' medians."""
    if result.error:
        raise RaceError(f"bench-telemetry, race with telemetry {mode}: {result.error.splitlines()[0]}")
    d = result.drivers[0]
    tel_file = Path(result.run_dir) / FILE_NAME
    laps_on = laps_off = None
    if mode == "alternate" and tel_file.exists():
        import pyarrow.parquet as pq

        meta = json.loads(pq.read_schema(tel_file).metadata[METADATA_KEY])
        per_lap = meta["cars"][0].get("lap_step_us", [])
        on = [us for _, recorded, us in per_lap if recorded]
        off = [us for _, recorded, us in per_lap if not recorded]
        if on and off:
            laps_on, laps_off = statistics.median(on), statistics.median(off)
    return {"mode": mode, "step_us_median": d.step_us_median, "step_us_p99": d.step_us_p99,
            "laps_on_us": laps_on, "laps_off_us": laps_off, "wall_s": result.wall_s, "laps": d.laps,
            "telemetry_bytes": tel_file.stat().st_size if tel_file.exists() else 0}


def run_telemetry_bench(overlay, track: str, laps: int, runs: int, robot: str, progress=None,
                        skill_level: SkillLevel = DEFAULT_SKILL_LEVEL) -> dict:
    """Per run: a race with telemetry and one without, back to back (on/off, then off/on, ...), and
    a third that records only its odd laps.  Returns every race's drive step median and p99 (µs),
    the ratio on/off of the medians over the races, the back-to-back pairs' ratios, and from the
    alternating races the ratio of the recorded laps' step median to the unrecorded laps' (laps
    last about 0.1 s of wall time, so this comparison is free of the machine's drift)."""
    category = catalog.check_track(track)
    load_robot_class(robot)
    races = []
    for k in range(runs):
        for mode in (("on", "off") if k % 2 == 0 else ("off", "on")) + ("alternate",):
            run_dir = Path(tempfile.mkdtemp(prefix="boxbox-bench-telemetry-"))  # removed after reading
            cfg = launch.RaceConfig(track=track, category=category, laps=laps, robots=[robot], run_dir=run_dir,
                                    telemetry=mode != "off", telemetry_alternate=mode == "alternate",
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
        run = {r["mode"]: r for r in races[3 * k: 3 * k + 3]}
        pairs.append(run["on"]["step_us_median"] / run["off"]["step_us_median"])
    alt = [r for r in races if r["mode"] == "alternate" and r["laps_on_us"] is not None]
    return {"track": track, "laps": laps, "runs": runs, "robot": robot, "skill_level": skill_level.torcs_name,
            "races": races,
            "step_us_median_on": med["on"], "step_us_median_off": med["off"], "ratio": med["on"] / med["off"],
            "pair_ratios": pairs, "pair_ratio_median": statistics.median(pairs),
            "lap_ratios": [r["laps_on_us"] / r["laps_off_us"] for r in alt],
            "lap_ratio_median": statistics.median(r["laps_on_us"] / r["laps_off_us"] for r in alt) if alt else None}


def table(res: dict) -> Table:
    """Per mode (on, off, alternate): the drive step's median and p99, wall time and file size."""
    out = Table(title=f"bench-telemetry: {res['robot']} on {res['track']}, {res['laps']} laps, "
                      f"{res['runs']} races each, skill level {res.get('skill_level', 'semi-pro')}")
    for col in ("telemetry", "step median us", "per race", "step p99 us", "wall s", "file MB"):
        out.add_column(col, justify="right")
    for mode in ("on", "off", "alternate"):
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
    if res["lap_ratio_median"] is not None:
        lines.append("within the races recording odd laps only: step median of the recorded laps / of the others: "
                     f"median {res['lap_ratio_median']:.3f}, per race "
                     + " ".join(f"{x:.3f}" for x in res["lap_ratios"]))
    return lines
