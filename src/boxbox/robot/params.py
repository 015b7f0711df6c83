"""The tutorial robot's parameters: typed, with the tutorial's values as defaults.

Overrides come from TOML files next to the robot, like TORCS setup files, applied in order:
  setups/default.toml, setups/<car>/default.toml, setups/<car>/<track>.toml
then `--set key=value` on the command line.  Unknown keys and wrong types are errors.
The environment variable BOXBOX_SETUPS points at another setups folder (tests use it).
`boxbox params --track T --car C` prints the effective values and where each came from.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

from boxbox.errors import UsageError
from boxbox.robot.pit import PitParams
from boxbox.robot.racecraft import RacecraftParams
from boxbox.robot.unstuck import UnstuckParams

SETUPS = Path(__file__).parent / "setups"


def setups_dir() -> Path:
    """$BOXBOX_SETUPS, else the setups folder next to the robot."""
    env = os.environ.get("BOXBOX_SETUPS")
    return Path(env) if env else SETUPS


PIT_DEFAULTS = PitParams()  # the pit_* parameters' defaults
UNSTUCK_DEFAULTS = UnstuckParams()  # the stuck_* parameters' defaults


@dataclass(frozen=True)
class TutorialParams(RacecraftParams):
    # racecraft's parameters (braking and yielding behind and beside a car, passing, wrecks) come
    # first, from RacecraftParams (robot/racecraft.py): set like every other one
    # steering: "lookahead" = the tutorial's target point (17 m + 0.33 s x speed ahead);
    # "line" = follow the racing line (curvature feed-forward + heading and distance corrections)
    steering: str = "line"
    lookahead_m: float = 17.0
    lookahead_s: float = 0.33
    line_preview_s: float = 0.05  # "line": take heading and curvature this far ahead (actuation lag)
    line_lateral_gain: float = 2.0
    line_yaw_damping_s: float = 0.05
    # "line": extra steer per m/s^2 of lateral acceleration, at rest: less as downforce loads the tyres
    line_understeer_rad_per_mps2: float = 0.003
    line_speed_margin_s: float = 0.04  # more room outside a fast turn: s x speed x share of grip used
    racing_line: float = 1.0  # 0 = the tutorial's middle line, 1 = the optimised line
    line_margin_m: float = 1.2  # racing line's distance from the track edge (car centre)
    # the width the line may use: "torcs" (what TORCS allows without penalty, the sides that grip
    # like the track included; robot/drivable.py) or "strict" (the track's edges).  torcs by default
    # since the constrained line: over all 38 tracks as fast or faster on all but forza (+0.23 s),
    # aalborg -1.45 s, mixed-2 -1.25 s, mixed-1 -0.72 s, no penalty (docs/tutorial-robot.md item 18)
    track_limits: str = "torcs"
    # car setup: the rear wing angle per track from the lap simulation (robot/carsetup.py), never
    # below the angle that keeps the rear's downforce per weight rear_balance x the front's
    wing_setup: bool = True
    rear_balance: float = 1.5
    side_catch_m: float = 0.6  # "torcs": room kept from where the usable sides end (grass, gravel, wall)
    cut_catch_m: float = 0.5  # "torcs": room kept from the cutting limit inside a turn (no slide inwards)
    # speed
    # cornering grip relative to the model's (surface x tyre friction with the skill level's skid
    # bonus, the weaker axle's downforce, banking): 1.0 with braking on 0.7 measured best over all 38
    # installed tracks at once (mu 0.95 to 1.05, brake 0.7 to 0.8 tried, `boxbox bench --tracks
    # all`, on the constrained minimum-curvature line); the shipped tutorial robot: 0.69
    mu_scale: float = 1.0
    brake_mu_scale: float = 0.7  # braking grip, same base (the shipped robot brakes on surface friction alone)
    brake_method: str = "exact"  # braking distance: "exact" or "approx" (the seed's formula)
    friction_circle: bool = True  # brake less where the line turns (grip shared with cornering)
    elevation: bool = True  # crests unload the tyres and dips load them: turn and brake accordingly
    banking: bool = True  # a road banked into the turn carries the car faster (and one banked away slower)
    crest_load_share: float = 0.5  # over a crest keep at least this share of the car's weight on the tyres
    bump_accel_mps2: float = 4.0  # over short bumps (a washboard) keep v^2 x their curvature below this
    kink_accel_mps2: float = 12.0  # ... and over a single rough kink (a jump's lip) below this
    packer_impact_mps: float = 1.5  # slow where a wheel would hit its packers faster than this (100: never)
    max_speed_mps: float = 100.0
    speed_lookahead_s: float = 0.06  # compare speed with the profile this far ahead (latency)
    full_accel_margin_mps: float = 1.0
    brake_band_mps: float = 2.0  # brake fully this far above the target speed (in proportion below it)
    # clutch at the start (1 = open): slips from clutch_start down to closed at clutch_release_mps
    clutch_start: float = 0.7
    clutch_release_mps: float = 15.0
    # gears (the tutorial's gear changing chapter)
    shift: float = 0.9
    shift_margin_mps: float = 4.0
    # traction control and ABS (slip in m/s)
    abs_slip_mps: float = 2.0
    abs_range_mps: float = 5.0
    # the ABS's bang (full, released, full: half the braking) held off this far over the target
    # speed, four brake bands (car1-stock1 into street-1's hairpin: up to 13; at 6 car1-trb1 was held
    # on spring): the release after a full step keeps abs_hold_share of it (traction.abs_hold;
    # 100: never)
    abs_hold_over_mps: float = 8.0
    abs_hold_share: float = 0.5
    tcl_slip_mps: float = 2.0
    tcl_slip_ratio: float = 0.15  # ... or this share of the speed, where more (the tyre peaks at a slip ratio)
    tcl_range_mps: float = 10.0
    slip_min_speed_mps: float = 3.0
    spin_yaw_rate_rps: float = 0.7  # no throttle while turning this much faster than the line, against the steering
    counter_lock_accel: float = 0.2  # the same while counter-steering at the lock (the rear is out)
    lock_accel: float = 0.4  # most throttle while the steering is at its lock (the car cannot follow its line)
    # getting unstuck: robot/unstuck.py's UnstuckParams, the one home of their defaults and what each means
    stuck_angle_deg: float = UNSTUCK_DEFAULTS.angle_deg
    stuck_speed_mps: float = UNSTUCK_DEFAULTS.speed_mps
    stuck_offset_m: float = UNSTUCK_DEFAULTS.offset_m
    stuck_time_s: float = UNSTUCK_DEFAULTS.time_s
    # opponents
    front_range_m: float = 200.0
    back_range_m: float = 50.0
    length_margin_m: float = 3.0
    side_margin_m: float = 1.0
    overtake_step_m: float = 0.1  # lateral offset change per drive step
    keep_side_s: float = 2.0  # a car reached within this long is passed on the side we are on (0: off)
    # a car close ahead this much slower than our lap simulation goes there is passed even at our
    # speed (we follow it in its slipstream; 0: only a car slower than us, the tutorial's)
    draft_mps: float = 0.0
    draft_after_s: float = 0.0  # ... once we have followed it (close ahead in our lane) this long
    draft_straight_m: float = 0.0  # ... with this much road before the next braking zone (400: none in sight)
    draft_last_lap: bool = False  # ... on the last lap only (a finish in a car's slipstream: 0.1-0.2 s behind it)
    # the fixed-gap brake as the share of a full brake that slows us to the car's speed before the gap
    # is down to this many metres (0: the tutorial's full brake; 1 m in 190 field races: +11 places,
    # +24 % damage, docs/racecraft.md's table)
    soft_gap_m: float = 0.0
    # brake for a car out of control ahead (sliding more than this many degrees off its heading, or
    # crossing the road) where its slide takes it by the time we reach it (0: off; docs/racecraft.md's table)
    hazard_slip_deg: float = 0.0
    lapped_own_side: bool = False  # a car we lap passed on our side of it (for a robot moving away from us; off)
    # pit: robot/pit.py's PitParams, the one home of their defaults and what each means
    pit_lookahead_m: float = PIT_DEFAULTS.lookahead_m
    pit_brake_mu_scale: float = PIT_DEFAULTS.brake_mu_scale
    pit_give_up_s: float = PIT_DEFAULTS.give_up_s
    pit_stop_threshold_m: float = PIT_DEFAULTS.stop_threshold_m
    pit_stop_grip_share: float = PIT_DEFAULTS.stop_grip_share
    # learning
    learning: bool = True
    learn_gain: float = 1.0  # share of the spare margin turned into turn grip per lap (2 % a lap on a held line)
    learn_margin_m: float = 0.5  # room to the track edge the learning keeps in every turn
    learn_steady_error_m: float = 1.5  # racing line: within this of the line near the apex raises a turn, 3x lowers it


@dataclass(frozen=True)
class Bound:
    """The values a number parameter may take; `log`: search it on a log scale (boxbox tune)."""

    lo: float = 0.0
    hi: float = math.inf
    log: bool = False


# declared bounds; every other number parameter is finite and >= 0
BOUNDS = {
    "rear_balance": Bound(0.5, 3.0), "side_catch_m": Bound(0.0, 10.0), "cut_catch_m": Bound(0.0, 10.0),
    "mu_scale": Bound(0.3, 1.5), "brake_mu_scale": Bound(0.3, 1.5), "racing_line": Bound(0.0, 1.0),
    "line_speed_margin_s": Bound(0.0, 0.2),
    "line_margin_m": Bound(0.0, 5.0), "lookahead_m": Bound(1.0, 60.0), "lookahead_s": Bound(0.0, 2.0),
    "line_lateral_gain": Bound(0.1, 10.0, log=True), "line_yaw_damping_s": Bound(0.0, 1.0),
    "line_understeer_rad_per_mps2": Bound(0.0, 0.02), "crest_load_share": Bound(0.0, 1.0),
    "bump_accel_mps2": Bound(0.5, 50.0, log=True),
    "kink_accel_mps2": Bound(0.5, 50.0, log=True),
    "packer_impact_mps": Bound(0.01, 100.0, log=True), "max_speed_mps": Bound(10.0, 150.0),
    "brake_band_mps": Bound(0.1, 10.0, log=True), "full_accel_margin_mps": Bound(0.1, 10.0, log=True),
    "clutch_start": Bound(0.0, 1.0), "shift": Bound(0.5, 0.999), "shift_margin_mps": Bound(0.0, 20.0),
    "abs_slip_mps": Bound(0.1, 20.0, log=True), "tcl_slip_mps": Bound(0.1, 20.0, log=True),
    "tcl_slip_ratio": Bound(0.0, 0.5), "abs_hold_over_mps": Bound(0.0, 100.0), "abs_hold_share": Bound(0.0, 1.0),
    "counter_lock_accel": Bound(0.0, 1.0), "lock_accel": Bound(0.0, 1.0),
    "pit_brake_mu_scale": Bound(0.1, 1.5), "pit_stop_grip_share": Bound(0.1, 1.0),
    "soft_gap_m": Bound(0.0, 10.0), "hazard_slip_deg": Bound(0.0, 90.0),
    "margin_m": Bound(0.1, 20.0), "close_brake": Bound(0.0, 1.0), "hold_line_grip_share": Bound(0.05, 2.0),
    "learn_gain": Bound(0.0, 1.0), "learn_margin_m": Bound(0.0, 3.0), "learn_steady_error_m": Bound(0.1, 5.0),
}


def bound_of(name: str) -> Bound:
    return BOUNDS.get(name, Bound())


CHOICES = {"steering": ("line", "lookahead"), "brake_method": ("exact", "approx"), "track_limits": ("torcs", "strict")}


def example_setting(name: str, default: bool | int | float | str, origin: str) -> str:
    """A right value for a setting, its default, written the way origin takes it: a --set pair, or a
    TOML line in a file (for the hint of an error)."""
    text = ("true" if default else "false") if isinstance(default, bool) else (
        f"{default:g}" if isinstance(default, float) else str(default))
    if origin == "--set":
        return f"e.g. --set {name}={text}"
    return f"e.g. {name} = {text!r}" if isinstance(default, str) else f"e.g. {name} = {text}"


def _example(name: str, origin: str) -> str:
    return example_setting(name, getattr(TutorialParams(), name), origin)


def _coerce(name: str, value, kind, origin: str):
    if kind is float and isinstance(value, (int, float)) and not isinstance(value, bool):
        b = bound_of(name)
        if not (math.isfinite(value) and b.lo <= value <= b.hi):
            upper = "" if math.isinf(b.hi) else f" to {b.hi:g}"
            raise UsageError(f"{origin}: {name} must be a finite number from {b.lo:g}{upper}, got {value!r}; "
                             f"{_example(name, origin)}")
        return float(value)
    if kind is bool and isinstance(value, bool):
        return value
    if kind is str and isinstance(value, str):
        if name in CHOICES and value not in CHOICES[name]:
            raise UsageError(f"{origin}: {name} must be one of {', '.join(CHOICES[name])}, got '{value}'")
        return value
    wanted = {bool: "true or false", float: "a number"}.get(kind, f"a {kind.__name__}")
    raise UsageError(f"{origin}: {name} must be {wanted}, got {value!r}; {_example(name, origin)}")


def _apply(values: dict, overrides: dict, origin: str, sources: dict) -> None:
    types = {f.name: type(f.default) for f in fields(TutorialParams)}
    for key, value in overrides.items():
        if key not in types:
            import difflib

            near = difflib.get_close_matches(key, types, n=1)
            hint = f" (did you mean {near[0]}?)" if near else ""
            raise UsageError(f"{origin}: unknown parameter '{key}'{hint}; `boxbox params` lists them")
        values[key] = _coerce(key, value, types[key], origin)
        sources[key] = origin


def parse_set(items: tuple[str, ...] | list[str]) -> dict:
    """`key=value` strings from the command line, values read as TOML (numbers, true, "text")."""
    out = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep:
            raise UsageError(f"--set takes key=value, got '{item}'")
        try:
            out[key.strip()] = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            out[key.strip()] = text
    return out


def setup_files(car: str, track: str) -> list[Path]:
    root = setups_dir()
    return [root / "default.toml", root / car / "default.toml", root / car / f"{track}.toml"]


def load_params(car: str, track: str, overrides: dict | None = None) -> tuple[TutorialParams, dict[str, str]]:
    """Effective parameters and, per key, where its value came from."""
    values = dataclasses.asdict(TutorialParams())
    sources = {k: "default" for k in values}
    for path in setup_files(car, track):
        if path.exists():
            try:
                data = tomllib.loads(path.read_text())
            except tomllib.TOMLDecodeError as exc:
                raise UsageError(f"{path}: not valid TOML: {exc}") from None
            except (OSError, UnicodeDecodeError) as exc:
                raise UsageError(f"{path}: cannot be read: {exc}") from None
            _apply(values, data, str(path), sources)
    _apply(values, overrides or {}, "--set", sources)
    return TutorialParams(**values), sources
