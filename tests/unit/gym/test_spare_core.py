"""Where a spare TORCS loads: beside the race on an idle core, on the race's own when none is idle."""

from __future__ import annotations

import time

from boxbox.gym.cores import IdleShares, spare_core


def test_an_idle_other_core_takes_the_spare():
    assert spare_core(0, {0, 1}, {0: 0.0, 1: 0.9}) == 1
    assert spare_core(1, {0, 1, 2, 3}, {0: 0.6, 1: 0.0, 2: 0.95, 3: 0.7}) == 2  # the idlest


def test_a_busy_machine_keeps_the_spare_on_the_race_core():
    assert spare_core(0, {0, 1}, {0: 0.0, 1: 0.2}) == 0
    assert spare_core(0, {0}, {0: 1.0}) == 0  # one core
    assert spare_core(0, {0, 1}, {}) == 0  # nothing known


def test_idle_shares_are_fractions_of_the_time_since_the_last_call():
    shares = IdleShares()
    shares.shares()
    time.sleep(0.3)  # (the kernel counts idle time in 10 ms ticks)
    got = shares.shares()
    assert got and all(-0.1 <= v <= 1.1 for v in got.values())
