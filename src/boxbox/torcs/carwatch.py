"""The car watch: what the robot host keeps of each Python car (`HostedCar`) and counts every drive
step (stuck, off the track, lost by TORCS, the step times), and the car's figures for the results.
"""

from __future__ import annotations

import json
import math
from array import array
from dataclasses import dataclass, field

from boxbox.model import Car, State, Track
from boxbox.model.state import CAR_STATE_NO_SIMU, CAR_STATE_OUT, CAR_STATE_PIT
from boxbox.model.track import LEFT
from boxbox.robot.base import Robot
from boxbox.torcs.messages import TrackChunks
from boxbox.torcs.pitwatch import PitWatch
from boxbox.torcs.telemetry import Recorder
from boxbox.torcs.timing import STEP_S

STUCK_SPEED_MPS = 1.0  # slower than this outside the pit counts as stuck
MAX_STEP_SAMPLES = 1 << 16  # step times kept per car: every step up to this, then every 2nd, 4th...


@dataclass
class HostedCar:
    """One Python car: its robot and what the host tracks for it."""

    robot: Robot
    spec: str
    name: str
    car: Car | None = None
    track: Track | None = None
    max_gear: int = 6
    laps_seen: int = 0
    lap_times: list[float] = field(default_factory=list)
    step_ns: array = field(default_factory=lambda: array("q"))  # a sample of the step times (see record_step_time)
    steps_timed: int = 0
    step_stride: int = 1
    chunks: TrackChunks = field(default_factory=TrackChunks)  # NEW_TRACK's
    last_state: State | None = None
    # incidents, in drive steps (see watch_step)
    stuck_steps: int = 0
    stuck_run: int = 0
    longest_stuck_steps: int = 0
    off_track_steps: int = 0
    pit_zone: bytes = b""  # 1 per segment between pit entry and exit
    pit_watch: PitWatch = field(default_factory=lambda: PitWatch(None, None, b""))  # replaced at NEW_RACE
    recorder: Recorder | None = None  # telemetry (None: not recorded)
    rec: Recorder | None = None  # the recorder while recording (the drive step's check), else None
    start_fuel_l: float | None = None
    started: bool = False  # on_track has returned: the robot is in the race
    ended: bool = False  # on_race_end has been called (once, however the race ended)
    lost_since_s: float | None = None  # when TORCS lost every car still racing (every_car_lost)




def pit_zone(track: Track | None) -> bytes:
    """1 for each segment from the pit entry to the pit exit (where the pit lane runs beside the track)."""
    if track is None or track.pit is None:
        return b""
    n = track.n_segments
    zone = bytearray(n)
    entry, exit_ = track.pit.entry_seg % n, track.pit.exit_seg % n
    i = entry
    for _ in range(n):
        zone[i] = 1
        if i == exit_:
            break
        i = (i + 1) % n
    return bytes(zone)


def watch_step(slot: HostedCar, state: State) -> None:
    """Count a drive step stuck (slower than 1 m/s) or off the track (the car's centre beyond an
    edge), outside the pit: captured in the box, or in the pit lane beside the pit zone, is neither."""
    if int(state.car_state) & (CAR_STATE_PIT | CAR_STATE_OUT):
        slot.stuck_run = 0
        return
    left, right = state.to_left_m, state.to_right_m
    if left < 0.0 or right < 0.0:
        seg = int(state.seg_id)
        pit = slot.track.pit if slot.track is not None else None
        if pit is not None and slot.pit_zone and 0 <= seg < len(slot.pit_zone) and slot.pit_zone[seg] and \
                (left < 0.0 if pit.side == LEFT else right < 0.0):
            slot.stuck_run = 0
            return  # in the pit lane
        slot.off_track_steps += 1
    if math.hypot(state.speed_x_mps, state.speed_y_mps) < STUCK_SPEED_MPS and state.sim_time_s > 0.0:
        slot.stuck_steps += 1
        slot.stuck_run += 1
        if slot.stuck_run > slot.longest_stuck_steps:
            slot.longest_stuck_steps = slot.stuck_run
    else:
        slot.stuck_run = 0


def every_car_lost(state: State) -> bool:
    """Whether TORCS has lost our car and every other car still racing (not in its pit, not out):
    all their positions NaN.  TORCS's physics has been seen to do this to every car in one step
    (docs/reliability.md); no car can finish after it, and TORCS goes on simulating them for good."""
    if state.x_m == state.x_m:
        return False
    return all(o.x_m != o.x_m for o in state.opponents if not int(o.car_state) & CAR_STATE_NO_SIMU)


def record_step_time(slot: HostedCar, ns: int) -> None:
    """Keep the step times in bounded memory: all of them up to MAX_STEP_SAMPLES, then an evenly
    spaced sample over the whole race (thinned by half, stride doubled, whenever it fills up)."""
    slot.steps_timed += 1
    if slot.steps_timed % slot.step_stride == 0:
        slot.step_ns.append(ns)
        if len(slot.step_ns) >= MAX_STEP_SAMPLES:
            del slot.step_ns[1::2]
            slot.step_stride *= 2


def incidents(slot: HostedCar) -> dict:
    return {"stuck_s": round(slot.stuck_steps * STEP_S, 2),
            "longest_stuck_s": round(slot.longest_stuck_steps * STEP_S, 2),
            "off_track_s": round(slot.off_track_steps * STEP_S, 2)}






def car_json(index: int, slot: HostedCar, final: bool, pit_laps: tuple[int, ...] = ()) -> dict:
    """One Python car's figures; the step times and the robot's report only at the end (final),
    when also the stops the race asked for (pit_laps) and the robot never did are missed stops."""
    ns = sorted(slot.step_ns) if final else []
    report: dict = {}
    if final and slot.car is not None:
        try:
            report = slot.robot.race_report()
            json.dumps(report)
        except Exception as exc:  # a report must never lose the race's results
            report = {"report_error": f"{type(exc).__name__}: {exc}"}
    return {"robot_index": index, "robot": slot.spec, "name": slot.name,
            "car_index": slot.car.car_index if slot.car else None,
            "lap_times": slot.lap_times, "steps": slot.steps_timed, "start_fuel_l": slot.start_fuel_l,
            "step_us_median": ns[len(ns) // 2] / 1000 if ns else None,
            "step_us_p99": ns[min(len(ns) - 1, int(len(ns) * 0.99))] / 1000 if ns else None,
            "missed_pit_stops": slot.pit_watch.finish() + slot.pit_watch.unasked(pit_laps, slot.laps_seen) if final
            else list(slot.pit_watch.missed),
            "report": report, **incidents(slot)}
