"""One TORCS race with several Python cars, all answered from the env's own process.

The bridge runs in its batch mode (BOXBOX_BATCH_DRIVE=1): at a simulation step's first drive call
of a Python car it sends the DRIVE of every Python car TORCS drives in that step, in robot order,
and then reads the answers in the same order.  TORCS moves the cars only after every robot's drive
call, so the states of one batch are all of the same instant, and the env sees every learning car's
state before it answers any (as the single env sees its one car's).  A car that TORCS no longer
drives (out of the race) gets no DRIVE: the batch's first message says which Python cars are still
driven (its opponents' `car_state`), so the session knows how many DRIVEs make the batch.
"""

from __future__ import annotations

import copy
from pathlib import Path

from boxbox.gym.race import (
    SETUP_ANSWER_TIMEOUT_S,
    STEP_TIMEOUT_S_DEFAULT,
    GymRace,
    RaceOrder,
    SessionResources,
    TorcsGone,
)
from boxbox.gym.session import Session
from boxbox.model import Car, PitOrder, State, Track
from boxbox.model.state import CAR_STATE_NO_SIMU
from boxbox.torcs import wire
from boxbox.torcs.messages import decode_state, pack_controls
from boxbox.torcs.raceprep import RaceConfig
from boxbox.torcs.setup import Overlay

Controls = tuple[float, float, float, float, int, bool]  # steer, accel, brake, clutch, gear, pit
PARKED: Controls = (0.0, 0.0, 1.0, 0.0, 1, False)  # what a car whose episode ended is given: it brakes


class MultiSession(Session):
    """The parallel env's races, one at a time (no spares): each a `MultiRace`."""

    def __init__(self, cfg: RaceConfig, overlay: Overlay, cpu: int | None = None,
                 initial_fuel_l: float | None = None, step_timeout_s: float = STEP_TIMEOUT_S_DEFAULT) -> None:
        super().__init__(overlay, cpu=cpu, step_timeout_s=step_timeout_s)
        self.cfg = cfg
        self.order = RaceOrder("multi", cfg, initial_fuel_l)  # every reset: the same race
        self.multi: MultiRace | None = None  # the race running (`race` too, which stop() and close() kill)

    def start_all(self, cfg: RaceConfig | None = None) -> tuple[Track, list[Car], dict[int, State]]:
        """A fresh TORCS (the last race killed first), served up to its first batch of drive steps:
        the track, each Python car's constants and each car's first state.  `cfg`: this race's
        (its starting grid placed elsewhere), else the session's."""
        self.stop()
        if cfg is not None:
            self.order = RaceOrder("multi", cfg, self.order.initial_fuel_l)
        self.race = self.multi = self._new_race(self.order)  # killed by stop() or close() if it fails half way
        return self.multi.start_all()

    def drive_all(self, controls: dict[int, Controls]) -> dict[int, State] | None:
        """Answer the pending batch (a robot missing from `controls` brakes); the next batch's states
        by robot, or None when the race has ended."""
        if self.multi is None or self.race is not self.multi:
            return None
        return self.multi.drive_all(controls)

    def _new_race(self, order: RaceOrder, spare: bool = False) -> MultiRace:
        self._count += 1
        return MultiRace(order, self.overlay, self.shared, self.dir / f"r{self._count}", self.cpu,
                         self.step_timeout_s)


class MultiRace(GymRace):
    """One TORCS process with len(cfg.robots) Python cars (robot indices 0..n-1) and TORCS's robots
    as opponents."""

    torcs_env = {"BOXBOX_BATCH_DRIVE": "1"}

    def __init__(self, order: RaceOrder, overlay: Overlay, shared: SessionResources, folder: Path, cpu: int,
                 step_timeout_s: float = STEP_TIMEOUT_S_DEFAULT) -> None:
        super().__init__(order, overlay, shared, folder, cpu, step_timeout_s)
        self.n_cars = len(order.cfg.robots)
        self.cars: list[Car] = []  # each Python car's constants (its own pit, its own car index)
        self.pending: list[tuple[int, int]] = []  # (robot, step) of the DRIVEs awaiting an answer
        self._base: tuple[Track, Car] | None = None  # the race's track and the car's file constants

    def start_all(self) -> tuple[Track, list[Car], dict[int, State]]:
        """TORCS started and served up to its first batch of drive steps."""
        self.listener = self._listen()
        self._spawn()
        self.conn = self._accept(block=True)
        assert self.conn is not None
        self.conn.settimeout(SETUP_ANSWER_TIMEOUT_S)
        self.cars = [None] * self.n_cars  # type: ignore[list-item]
        while True:
            n = self._recv()
            kind, robot, step, count = wire.HEADER.unpack_from(self._buf, 0)
            if kind == wire.DRIVE:
                assert self._base is not None and all(car is not None for car in self.cars)
                self.conn.settimeout(self.step_timeout_s)
                return self._base[0], self.cars, self._batch(robot, step, count)
            if not self._answer_setup(kind, robot, step, count, n):
                raise TorcsGone(f"TORCS sent message kind {kind} before the race started")

    def drive_all(self, controls: dict[int, Controls]) -> dict[int, State] | None:
        """Answer the pending batch (a robot missing from `controls` brakes); the next batch's states
        by robot, or None when the race has ended."""
        if self.conn is None or self.ended:
            return None
        for robot, step in self.pending:
            pack_controls(self._out, 0, robot, step, *controls.get(robot, PARKED))
            self._send(self._controls)
        self.pending = []
        while True:
            if not self._recv_in_race():
                return None
            kind, robot, step, count = wire.HEADER.unpack_from(self._buf, 0)
            if kind == wire.DRIVE:
                return self._batch(robot, step, count)
            if kind == wire.PIT_CMD:
                self._reply(wire.PIT_ORDER, robot, step, wire.PIT_ORDER_REC, (PitOrder().fuel_l, PitOrder().repair))
            elif kind == wire.END_RACE:
                self.ended = True
                self._reply(wire.ACK, robot, step)
                return None

    # --- pieces --------------------------------------------------------------------------------
    def _batch(self, robot: int, step: int, count: int) -> dict[int, State]:
        """The batch whose first DRIVE is in the buffer: every DRIVE of it, by robot."""
        first = decode_state(self._buf, count)
        states = {robot: first}
        self.pending = [(robot, step)]
        for other in self._driven_after(robot, first):
            self._recv()
            kind, r, step, count = wire.HEADER.unpack_from(self._buf, 0)
            if kind != wire.DRIVE or r != other:
                raise TorcsGone(f"TORCS sent message kind {kind} for car {r} in the middle of a batch (car {other} "
                                "was due)")
            states[r] = decode_state(self._buf, count)
            self.pending.append((r, step))
        return states

    def _driven_after(self, robot: int, first: State) -> list[int]:
        """The Python cars after `robot` that TORCS drives in this step (the bridge sends in robot order)."""
        by_index = {int(o.car_index): int(o.car_state) for o in first.opponents}
        return [j for j in range(robot + 1, self.n_cars)
                if not by_index.get(self.cars[j].car_index, CAR_STATE_NO_SIMU) & CAR_STATE_NO_SIMU]

    def _car_known(self, robot: int, blob: bytes) -> None:
        """NEW_TRACK's whole bytes: the track (decoded once per session) and a car of its own for the robot."""
        self._base = self._decoded(blob)
        self.cars[robot] = copy.deepcopy(self._base[1])

    def _car(self, robot: int) -> Car:
        return self.cars[robot]
