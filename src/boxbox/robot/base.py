"""The interface a Python robot implements.  TORCS calls reach these methods through the bridge."""

from __future__ import annotations

from dataclasses import dataclass, field

from boxbox.model import Car, CarSetup, Controls, PitOrder, State, Track
from boxbox.model.car_setup import SETTING_NAMES

# Fuel use before anything is measured: litres per metre for a car with fuel cons factor 1
# (car1-trb1 at racing speed uses about this much; robots refine it lap by lap).
FUEL_L_PER_M_ESTIMATE = 0.00065  # measured about 0.000625 l/m x fuel_cons_factor (car1-trb1, e-track-2)


@dataclass
class RaceOptions:
    """What the race asks of a robot beyond driving (from `boxbox race` options)."""

    laps: int = 0  # race length
    cars: int = 1  # cars in the race, this one included (1: alone)
    fuel_laps: float | None = None  # start with fuel for this many laps (None: the car's default)
    pit_laps: tuple[int, ...] = ()  # laps on which to stop in the pit
    pit_mode: str = "constant-decel"
    learning_dir: str | None = None  # where robots keep what they learn per track and car
    robot_args: dict = field(default_factory=dict)  # robot-specific (the tutorial robot: {"set": {...}})
    # the car setup from the race's settings (CarSetup's field names: final_drive_ratio = 4.2), for
    # every Python car: over what the robot's car_setup() returns
    car_setup: dict = field(default_factory=dict)


def race_options(settings: dict | None = None, **options) -> RaceOptions:
    """RaceOptions with the race's settings (--set, --setup, tune's): the car setup's apart
    (RaceOptions.car_setup), the robots' parameters in robot_args["set"]."""
    params = dict(settings or {})
    setup = {name: params.pop(name) for name in list(params) if name in SETTING_NAMES}
    return RaceOptions(robot_args={"set": params} if params else {}, car_setup=setup, **options)


class Robot:
    """Subclass this and override `drive`; everything else has a sensible default.

    Call order: `initial_fuel_l` and `car_setup` (track known, car gears not yet), `on_track`
    (everything known), `telemetry_fields` (when telemetry is recorded), `drive` and `telemetry` every
    0.02 s of simulated time, `pit_stop` when captured in the pit, then `on_race_end` once however
    the race ends (finished, Ctrl-C, a fault, TORCS gone), and `race_report` last.
    """

    name = "robot"
    # tunable parameters (robot/tunable.py, `boxbox tune`): a dataclass of defaults, search ranges
    # (name -> robot.params.Bound) and the values of str parameters
    param_class: type | None = None
    param_bounds: dict = {}
    param_choices: dict = {}

    def __init__(self, options: RaceOptions | None = None) -> None:
        self.options = options or RaceOptions()
        # None until on_track; typed as set, since every call that reads them comes after it
        self.track: Track = None  # type: ignore[assignment]
        self.car: Car = None  # type: ignore[assignment]

    @classmethod
    def check_setup(cls, options: RaceOptions, track_name: str, car_name: str) -> None:
        """Raise boxbox.errors.UsageError for bad robot settings, before TORCS starts.  Default: the
        settings checked against the declared `param_class`, if any."""
        from boxbox.robot.tunable import declares_params, param_space

        if declares_params(cls) and options.robot_args.get("set"):
            param_space(cls).check(options.robot_args["set"], "--set")

    def initial_fuel_l(self, track: Track, car: Car) -> float | None:
        """Litres to start with, or None for the car's default.  Default: honour --fuel-laps."""
        if self.options.fuel_laps is None:
            return None
        per_lap = FUEL_L_PER_M_ESTIMATE * car.fuel_cons_factor * track.length_m
        return min(car.tank_l, self.options.fuel_laps * per_lap)

    def car_setup(self, track: Track, car: Car) -> CarSetup | None:
        """Car parameters to set before the car is built (after `initial_fuel_l`): wings, gears,
        brakes, suspension, differential (docs/robots.md, "The car setup").  TORCS merges them over
        the car's file; each must lie in the car's range.  `on_track` then sees the car with them.
        Default: None, the car as its file has it (and the race's setup settings over it)."""
        return None

    def on_track(self, track: Track, car: Car) -> None:
        """Called once before the race with the whole track and the car's constants."""
        self.track, self.car = track, car

    def drive(self, state: State) -> Controls:
        """Every 0.02 s of simulated time: the controls for this step.  Every robot defines it."""
        raise NotImplementedError(f"robot class {type(self).__name__} does not define drive(self, state)")

    def pit_stop(self, state: State) -> PitOrder:
        """Called when TORCS has captured the car in its pit: how much fuel and repair to take."""
        return PitOrder(fuel_l=0.0, repair=0.0)

    def on_race_end(self, state: State) -> None:
        """Called once when the race ends, however it ends (finished, stopped by Ctrl-C, a robot's
        fault, TORCS gone), after the last `drive` and before `race_report`: with the car's state at
        the end (its last lap's time in `last_lap_time_s`), or the last state `drive` saw when TORCS
        could not give it.  Not called when `on_track` failed."""

    def race_report(self) -> dict:
        """Extra fields for this driver's entry in the race JSON (e.g. {"pit_events": [...]})."""
        return {}

    def signals(self) -> dict[str, float]:
        """Named values to record in telemetry this step (override to add your own).  The simple way:
        the default `telemetry_fields`/`telemetry` use it, building a dict each step.  Keep the keys
        the same every step."""
        return {}

    def telemetry_fields(self) -> tuple[str, ...]:
        """Names of the values `telemetry` returns, asked once after `on_track` (fixed for the race).
        A value named 'target_speed_mps' fills the telemetry's target speed column; the others become
        `sig_<name>` columns.  Default: the keys of `signals()`; () records no robot values."""
        return tuple(self.signals())

    def telemetry(self, state: State) -> tuple[float, ...]:
        """This step's values in `telemetry_fields` order, called after every `drive` while telemetry
        is recorded.  It runs inside the drive step: keep it cheap (return a tuple of numbers).
        Default: the values of `signals()`."""
        return tuple(self.signals().values())
