"""An SCR server: clients written for the Simulated Car Racing championship drive stock TORCS.

The SCR championship's software patches TORCS with a robot that talks UDP; this server speaks
the same text protocol on 127.0.0.1 with the TORCS env (gym/env.py) behind it, so an unmodified
SCR client (snakeoil-style) drives Debian's TORCS.  The protocol, as the SCR manual describes it:

- the client identifies itself with `ID(init A1 A2 ... A19)`, the angles (degrees) of its 19 track
  sensors; the server answers `***identified***` and the race starts;
- every drive step the server sends the sensors, `(name value ...)` groups: angle, curLapTime,
  damage, distFromStart, distRaced, fuel, gear, lastLapTime, opponents (36), racePos, rpm,
  speedX, speedY, speedZ (km/h), track (19), trackPos, wheelSpinVel (4), z, focus (5);
- the client answers with the actions `(accel a)(brake b)(gear g)(steer s)(clutch c)(focus f)
  (meta m)`; `meta 1` restarts the race: the server answers `***restart***` and waits for the
  client to identify again;
- at the end of the race, or when the server stops, it sends `***shutdown***`.
A client that does not answer within `answer_timeout_s` keeps its last action for that step (as
SCR's server does); one silent for `gone_after_s` is dropped and the race ends.
"""

from __future__ import annotations

import math
import re
import socket
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from boxbox.errors import UsageError
from boxbox.gym.env import TorcsEnv
from boxbox.gym.sensors import SCR_TRACK_ANGLES_DEG
from boxbox.model import State, Track

IDENTIFIED, RESTART, SHUTDOWN = b"***identified***", b"***restart***", b"***shutdown***"
MPS_TO_KMH = 3.6
RADPS_TO_RPM = 60.0 / (2.0 * math.pi)
FOCUS_SPREAD_DEG = (-2.0, -1.0, 0.0, 1.0, 2.0)  # SCR's five focus rays around the focus direction
INIT = re.compile(rb"^\s*([^()\s]*)\(init((?:\s+[-+0-9.eE]+)*)\s*\)")
GROUP = re.compile(rb"\((\w+)((?:\s+[-+0-9.eE]+)+)\)")
ACTION_ORDER = ("steer", "throttle", "brake", "gear", "clutch")


# the action message's fields and their values until the client sends others; a focus outside
# [-90, 90] degrees asks for no focus reading
ACTION_DEFAULTS = {"accel": 0.0, "brake": 0.0, "gear": 0.0, "steer": 0.0, "clutch": 0.0, "focus": 360.0, "meta": 0.0}


class Action:
    """A client's latest action message; fields it leaves out keep their last values."""

    def __init__(self) -> None:
        self.values = dict(ACTION_DEFAULTS)

    def update(self, message: bytes) -> None:
        for name, values in GROUP.findall(message):
            key = name.decode()
            if key in self.values:
                self.values[key] = float(values.split()[0])

    @property
    def restart(self) -> bool:
        return self.values["meta"] == 1.0

    @property
    def focus_deg(self) -> float:
        return self.values["focus"]

    def vector(self) -> np.ndarray:
        v = self.values
        return np.array([v["steer"], v["accel"], v["brake"], v["gear"], v["clutch"]], dtype=np.float32)


def parse_init(message: bytes) -> tuple[float, ...] | None:
    """The track sensor angles of an identification message (SCR's default when it names none);
    None when the message is no identification."""
    m = INIT.match(message)
    if m is None:
        return None
    angles = tuple(float(a) for a in m.group(2).split())
    return angles or SCR_TRACK_ANGLES_DEG


def _values(values) -> str:
    return " ".join(f"{float(v):.6g}" for v in values)


@dataclass
class Race:
    """What the sensor message needs besides the state: the distance raced, the focus rays."""

    env: TorcsEnv
    dist_raced_m: float = 0.0
    focus_deg: float = 360.0

    def sensors(self, obs: dict, s: State) -> bytes:
        groups = [
            ("angle", [s.angle_rad]), ("curLapTime", [s.cur_lap_time_s]), ("damage", [s.damage]),
            ("distFromStart", [s.dist_from_start_m]), ("distRaced", [self.dist_raced_m]), ("fuel", [s.fuel_l]),
            ("gear", [s.gear]), ("lastLapTime", [s.last_lap_time_s]), ("opponents", obs["opponents_m"]),
            ("racePos", [s.position]), ("rpm", [s.rpm * RADPS_TO_RPM]),
            ("speedX", [s.speed_x_mps * MPS_TO_KMH]), ("speedY", [s.speed_y_mps * MPS_TO_KMH]),
            ("speedZ", [s.speed_z_mps * MPS_TO_KMH]), ("track", obs["track_edges_m"]),
            ("trackPos", obs["track_pos"]), ("wheelSpinVel", obs["wheel_spin_radps"]),
            ("z", [s.z_m - track_height_m(self.env.track, s)]), ("focus", self.focus(s)),
        ]
        return "".join(f"({name} {_values(v)})" for name, v in groups).encode()

    def focus(self, s: State) -> list[float]:
        """Five range finders around the client's focus direction; -1 each without one."""
        edges = self.env.edges
        if edges is None or not -90.0 <= self.focus_deg <= 90.0 or s.to_left_m < 0.0 or s.to_right_m < 0.0:
            return [-1.0] * 5
        rays = -np.radians(np.array(FOCUS_SPREAD_DEG) + self.focus_deg)
        return edges.cast(s.x_m, s.y_m, s.yaw_rad, int(s.seg_id), rays).tolist()


def track_height_m(track: Track | None, s: State) -> float:
    """The track's height under the car (its segment's start and end heights, interpolated)."""
    if track is None or s.seg_id < 0:
        return 0.0
    seg = track.seg
    i = int(s.seg_id)
    along = track.dist_of(i, s.to_start) - float(seg["start_dist_m"][i])
    share = min(1.0, max(0.0, along / max(float(seg["length_m"][i]), 1e-6)))
    return float(seg["start_z_m"][i] + share * (seg["end_z_m"][i] - seg["start_z_m"][i]))


class ScrServer:
    """One UDP port, one client, races one after another (`serve`)."""

    def __init__(self, port: int = 3001, host: str = "127.0.0.1", answer_timeout_s: float = 1.0,
                 gone_after_s: float = 10.0, log: Callable[[str], None] = print, **env_kwargs) -> None:
        self.env_kwargs = dict(env_kwargs, actions=ACTION_ORDER, assists=(), off_track_s=None, stuck_s=None)
        TorcsEnv(**self.env_kwargs).close()  # bad input fails here, before a client waits on it
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((host, port))
        except OSError as exc:
            self.sock.close()
            raise UsageError(f"UDP port {port} on {host} cannot be used ({exc.strerror or exc}); "
                             "choose another --port") from None
        self.port = self.sock.getsockname()[1]
        self.answer_timeout_s, self.gone_after_s = answer_timeout_s, gone_after_s
        self.log = log
        self.env: TorcsEnv | None = None
        self.angles: tuple[float, ...] = ()
        self.client: tuple | None = None
        self.stopping = False
        self.silent_s = 0.0  # since the client's last message, in answer timeouts

    def serve(self, races: int | None = 1) -> int:
        """Serve races (None: until stopped); the number of races that ended."""
        self.log(f"SCR server on {self.sock.getsockname()[0]}:{self.port}: waiting for a client to identify")
        ended = 0
        try:
            while not self.stopping and (races is None or ended < races):
                self._identify()
                if self.stopping:
                    break
                if self._race():
                    ended += 1
        finally:
            self.close()
        return ended

    def stop(self) -> None:
        self.stopping = True

    def close(self) -> None:
        if self.client is not None:
            self._send(SHUTDOWN)
            self.client = None
        if self.env is not None:
            self.env.close()
            self.env = None
        self.sock.close()

    def _identify(self) -> None:
        self.sock.settimeout(0.2)  # wakes up to see stop()
        while not self.stopping:
            try:
                message, addr = self.sock.recvfrom(4096)
            except TimeoutError:
                continue
            angles = parse_init(message)
            if angles is None:
                continue
            if len(angles) != 19:
                self.log(f"client {addr[0]}:{addr[1]} sent {len(angles)} sensor angles; SCR clients send 19")
                continue
            self.client = addr
            self._send(IDENTIFIED)
            if self.env is None or angles != self.angles:
                if self.env is not None:
                    self.env.close()
                self.env = TorcsEnv(**self.env_kwargs, track_sensor_angles_deg=angles)
                self.angles = angles
            self.log(f"client {addr[0]}:{addr[1]} identified")
            return

    def _race(self) -> bool:
        """One race with the identified client: True when it ended, False on a restart or a lost client."""
        assert self.env is not None
        obs, info = self.env.reset()
        race, action = Race(self.env), Action()
        self._send(race.sensors(obs, info["state"]))
        while not self.stopping:
            got = self._next_action(action)
            if got is None:
                self.log("the client went silent; race stopped")
                self.client = None
                return False
            if got is IDENTIFIED or action.restart:
                self._send(RESTART)
                self.log("the client asked for a restart")
                return False
            race.focus_deg = action.focus_deg
            obs, _, terminated, _, info = self.env.step(action.vector())
            race.dist_raced_m += info["progress_m"]
            if terminated:
                self.log(f"race over ({info['termination']}" + (f": {info['fault']})" if info["fault"] else ")"))
                self._send(SHUTDOWN)
                self.client = None
                return True
            self._send(race.sensors(obs, info["state"]))
        return False

    def _next_action(self, action: Action):
        """Read the client's answer into `action`: action (on time or not), IDENTIFIED (it identified
        again: a restart), or None when it was silent for gone_after_s."""
        self.sock.settimeout(self.answer_timeout_s)
        while True:
            try:
                message, addr = self.sock.recvfrom(4096)
            except TimeoutError:
                self.silent_s += self.answer_timeout_s
                if self.silent_s >= self.gone_after_s:
                    return None
                return action  # late: the last action once more
            if addr != self.client:
                continue
            self.silent_s = 0.0
            if parse_init(message) is not None:
                return IDENTIFIED
            action.update(message)
            return action

    def _send(self, data: bytes) -> None:
        if self.client is not None:
            try:
                self.sock.sendto(data, self.client)
            except OSError:
                pass  # a client that went away: noticed when it stays silent


def serve(port: int = 3001, track: str = "g-track-1", races: int | None = 1, **kwargs) -> int:
    """Run an SCR server on 127.0.0.1:port for `races` races (None: until interrupted)."""
    server = ScrServer(port=port, track=track, **kwargs)
    try:
        return server.serve(races)
    except KeyboardInterrupt:
        server.stop()
        return 0
