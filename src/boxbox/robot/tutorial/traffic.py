"""The tutorial robot among other cars: who is near (robot/opponents.py), the overtaking offset
bounded by racecraft (robot/racecraft.py), the brakes for a car ahead, steering away from a car
alongside and round a wreck."""

from __future__ import annotations

import math
from collections.abc import Callable

from boxbox.control.pit_brake import ENTRY, EXIT, FREE, GAVE_UP, HOLD, LANE, LIMIT, STOP
from boxbox.control.speed import SpeedProfile
from boxbox.control.steering import steer_to_point
from boxbox.model import State
from boxbox.model.constants import DRIVE_STEP_S
from boxbox.robot.base import Robot
from boxbox.robot.behind import collision_brake, hazard_brake
from boxbox.robot.opponents import Nearby, OpponentParams, nearby, overtake_offset, relate, side_steer
from boxbox.robot.params import TutorialParams
from boxbox.robot.pit import PitStops
from boxbox.robot.racecraft import TURN_CURVATURE_1PM, Racecraft
from boxbox.robot.racingline import RacingLine
from boxbox.robot.unstuck import Unstuck

# the pit brake filter's phase as a number for telemetry (0: no pit business)
PIT_PHASE_CODES = {None: 0, FREE: 0, ENTRY: 1, LIMIT: 2, LANE: 3, STOP: 4, HOLD: 5, EXIT: 6, GAVE_UP: 7}
FOLLOW_LENGTHS = 3.0  # a car this many of our lengths ahead (centre to centre) in our lane: we follow it
# an overtaking offset keeps inside the room over this much road ahead (20-50 m measured: docs/racecraft.md;
# 40 m won more field races but failed the integration race from third on g-track-1)
OFFSET_ROOM_AHEAD_M = 30.0


class Traffic(Robot):
    """Cars near: the overtaking offset, the brakes for a car ahead, a wreck driven round."""

    # the plan of the track (plan.py, robot.py's on_track) read here
    params: TutorialParams
    line: RacingLine
    n: int
    step_m: float
    profile: SpeedProfile
    _brakedist: Callable[..., float]
    _alone_mps: list[float]
    _headings: list[float]
    _half_left: list[float]
    _half_right: list[float]
    _normals: list[tuple[float, float]]
    _offset_room_l: list[float]
    _offset_room_r: list[float]
    craft: Racecraft
    opp: OpponentParams
    pits: PitStops
    # the race's state, and getting unstuck (robot/unstuck.py), which backs away from a wreck
    offset_m: float
    blocked_steps: int
    _wrecks_until_s: float
    unstuck: Unstuck

    def _traffic(self, s: State, v: float) -> list[Nearby]:
        """The cars near enough to matter, and the line's offset from racecraft (robot/racecraft.py:
        passing, room side by side, letting a lapping car by); back to the line, a step at a time,
        when nobody is near."""
        p = self.params
        cars = nearby(s, self.car.length_m, self.track.length_m, p.back_range_m, p.front_range_m, self._heading_at) \
            if s.opponents and not math.isnan(s.dist_from_start_m) else []
        self.wreck = None
        if cars:
            cars = relate(self.craft.predict(s.sim_time_s, cars), self.car.width_m, self.opp.side_margin_m,
                          self.craft.p.lane_m)
            self._back_from_wreck(s, v, cars)
            self.wreck = self._wreck_ahead(s, cars)
            dist = s.dist_from_start_m
            self._now_s, self._my_mid_m = s.sim_time_s, s.to_middle_m
            j = int(dist / self.step_m) % self.n
            k = self.line.curvature_at(dist + self.craft.p.horizon_s * v)  # the turn we are heading for
            inside = 0.0 if abs(k) < TURN_CURVATURE_1PM else math.copysign(1.0, k)
            straight = next((x for x in range(0, 400, 10) if self.profile.speed_at(dist + x) < 0.95 * v), 400)
            base = overtake_offset(self.offset_m, v, s.to_middle_m, cars, 0.5 * self.track.width_m - 1.5,
                                   self.car.length_m, self.opp, self._held_up(s, cars, j, straight))
            turn = max(abs(self.line.curvature_at(dist + x))
                       for x in range(0, int(max(0.0, v) * self.craft.p.turn_ahead_s) + 1, 10))
            self.offset_m = self.craft.offset(s.sim_time_s, v, s.to_middle_m, cars, self.offset_m,
                                              self.line.offset_at(dist), (self._half_left[j], -self._half_right[j]),
                                              inside, p.overtake_step_m, base, turn)
        else:
            self._following = -1  # nobody near: a car met again is followed afresh (_held_up)
        if not cars and self.offset_m:
            self.offset_m = max(0.0, self.offset_m - p.overtake_step_m) if self.offset_m > 0 \
                else min(0.0, self.offset_m + p.overtake_step_m)
        return cars

    def _held_up(self, s: State, cars: list[Nearby], j: int, straight_m: float) -> float:
        """Our lap simulation's speed here once we have followed the same car close ahead in our lane
        for TutorialParams.draft_after_s (a train: passing it at our speed is worth a try) with at
        least draft_straight_m of road before the next braking zone (with draft_last_lap: on the last
        lap only), else 0 (the tutorial's rule)."""
        if not self._alone_mps or (self.params.draft_last_lap and s.laps < s.total_laps):
            return 0.0
        reach_m = FOLLOW_LENGTHS * self.car.length_m
        ahead = [c for c in cars if c.ahead and c.dist_m < reach_m and c.in_our_lane]
        index = min(ahead, key=lambda c: c.dist_m).index if ahead else -1
        if index != self._following:
            self._following, self._following_since_s = index, s.sim_time_s
        if index < 0 or s.sim_time_s - self._following_since_s < self.params.draft_after_s \
                or straight_m < self.params.draft_straight_m:
            return 0.0
        return self._alone_mps[j]

    def _heading_at(self, dist_m: float) -> float:
        """The track's direction at dist_m (rad), from the middle line's samples."""
        return self._headings[int(dist_m / self.step_m) % self.n]

    def _back_from_wreck(self, s: State, v: float, cars: list[Nearby]) -> None:
        """Start backing away from a stopped car in our lane after RacecraftParams.blocked_s stopped
        behind it (robot/racecraft.py blocking): from where we stand there is no steering round it."""
        on_track = PIT_PHASE_CODES.get(self.pits.phase, -1) == 0  # not in the pit lane, where cars stop
        blocker = self.craft.blocking(v, cars) if on_track else None
        self.blocked_steps = self.blocked_steps + 1 if blocker else 0
        wait_s = self.craft.p.blocked_grinding_s if self.unstuck.grinding(s) else self.craft.p.blocked_s
        if blocker and self.blocked_steps * DRIVE_STEP_S > wait_s:
            self.blocked_steps = 0
            self.unstuck.back_away(s, self.craft.p.blocked_back_lengths * self.car.length_m)
            self._wrecks_until_s = s.sim_time_s + self.craft.p.wreck_s

    def _wreck_ahead(self, s: State, cars: list[Nearby]) -> Nearby | None:
        """Within RacecraftParams.wreck_s of backing from a wreck: the nearest stopped car ahead
        (or alongside) in our way, driven round at walking pace and not braked for (a pile-up
        seldom has one car in it)."""
        if s.sim_time_s > self._wrecks_until_s:
            return None
        return self.craft.stopped_ahead(cars)

    def _steer_by_wreck(self, s: State, c: Nearby) -> float | None:
        """Steer at the point beside the wreck c (a car length ahead of us once alongside), on the
        side with room (robot/racecraft.py wreck_target); None when neither side has room."""
        at = s.dist_from_start_m + max(c.dist_m, self.car.length_m)
        j = int(at / self.step_m) % self.n
        target = self.craft.wreck_target(c, self._half_left[j], -self._half_right[j])
        if target is None:
            return None
        tx, ty = self.line.point_at(at)
        off = target - self.line.offset_at(at)
        nx, ny = self._normals[j]
        return steer_to_point(s.x_m, s.y_m, s.yaw_rad, tx + off * nx, ty + off * ny, self.car.steer_lock_rad)

    def _moved_line(self, j: int, line_off: float) -> float:
        """The line at sample j moved by the overtaking offset: never nearer the edge of the room than
        RacecraftParams.edge_m unless the line itself is (aalborg's right-hander at 1350 m: an inside
        offset held to the room's very edge, the car cut past it into the inside wall, 29k damage in 9 races)."""
        edge = self.craft.p.edge_m
        lo = min(line_off, edge - self._half_right[j])
        hi = max(line_off, self._half_left[j] - edge)
        off = max(min(0.0, edge - self._offset_room_r[j]), min(max(0.0, self._offset_room_l[j] - edge), self.offset_m))
        return max(lo, min(hi, line_off + off))

    def _avoid_side(self, steer: float, cars: list[Nearby]) -> float:
        if not cars:
            return steer
        return side_steer(steer, cars, self.car.length_m, self.car.width_m, self.car.steer_lock_rad, self.opp,
                          self.craft.p.side_push_rad_per_m)

    def _avoid_collision(self, brake: float, v: float, cars: list[Nearby]) -> float:
        """Brake for a car ahead: racecraft's touch of brake for a car touching ahead
        (robot/racecraft.py), the tutorial's fixed-gap filter and the hazard brake (robot/opponents.py)."""
        if not cars:
            return brake
        if self.wreck is not None:  # driven round at walking pace
            cars = [c for c in cars if c.index != self.wreck.index]
        brake = self.craft.brake(self._now_s, brake, v, cars)
        brake = collision_brake(brake, v, cars, self.opp, self._brakedist)
        return hazard_brake(brake, v, self._my_mid_m, cars, self.car.width_m, self.opp, self._brakedist)
