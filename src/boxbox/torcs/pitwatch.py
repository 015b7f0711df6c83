"""Pit stops asked for and not made, with the reason, from the steps the robot host sees.

TORCS captures a car that asks for a stop (`pit_request`) when it is inside its box along the
track (`Car.pit_lmin_m` to `pit_lmax_m`), laterally in the pit lane, and slower than 1 m/s (see
docs/pits.md). A robot that asks and is not captured gets no message from TORCS: the car simply
drives on. The host follows each request from the first step that asks until the car is captured or
drives out of the pit zone (pit entry to pit exit), and names what went wrong:

* `never entered the pit lane`: the car passed the pit zone on the track;
* `passed its box`: in the pit lane, but never slower than 5 m/s near its box;
* `not captured`: it slowed near its box but too fast (over 1 m/s) in it, or stopped too far from it.

A request dropped before the car reaches the pit zone is the robot changing its mind, not a miss.
The host adds the misses to the driver's result (`missed_pit_stops`: lap, reason, detail).
"""

from __future__ import annotations

import math

from boxbox.model import Car, State, Track
from boxbox.model.state import CAR_STATE_PIT
from boxbox.model.track import LEFT

CAPTURE_SPEED_MPS = 1.0  # TORCS captures a car slower than this in its box
SLOWED_SPEED_MPS = 5.0  # slower than this near the box counts as trying to stop there
NEAR_BOX_M = 20.0  # "near its box": within this distance of the box's ends

NEVER_ENTERED = "never entered the pit lane"
PASSED_BOX = "passed its box"
NOT_CAPTURED = "not captured"
NOT_ASKED = "not asked"


class PitWatch:
    """One Python car's pit requests (`step` is called only while one is open or asked for)."""

    __slots__ = ("zone", "left_side", "box_mid_m", "box_half_m", "length_m", "active", "in_zone", "entered",
                 "lap", "slowest_near_mps", "slowest_in_box_mps", "stop_off_m", "missed", "leaving", "asked_laps")

    def __init__(self, track: Track | None, car: Car | None, zone: bytes) -> None:
        self.zone = zone if track is not None and track.pit is not None and car is not None and car.pit_seg >= 0 \
            else b""
        self.left_side = bool(track is not None and track.pit is not None and track.pit.side == LEFT)
        self.length_m = float(track.length_m) if track is not None else 0.0
        lmin, lmax = (car.pit_lmin_m, car.pit_lmax_m) if car is not None else (0.0, 0.0)
        if lmax < lmin:  # the box straddles the start line
            lmax += self.length_m
        self.box_mid_m, self.box_half_m = (lmin + lmax) / 2, (lmax - lmin) / 2
        self.active = False
        self.leaving = False  # captured on this pass: a request until it leaves the pit zone is that stop's
        self.missed: list[dict] = []
        self.asked_laps: set[int] = set()  # the laps (State.laps) on which the robot asked for a stop
        self._reset()

    def _reset(self) -> None:
        self.active = self.in_zone = self.entered = False
        self.lap = 0
        self.slowest_near_mps = self.slowest_in_box_mps = math.inf
        self.stop_off_m = math.inf

    def step(self, state: State, asked: bool) -> None:
        if asked:
            self.asked_laps.add(int(state.laps))
        if not self.zone:
            return
        seg = int(state.seg_id)
        in_zone = 0 <= seg < len(self.zone) and self.zone[seg] == 1
        if int(state.car_state) & CAR_STATE_PIT:
            self._reset()  # captured: the stop is made; followed until the car is out of the pit zone
            self.active = self.leaving = True
            return
        if self.leaving:
            if in_zone:
                return
            self.active = self.leaving = False
        if not self.active:
            if not asked:
                return
            self.active = True
        if self.in_zone and not in_zone:  # drove out of the pit zone without being captured
            self._miss()
            return
        self.in_zone = in_zone
        if in_zone:
            self.lap = int(state.laps)  # the lap on which the car passes its pit
        else:
            if not asked:
                self._reset()  # the robot changed its mind before the pit
            return
        if (state.to_left_m if self.left_side else state.to_right_m) < 0.0:
            self.entered = True
            self._near_box(state)

    def _near_box(self, state: State) -> None:
        half_l = self.length_m / 2
        off = abs((state.dist_from_start_m - self.box_mid_m + half_l) % self.length_m - half_l) - self.box_half_m
        speed = math.hypot(state.speed_x_mps, state.speed_y_mps)
        if off <= NEAR_BOX_M:
            self.slowest_near_mps = min(self.slowest_near_mps, speed)
        if off <= 0.0:
            self.slowest_in_box_mps = min(self.slowest_in_box_mps, speed)
        if speed < CAPTURE_SPEED_MPS:
            self.stop_off_m = min(self.stop_off_m, max(0.0, off))

    def _miss(self) -> None:
        if not self.entered:
            reason, detail = NEVER_ENTERED, "it stayed on the track past the pit entry"
        elif self.slowest_near_mps >= SLOWED_SPEED_MPS:
            slowest = "" if math.isinf(self.slowest_near_mps) else \
                f" (slowest {self.slowest_near_mps:.1f} m/s within {NEAR_BOX_M:.0f} m of it)"
            reason, detail = PASSED_BOX, f"it drove past its box{slowest}"
        elif self.stop_off_m > 0.0 and not math.isinf(self.stop_off_m):
            reason, detail = NOT_CAPTURED, f"it stopped {self.stop_off_m:.1f} m from its box"
        elif self.slowest_in_box_mps >= CAPTURE_SPEED_MPS:
            slowest = "never reached" if math.isinf(self.slowest_in_box_mps) else \
                f"slowest {self.slowest_in_box_mps:.1f} m/s"
            reason, detail = NOT_CAPTURED, f"too fast in its box ({slowest}; capture needs under 1 m/s)"
        else:
            reason, detail = NOT_CAPTURED, "it stopped in its box but not inside the pit lane"
        self.missed.append({"lap": self.lap, "reason": reason, "detail": detail})
        self._reset()

    def unasked(self, pit_laps: tuple[int, ...], laps_seen: int) -> list[dict]:
        """The stops the race asked for (--pit-laps) on laps the car drove past its pit (it reached
        the next lap), for which the robot never asked TORCS (pit_request on that lap or the ones
        beside it)."""
        return [{"lap": lap, "reason": NOT_ASKED,
                 "detail": "the robot never set pit_request for it (boxbox.PitStops makes the stops --pit-laps "
                           "asks for)"}
                for lap in pit_laps if lap < laps_seen and not self.asked_laps & {lap - 1, lap, lap + 1}]

    def finish(self) -> list[dict]:
        """The missed stops; a request still open at the end counts only if the car was in the pit
        lane (one asked on the last lap, before the pit, is a stop the race ended first)."""
        if self.active and self.entered:
            self._miss()
        return self.missed
