"""The stop drill: drive the tutorial robot's line, stop at a marker with the stop controller.

Used by `boxbox drill stop`: it measures how well the constant-deceleration stop controller stops
the car on the racing line (error against the marker, peak deceleration, how steady the
deceleration was) away from the pit, where nothing else interferes.
"""

from __future__ import annotations

import math
import statistics

from boxbox.control.stop import SpeedTracker, Stop, StopDriver, StopStatus
from boxbox.model import Car, Controls, State, Track
from boxbox.model.constants import DRIVE_STEP_S, G_MPS2
from boxbox.robot.tutorial import TutorialRobot

HOLD_S = 2.0  # stand this long at the marker before driving on


class StopDrill(TutorialRobot):
    name = "drill"

    def on_track(self, track: Track, car: Car) -> None:
        super().on_track(track, car)
        args = self.options.robot_args
        at_m = float(args.get("drill_at_m", 0.0))
        if not 0.0 <= at_m < track.length_m:  # the track's length is known only now, from TORCS
            raise ValueError(f"--at {at_m:g} m is not on {track.name} ({track.length_m:.0f} m long): "
                             f"give a marker from 0 to {track.length_m:.0f}")
        self.marker_m = at_m
        grip = self.tyre_model.mu * float(track.seg["friction"][track.segment_at(self.marker_m)])
        share = float(args.get("drill_grip_share", self.params.pit_stop_grip_share))
        self.max_decel_mps2 = share * grip * G_MPS2
        self.driver = StopDriver(Stop(self.max_decel_mps2),
                                 SpeedTracker(full_brake_mps2=grip * G_MPS2,
                                              drag_k_per_m=self.tyre_model.cw / self.tyre_model.mass_kg))
        self.phase = "approach"  # approach -> stopping -> standing -> done
        self.latched_at_s = 0.0
        self.standing_since_s = 0.0
        self.decels: list[float] = []
        self.prev_speed: float | None = None
        self.result: dict = {}

    def drive(self, s: State) -> Controls:
        c = super().drive(s)
        if self.phase == "done" or s.laps < 1:
            return c
        v = s.speed_x_mps
        left = (self.marker_m - s.dist_from_start_m) % self.track.length_m
        if self.phase == "approach" and left > self.track.length_m - 50.0:
            return c  # just passed it (start behind the marker): wait for the next pass
        accel, brake, r = self.driver.control(self.profile.speed_at(s.dist_from_start_m), v, left, 0.05,
                                              topspeed_mps=v)
        if not self.driver.stop.stopping:
            return c
        if self.phase == "approach":
            self.phase, self.latched_at_s = "stopping", s.sim_time_s
            self.result["latch_speed_mps"] = round(v, 2)
            self.result["latch_dist_m"] = round(left, 2)
            self.result["latch_decel_mps2"] = round(r.decel_mps2, 2)
        if self.prev_speed is not None and v > 0.5:
            self.decels.append((self.prev_speed - v) / DRIVE_STEP_S)
        self.prev_speed = v
        if self.phase == "stopping" and (r.status is StopStatus.FINISHED or v < 0.05):
            self.phase, self.standing_since_s = "standing", s.sim_time_s
            error = -left if left < self.track.length_m / 2 else self.track.length_m - left
            self.result.update(stop_error_m=round(error, 3), stop_time_s=round(s.sim_time_s - self.latched_at_s, 2))
        if self.phase == "standing" and s.sim_time_s - self.standing_since_s > HOLD_S:
            self.phase = "done"
            self._summarise()
            return c
        clutch = 1.0 if brake > 0.0 else c.clutch
        return Controls(steer=c.steer, accel=accel, brake=max(brake, 1.0 if self.phase == "standing" else 0.0),
                        clutch=clutch, gear=c.gear)

    def _summarise(self) -> None:
        d = self.decels
        if d:
            mean = statistics.fmean(d)
            self.result.update(peak_decel_mps2=round(max(d), 2), mean_decel_mps2=round(mean, 2),
                               decel_sd_mps2=round(statistics.pstdev(d), 2),
                               decel_cv=round(statistics.pstdev(d) / mean, 3) if mean > 0 else math.inf,
                               max_decel_setting_mps2=round(self.max_decel_mps2, 2))

    def race_report(self) -> dict:
        if self.phase != "done" and self.decels:
            self._summarise()
        return {**super().race_report(), "drill": {"marker_m": round(self.marker_m, 1), "phase": self.phase,
                                                   **self.result}}
