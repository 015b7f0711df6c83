"""The SCR messages: identification and actions parsed as the protocol describes them."""

from __future__ import annotations

from boxbox.gym.scr import Action, parse_init
from boxbox.gym.sensors import SCR_TRACK_ANGLES_DEG


def test_identification_with_and_without_angles():
    angles = " ".join(str(a) for a in range(-90, 100, 10))
    assert parse_init(f"SCR(init {angles})".encode()) == tuple(float(a) for a in range(-90, 100, 10))
    assert parse_init(b"SCR(init)") == SCR_TRACK_ANGLES_DEG
    assert parse_init(b"bot2(init -1.5e1 0 15)") == (-15.0, 0.0, 15.0)
    assert parse_init(b"(accel 1)(brake 0)") is None and parse_init(b"***identified***") is None


def test_actions_keep_what_a_message_leaves_out():
    action = Action()
    assert list(action.vector()) == [0.0, 0.0, 0.0, 0.0, 0.0] and not action.restart and action.focus_deg == 360.0
    action.update(b"(accel 0.75)(brake 0)(gear 2)(steer -0.25)(clutch 0.5)(focus 30)(meta 0)")
    assert list(action.vector()) == [-0.25, 0.75, 0.0, 2.0, 0.5] and action.focus_deg == 30.0
    action.update(b"(steer 0.5)(meta 1)(unknown 3)")
    assert list(action.vector()) == [0.5, 0.75, 0.0, 2.0, 0.5] and action.restart
