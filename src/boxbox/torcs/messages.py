"""The bridge's messages read and written (torcs/wire.py's layouts): the one implementation the
robot host (torcs/host.py) and the gym's races (gym/race.py, gym/multisession.py) share.

Reading: a DRIVE's STATE and opponents into a `State`, a STATE alone (PIT_CMD, END_RACE,
SHUTDOWN), NEW_TRACK's chunks joined (`TrackChunks`) and decoded into the `Track` and the car's
file constants (`decode_track`), NEW_RACE's CAR record into the car (`complete_car`).  Writing: a
reply's header and record packed into a buffer the caller keeps (`pack_reply`, `pack_controls`).
"""

from __future__ import annotations

import numpy as np

from boxbox.model import Car, CarSetup, Opponent, PitLane, State, Track
from boxbox.model.car import RWD
from boxbox.torcs import wire
from boxbox.torcs.car_setup import slot_values

HSIZE = wire.HEADER.size
STATE_SIZE = wire.STATE_REC.size
OPP_SIZE = wire.OPPONENT_REC.size
OPPONENTS_AT = HSIZE + STATE_SIZE  # a DRIVE's first opponent record
REPLY_BYTES = HSIZE + max(wire.HELLO_REC.size, wire.FUEL_REC.size, wire.CONTROLS_REC.size, wire.PIT_ORDER_REC.size)

_state_rec, _opp_rec = wire.STATE_REC.unpack_from, wire.OPPONENT_REC.unpack_from
_make_state, _make_opp = State._make, Opponent._make


def decode_state(buf: bytearray, count: int) -> State:
    """The message in `buf` (a DRIVE's): its STATE and `count` opponents."""
    if count:
        opps = tuple([_make_opp(_opp_rec(buf, OPPONENTS_AT + i * OPP_SIZE)) for i in range(count)])
    else:
        opps = ()
    return _make_state(_state_rec(buf, HSIZE) + (opps,))


def message_state(buf: bytearray, n: int) -> State | None:
    """The STATE record (no opponents) a message of n bytes carries, if it carries one."""
    if n < HSIZE + STATE_SIZE:
        return None
    return _make_state(_state_rec(buf, HSIZE) + ((),))


def pack_reply(out: bytearray, kind: int, robot: int, step: int, rec=None, values=(), flags: int = 0) -> memoryview:
    """A reply (the message's kind, robot and step; FLAG_* bits in `flags`) and its record packed
    at the start of `out` (REPLY_BYTES at least): the bytes to send."""
    wire.HEADER.pack_into(out, 0, kind, robot, step, flags)
    n = HSIZE
    if rec is not None:
        rec.pack_into(out, n, *values)
        n += rec.size
    return memoryview(out)[:n]


def pack_controls(out: bytearray, at: int, robot: int, step: int, steer: float, accel: float, brake: float,
                  clutch: float, gear: int, pit: bool) -> None:
    """A DRIVE's CONTROLS reply packed at `at` of `out` (HSIZE + CONTROLS_REC.size bytes)."""
    wire.HEADER.pack_into(out, at, wire.CONTROLS, robot, step, 0)
    wire.CONTROLS_REC.pack_into(out, at + HSIZE, steer, accel, brake, clutch, gear, 1.0 if pit else 0.0)


class TrackChunks:
    """NEW_TRACK's chunks of one car (the message is split above MAX_MESSAGE_BYTES), joined."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []

    def add(self, buf: bytearray, n: int, step: int, count: int) -> bytes | None:
        """Keep the chunk of n bytes in `buf` (chunk `step` of `count`); the whole track's bytes
        once it is the last, else None."""
        self.parts.append(bytes(buf[HSIZE:n]))
        if step + 1 < count:
            return None
        blob, self.parts = b"".join(self.parts), []
        return blob


def decode_track(blob: bytes, name: str, category: str) -> tuple[Track, Car]:
    t = dict(zip(wire.TRACK_FIELDS, wire.TRACK_REC.unpack_from(blob, 0), strict=True))
    n = int(t["n_segments"])
    off = wire.TRACK_REC.size
    seg_rows = np.frombuffer(blob, dtype="<f8", count=n * len(wire.SEGMENT_FIELDS), offset=off)
    seg_rows = seg_rows.reshape(n, len(wire.SEGMENT_FIELDS))
    seg = {f: seg_rows[:, i].copy() for i, f in enumerate(wire.SEGMENT_FIELDS)}
    seg["type"] = seg["type"].astype(int)
    seg["race_info"] = seg["race_info"].astype(int)
    off += wire.SEGMENT_REC.size * n
    handle = dict(zip(wire.HANDLE_FIELDS, wire.HANDLE_REC.unpack_from(blob, off), strict=True))
    pit = None
    if int(t["pit_type"]) != 0 and t["pit_entry_seg"] >= 0:
        pit = PitLane(side=int(t["pit_side"]), entry_seg=int(t["pit_entry_seg"]), start_seg=int(t["pit_start_seg"]),
                      end_seg=int(t["pit_end_seg"]), exit_seg=int(t["pit_exit_seg"]), width_m=t["pit_width_m"],
                      box_length_m=t["pit_box_length_m"], speed_limit_mps=t["pit_speed_limit_mps"],
                      count=int(t["pit_count"]))
    track = Track(name=name, category=category, length_m=t["length_m"], width_m=t["width_m"], seg=seg, pit=pit)
    handle["drivetrain"] = int(handle["drivetrain"])
    points = int(handle.pop("torque_points"))
    rpm = [handle.pop(f"torque_rpm_{i}") for i in range(wire.MAX_TORQUE_POINTS)]
    torque = [handle.pop(f"torque_nm_{i}") for i in range(wire.MAX_TORQUE_POINTS)]
    handle["torque_curve_radps"], handle["torque_curve_nm"] = tuple(rpm[:points]), tuple(torque[:points])
    return track, Car(**handle)


def complete_car(car: Car, payload: bytes) -> None:
    r = dict(zip(wire.CAR_FIELDS, wire.CAR_REC.unpack_from(payload, 0), strict=True))
    ints = {"car_index", "gear_count", "gear_offset", "pit_seg", "start_rank", "race_laps", "skill_level"}
    for key, value in r.items():
        if key.startswith("gear_ratio_"):
            continue
        setattr(car, key, int(value) if key in ints else value)
    car.gear_ratios = tuple(r[f"gear_ratio_{i}"] for i in range(wire.MAX_GEARS))


def fuel_reply(fuel_l: float | None, setup: CarSetup | None = None, drivetrain: int = RWD) -> tuple[float, ...]:
    """NEW_TRACK's FUEL record: the start fuel (-1: the car's own) and the car setup, a value per
    place in the car's file (torcs/car_setup.py; NaN: the car's own)."""
    return (-1.0 if fuel_l is None else float(fuel_l), *slot_values(setup, drivetrain))
