"""The physical limit lap: the least time a car can lap a track in, by a quasi-steady-state lap
simulation (control/lapsim.py) on a minimum-curvature line over the drivable width
(control/trackwidth.py, control/minline.py), with the car's own model: friction circle with
downforce, drag with the wings', the torque curve through the gears, banking, grade, vertical
curvature and each surface's friction, and the skill level's tyre gain (control/tyre.py).

The track and the car come from TORCS itself (torcs/track_record.py: a 0-lap race of the recorder
robot, kept under the cache folder per track and car).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from boxbox.cache import cache_dir
from boxbox.control.carmodel import CarModel, wing_drag_coefficient
from boxbox.control.lapsim import PointMassCar, lap_speeds_mps, lap_time_s
from boxbox.control.minline import closed_curvature, min_curvature_offsets
from boxbox.control.trackwidth import (
    drivable_width,
    grippy_sides,
    pit_exempt,
    side_parts,
    surface_friction,
    turn_direction,
)
from boxbox.errors import BoxboxError
from boxbox.files import atomic_path
from boxbox.model import Car, Track
from boxbox.model.car import FWD
from boxbox.model.skill import SkillLevel
from boxbox.model.track import LEFT, RIGHT
from boxbox.robot.racingline import middle_line, vertical_curvature
from boxbox.torcs.track_record import record_key, recorded_track

STEP_M = 3.0  # sample spacing of the line
WING_ANGLES = 8  # rear wing angles tried, from 0 to the car's own


@dataclass(frozen=True)
class LimitLap:
    """The limit lap of one car on one track: time (s), and per sample the distance along the middle
    (m), the line's offset (m, + left), its speed (m/s) and the room left and right (m)."""

    track: str
    car: str
    skill_level: SkillLevel
    track_limits: str
    lap_time_s: float
    top_speed_mps: float
    dist_m: np.ndarray
    offset_m: np.ndarray
    speed_mps: np.ndarray
    left_m: np.ndarray
    right_m: np.ndarray
    line: str  # which width the fastest line was drawn over
    rear_wing_deg: float = math.nan  # the rear wing angle of the fastest lap (a robot may set it: Robot.car_setup)


def point_mass_car(car: Car, skill_level: SkillLevel, fuel_l: float = 0.0) -> PointMassCar:
    """The lap simulation's car: mass with `fuel_l`, CA with both wings, CW with the wings' drag,
    the weakest tyre's mu at this skill level, the driven wheels' radius, forward gears, torque."""
    model = CarModel.from_car(dataclasses.replace(car, skill_level=int(skill_level)), fuel_l=fuel_l)
    forward = [r for r in car.gear_ratios[car.gear_offset + 1:] if r > 0]
    radius = car.wheel_radius_fr_m if car.drivetrain == FWD else car.wheel_radius_rr_m
    if not forward or not car.torque_curve_nm:
        raise BoxboxError(f"car {car.name}: no forward gears or torque curve recorded")
    cw = model.cw + wing_drag_coefficient(car)
    wheels = ("fr", "fl", "rr", "rl")
    op_loads = [getattr(car, f"tyre_operating_load_{w}_n") for w in wheels]
    return PointMassCar(mass_kg=model.mass_kg, ca_n_per_mps2=model.ca, cw_n_per_mps2=cw,
                        mu=model.mu, wheel_radius_m=radius, gear_ratios=tuple(forward),
                        torque_curve_radps=car.torque_curve_radps, torque_curve_nm=car.torque_curve_nm,
                        limiter_radps=car.rpm_redline or car.rpm_max,
                        load_factor_max=max(getattr(car, f"tyre_load_factor_max_{w}") for w in wheels),
                        load_factor_min=max(getattr(car, f"tyre_load_factor_min_{w}") for w in wheels),
                        operating_load_n=sum(op_loads) if all(op_loads) else 0.0)


def _pit_exempt(track: Track, ids: np.ndarray, side: int) -> np.ndarray:
    pit = track.pit
    return pit_exempt(pit.side if pit else None, pit.entry_seg if pit else 0, pit.exit_seg if pit else 0, ids, side)


def limit_lap(track: Track, car: Car, skill_level: SkillLevel, track_limits: str = "torcs",
              step_m: float = STEP_M) -> LimitLap:
    """The fastest of the minimum-curvature lines over the drivable width and over the track's own
    width (a line over more width is not always faster when the sides have less grip)."""
    mid = middle_line(track, step_m=step_m)
    ids = mid.seg_id[:-1]
    seg = track.seg
    frac = mid.seg_frac[:-1]
    half = mid.half_left_m[:-1]
    left, right = side_parts(seg, ids, frac, "left"), side_parts(seg, ids, frac, "right")
    turn = turn_direction(seg["type"][ids])
    bank = mid.bank_rad[:-1]
    z = mid.z_m[:-1]
    grade = np.clip((np.roll(z, -1) - z) / mid.step_m, -0.5, 0.5)
    kv = vertical_curvature(z, mid.step_m)
    x, y, heading = mid.x_m[:-1], mid.y_m[:-1], mid.heading_rad[:-1]
    nx, ny = -np.sin(heading), np.cos(heading)
    pm = point_mass_car(car, skill_level)
    widths = {"strict": drivable_width("strict", half, turn, left, right, car.width_m)}
    if track_limits == "torcs":
        exempt = _pit_exempt(track, ids, LEFT), _pit_exempt(track, ids, RIGHT)
        widths["torcs"] = drivable_width("torcs", half, turn, left, right, car.width_m, *exempt)
        main_mu = mid.friction[:-1]  # the sides only where they grip as well as the track
        grip_l, grip_r = grippy_sides(left, main_mu), grippy_sides(right, main_mu)
        widths["torcs-grip"] = drivable_width("torcs", half, turn, grip_l, grip_r, car.width_m, *exempt)
    best: LimitLap | None = None
    # a robot may set the rear wing (Robot.car_setup): the limit is the fastest over its range
    wings = [dataclasses.replace(car, rear_wing_angle_rad=float(a))
             for a in np.linspace(0.0, car.rear_wing_angle_rad, WING_ANGLES)] if car.rear_wing_area_m2 > 0 else [car]
    cars = [(c, point_mass_car(c, skill_level)) for c in wings]
    for name, (room_l, room_r) in widths.items():
        off = min_curvature_offsets(x, y, nx, ny, room_l, room_r)
        k, ds = closed_curvature(x + off * nx, y + off * ny)
        mu = pm.mu * surface_friction(off, half, mid.friction[:-1], left, right)
        for wing_car, wing_pm in cars:
            v = lap_speeds_mps(ds, k, np.maximum(mu, 1e-3), wing_pm, kv, bank_rad=bank, grade=grade)
            lap = LimitLap(track=track.name, car=car.name, skill_level=skill_level, track_limits=track_limits,
                           lap_time_s=lap_time_s(ds, v), top_speed_mps=float(v.max()), dist_m=mid.dist_m[:-1],
                           offset_m=off, speed_mps=v, left_m=room_l, right_m=room_r, line=name,
                           rear_wing_deg=round(math.degrees(wing_car.rear_wing_angle_rad), 1))
            if best is None or lap.lap_time_s < best.lap_time_s:
                best = lap
    assert best is not None
    return best


def _model_version() -> str:
    """A hash of the sources the limit lap depends on: a changed model computes its laps again."""
    import boxbox.control.carmodel as carmodel
    import boxbox.control.lapsim as lapsim
    import boxbox.control.minline as minline
    import boxbox.control.trackwidth as trackwidth
    import boxbox.control.tyre as tyre
    import boxbox.robot.racingline as racingline

    digest = hashlib.sha256()
    for module in (carmodel, lapsim, minline, trackwidth, tyre, racingline):
        digest.update(Path(str(module.__file__)).read_bytes())
    digest.update(Path(__file__).read_bytes())
    return digest.hexdigest()[:16]


def limit_for(track: str, car: str, skill_level: SkillLevel, track_limits: str = "torcs") -> LimitLap:
    """limit_lap for a track and car by name (recorded from TORCS when not cached), kept under the
    cache folder per track, car, skill level, track limits and model version."""
    key = f"{track}-{car}-{int(skill_level)}-{track_limits}-{record_key(track, car)}-{_model_version()}"
    path = cache_dir() / "limit" / "laps" / f"{key}.npz"
    try:
        with np.load(path) as z:
            scalars = json.loads(str(z["meta"]))
            return LimitLap(skill_level=SkillLevel(scalars.pop("skill_level")), **scalars,
                            **{f: z[f] for f in _ARRAYS})
    except (OSError, ValueError, KeyError):
        pass
    t, c = recorded_track(track, car)
    c = dataclasses.replace(c, name=car) if not c.name else c
    lap = limit_lap(t, c, skill_level, track_limits)
    meta = {f.name: getattr(lap, f.name) for f in dataclasses.fields(lap) if f.name not in _ARRAYS}
    meta["skill_level"] = int(lap.skill_level)
    arrays: dict[str, Any] = {"meta": np.asarray(json.dumps(meta)), **{f: getattr(lap, f) for f in _ARRAYS}}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
    except OSError:
        pass  # a read-only cache only costs time
    return lap


_ARRAYS = ("dist_m", "offset_m", "speed_mps", "left_m", "right_m")


def plot_limit(lap: LimitLap, path: Path) -> None:
    """Limit speed (km/h) against distance, and the line's offset within the drivable width."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(11, 6), sharex=True, height_ratios=(2, 1))
    ax.plot(lap.dist_m, lap.speed_mps * 3.6, lw=1.2, color="tab:red", label="limit speed")
    ax.set_ylabel("speed (km/h)")
    ax.set_title(f"{lap.track}, {lap.car} ({lap.skill_level.torcs_name}, track limits {lap.track_limits}): "
                 f"limit lap {lap.lap_time_s:.2f} s, top speed {lap.top_speed_mps * 3.6:.0f} km/h")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    bx.fill_between(lap.dist_m, -lap.right_m, lap.left_m, color="0.85", label="drivable width")
    bx.plot(lap.dist_m, lap.offset_m, lw=1.0, color="tab:blue", label="line")
    bx.set_ylabel("offset (m, + left)")
    bx.set_xlabel("distance from the start line (m)")
    bx.grid(alpha=0.3)
    bx.legend(loc="lower right")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def gap_percent(time_s: float, limit_s: float) -> float:
    """How far a lap is above the limit (%); negative: it beats the limit (the model is wrong there)."""
    if not (math.isfinite(limit_s) and limit_s > 0):
        return math.nan
    return 100.0 * (time_s / limit_s - 1.0)
