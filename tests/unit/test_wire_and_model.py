"""The wire format and the plain data types agree, field for field."""

from __future__ import annotations

import dataclasses
import math

import pytest

from boxbox import Controls, PitOrder
from boxbox.model import Car, Opponent, State
from boxbox.torcs import wire


def test_state_and_opponent_follow_the_wire_layout():
    assert list(State._fields[:-1]) == wire.STATE_FIELDS
    assert State._fields[-1] == "opponents"
    assert list(Opponent._fields) == wire.OPPONENT_FIELDS


def test_every_car_constant_on_the_wire_is_a_car_field():
    fields = {f.name for f in dataclasses.fields(Car)}
    arrays = ("gear_ratio_", "torque_rpm_", "torque_nm_")  # arrive as the tuples below
    wire_names = {f for f in [*wire.HANDLE_FIELDS, *wire.CAR_FIELDS] if not f.startswith(arrays)}
    wire_names -= {"torque_points"}
    assert wire_names <= fields
    assert {"gear_ratios", "torque_curve_radps", "torque_curve_nm"} <= fields


def test_c_header_declares_every_record_in_order():
    header = wire.c_header()
    for name, fields in wire.RECORDS.items():
        line = next(ln for ln in header.splitlines() if ln.endswith(f"bb_{name.lower()};"))
        body = line.split("{")[1].split("}")[0]
        assert [part.split()[1].rstrip(";") for part in body.split(";") if part.strip()] == fields
    assert f"#define BB_PROTOCOL_VERSION {wire.PROTOCOL_VERSION}" in header


def test_a_drive_message_fits_one_packet_with_every_opponent():
    size = wire.HEADER.size + wire.STATE_REC.size + wire.MAX_OPPONENTS * wire.OPPONENT_REC.size
    assert size < wire.MAX_MESSAGE_BYTES


def test_state_decodes_from_packed_bytes():
    values = [float(i) for i in range(len(wire.STATE_FIELDS))]
    data = wire.STATE_REC.pack(*values)
    state = State._make(wire.STATE_REC.unpack(data) + ((),))
    assert state.laps == wire.STATE_FIELDS.index("laps")
    assert state.angle_rad == wire.STATE_FIELDS.index("angle_rad")


@pytest.mark.parametrize("controls,problem", [
    (Controls(steer=0.1, accel=1.0, brake=0.0, clutch=0.0, gear=3), None),
    (Controls(steer=math.nan), "steer is nan"),
    (Controls(accel=math.inf), "accel is inf"),
    (Controls(brake=-0.1), "brake=-0.1 is outside [0, 1]"),
    (Controls(clutch="x"), "clutch must be a number, got str"),
    (Controls(gear=2.5), "gear=2.5 must be a whole number in [-1, 6]"),
    (Controls(gear=7), "gear=7 must be a whole number in [-1, 6]"),
    (Controls(gear=-1), None),
])
def test_controls_validation(controls, problem):
    assert controls.problem(max_gear=6) == problem


@pytest.mark.parametrize("name,lo", [("steer", -1.0), ("accel", 0.0), ("brake", 0.0), ("clutch", 0.0)])
def test_a_control_a_rounding_outside_its_range_is_set_to_the_bound(name, lo):
    """1 + 1e-12 (a steer summed from several terms) stopped the race: within 1e-9 of a bound it
    is the bound; further out it is refused, the same for every control."""
    for bound, nudge in ((1.0, 1e-12), (1.0, 9e-10), (lo, -1e-12)):
        controls = Controls(**{name: bound + nudge})
        assert controls.problem(max_gear=6) is None
        assert getattr(controls, name) == bound
    assert Controls(**{name: 1.0 + 2e-9}).problem(max_gear=6) == f"{name}={1.0 + 2e-9} is outside [{lo:g}, 1]"
    assert Controls(**{name: lo - 1e-6}).problem(max_gear=6) == f"{name}={lo - 1e-6} is outside [{lo:g}, 1]"


def test_controls_positional_fields_match_the_documented_constructor():
    c = Controls(steer=0.0, accel=0.5, brake=0.0, clutch=0.0, gear=1)
    assert (c.steer, c.accel, c.brake, c.clutch, c.gear, c.pit_request) == (0.0, 0.5, 0.0, 0.0, 1, False)


@pytest.mark.parametrize("order,ok", [(PitOrder(10, 100), True), (PitOrder(math.nan, 0), False),
                                      (PitOrder(0, -1), False), (PitOrder("a", 0), False)])
def test_pit_order_validation(order, ok):
    assert (order.problem() is None) == ok


def test_car_gear_helpers():
    car = Car(gear_count=8, gear_offset=1, gear_ratios=(-3.0, 0.0, 3.0, 2.0, 1.5, 1.2, 1.0, 0.9))
    assert car.max_gear == 6
    assert car.gear_ratio(1) == 3.0 and car.gear_ratio(-1) == -3.0


def test_numpy_scalars_and_a_whole_float_gear_are_fine_controls():
    import numpy as np

    c = Controls(steer=np.float32(0.25), accel=np.float64(0.5), brake=np.array(0.0), gear=np.int64(3))
    assert c.problem(6) is None
    assert (type(c.steer), type(c.accel), type(c.brake), c.gear, type(c.gear)) == (float, float, float, 3, int)
    state_gear = Controls(gear=4.0)  # State.gear arrives as a float
    assert state_gear.problem(6) is None and type(state_gear.gear) is int
    assert "whole number" in Controls(gear=2.5).problem(6)
    assert Controls(steer=np.float32("nan")).problem(6) == "steer is nan"
    assert "outside" in Controls(accel=np.float32(2.0)).problem(6)
