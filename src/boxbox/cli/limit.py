"""`boxbox limit`: the physical limit lap time of a car on a track (bench/limit.py)."""

from __future__ import annotations

import click

from boxbox.cli.common import out, ready
from boxbox.cli.types import Choice, OutputFile, skill_level_option
from boxbox.files import write_json_atomic
from boxbox.options import TRACK_LIMITS


@click.command()
@click.option("--track", required=True, help="Track name, e.g. aalborg (`boxbox tracks`).")
@click.option("--car", default="car1-trb1", show_default=True, help="Car name (`boxbox cars`).")
@skill_level_option
@click.option("--track-limits", type=Choice(TRACK_LIMITS), default="torcs", show_default=True,
              help="torcs: the width TORCS allows without a penalty, up to the barriers; strict: the track's edges.")
@click.option("--plot", "plot_file", type=OutputFile(),
              help="Write limit speed against distance as a PNG, e.g. --plot l.png.")
@click.option("--json", "json_file", type=OutputFile(),
              help="Write the time and, per sample, distance, offset and limit speed as JSON.")
def limit(track, car, skill_level, track_limits, plot_file, json_file) -> None:
    """Print the least lap time this car can do on this track, by a lap simulation on a
    minimum-curvature line over the drivable width (docs/limit.md).

    Example: boxbox limit --track aalborg --car car1-trb1 --plot aalborg.png
    """
    from boxbox.bench.limit import limit_for, plot_limit
    from boxbox.torcs import checks

    ready()
    checks.check_race(track, car, 1, [], [], 1)
    lap = limit_for(track, car, skill_level, track_limits)
    out.print(f"{track} {car} ({skill_level.torcs_name}, track limits {track_limits}): limit lap "
              f"{lap.lap_time_s:.2f} s, top speed {lap.top_speed_mps * 3.6:.1f} km/h (line over the {lap.line} width)")
    if json_file is not None:
        write_json_atomic(json_file, {
            "track": track, "car": car, "skill_level": skill_level.torcs_name, "track_limits": track_limits,
            "lap_time_s": round(lap.lap_time_s, 3), "top_speed_mps": round(lap.top_speed_mps, 3), "line": lap.line,
            "dist_m": lap.dist_m.round(2).tolist(), "offset_m": lap.offset_m.round(3).tolist(),
            "speed_mps": lap.speed_mps.round(3).tolist()})
        out.print(f"json: {json_file}")
    if plot_file is not None:
        plot_limit(lap, plot_file)
        out.print(f"plot: {plot_file}")
