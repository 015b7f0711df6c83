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
SCR's server does); one silent for `client_timeout_s` is dropped and the race ends, and another
client's identification takes over then (a restarted client has a new port: SCR's snakeoil client
gives up after about 7 s without an answer, and then runs `pkill torcs`).

Malformed messages (a datagram that is neither an identification nor an action message with numbers
where numbers belong) are ignored, counted and logged in one line each (the first few): the parsers
below never raise; `parse_init` answers None and `Action.update` False for them.
"""

from __future__ import annotations

import math
import re
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from boxbox import validate
from boxbox.errors import UsageError
from boxbox.gym.env import TorcsEnv
from boxbox.gym.sensors import SCR_TRACK_ANGLES_DEG
from boxbox.model import State, Track

IDENTIFIED, RESTART, SHUTDOWN = b"***identified***", b"***restart***", b"***shutdown***"
# the answer to an identification while another client races (not in SCR's protocol, which has one
# client): an SCR client identifies again at once on any answer other than IDENTIFIED, where its
# silence would count down to snakeoil's `pkill torcs` after about 7 s
WAIT = b"***wait*** another client is racing; identify again: this one takes over once that one is silent for"
MPS_TO_KMH = 3.6
RADPS_TO_RPM = 60.0 / (2.0 * math.pi)
FOCUS_SPREAD_DEG = (-2.0, -1.0, 0.0, 1.0, 2.0)  # SCR's five focus rays around the focus direction
# a number as the protocol writes one (C's printf): what float() takes, and nothing else ('-', '.',
# 'e' alone are not numbers)
NUMBER = re.compile(rb"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?")
INIT = re.compile(rb"^\s*([^()\s]*)\(init((?:\s+[^()\s]+)*)\s*\)")
GROUP = re.compile(rb"\((\w+)([^()]*)\)")
ACTION_ORDER = ("steer", "throttle", "brake", "gear", "clutch")


# the action message's fields and their values until the client sends others; a focus outside
# [-90, 90] degrees asks for no focus reading
ACTION_DEFAULTS = {"accel": 0.0, "brake": 0.0, "gear": 0.0, "steer": 0.0, "clutch": 0.0, "focus": 360.0, "meta": 0.0}


class Action:
    """A client's latest action message; fields it leaves out keep their last values."""

    def __init__(self) -> None:
        self.values = dict(ACTION_DEFAULTS)

    def update(self, message: bytes) -> bool:
        """Take the fields of an action message; False (and nothing taken) when it has no field of
        an action, or one whose value is not a finite number."""
        found = {}
        for name, values in GROUP.findall(message):
            key = name.decode()
            if key in self.values:
                number = _number(values.split()[0] if values.split() else b"")
                if number is None:
                    return False
                found[key] = number
        self.values.update(found)
        return bool(found)

    @property
    def restart(self) -> bool:
        return self.values["meta"] == 1.0

    @property
    def focus_deg(self) -> float:
        return self.values["focus"]

    def vector(self) -> np.ndarray:
        v = self.values
        return np.array([v["steer"], v["accel"], v["brake"], v["gear"], v["clutch"]])  # float64: 1e100 stays finite


def _number(token: bytes) -> float | None:
    """A finite number written as the protocol writes them, else None."""
    if NUMBER.fullmatch(token) is None:
        return None
    value = float(token)
    return value if math.isfinite(value) else None


def parse_init(message: bytes) -> tuple[float, ...] | None:
    """The track sensor angles of an identification message (SCR's default when it names none);
    None when the message is no identification, or a malformed one (an angle that is no number)."""
    m = INIT.match(message)
    if m is None:
        return None
    angles = tuple(_number(a) for a in m.group(2).split())
    if any(a is None for a in angles):
        return None
    return tuple(a for a in angles if a is not None) or SCR_TRACK_ANGLES_DEG


def _values(values) -> str:
    return " ".join(f"{float(v):.6g}" for v in values)


@dataclass
class ScrRaceState:
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


SHOWN_MALFORMED = 5  # malformed messages logged one by one; the rest are counted


@dataclass
class Takeover:
    """Another client identified while the race's client has been silent for the client timeout."""

    addr: tuple
    angles: tuple[float, ...]


class ScrServer:
    """One UDP port, one client at a time, races one after another (`serve`)."""

    def __init__(self, port: int = 3001, host: str = "127.0.0.1", answer_timeout_s: float = 1.0,
                 client_timeout_s: float = validate.CLIENT_TIMEOUT_S_DEFAULT, log: Callable[[str], None] = print,
                 **env_kwargs) -> None:
        port = validate.whole_number(port, 0, 65535, name="port")
        host = validate.text(host, "host address", "127.0.0.1", name="host")
        self.answer_timeout_s = validate.finite_number(answer_timeout_s, 0.001, 60, name="answer_timeout_s")
        self.client_timeout_s = validate.client_timeout_s(client_timeout_s, name="client_timeout_s")
        # SCR's race: a client's action every drive step, the sensors in their units, the grid start
        self.env_kwargs = dict(env_kwargs, actions=ACTION_ORDER, assists=(), off_track_s=None, stuck_s=None,
                               action_repeat=1, raw_observations=True, random_start=False)
        TorcsEnv(**self.env_kwargs).close()  # bad input fails here, before a client waits on it
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((host, port))
        except OSError as exc:
            self.sock.close()
            raise UsageError(f"UDP port {port} on {host} cannot be used ({exc.strerror or exc}); "
                             "choose another --port") from None
        self.port = self.sock.getsockname()[1]
        self.log = log
        self.env: TorcsEnv | None = None
        self.angles: tuple[float, ...] = ()
        self.client: tuple | None = None
        self.stopping = False
        self.heard_at = 0.0  # time.monotonic() of the client's last message
        self.malformed = 0  # messages ignored as malformed
        self.waiting: set[tuple] = set()  # clients told to wait for the race's client to go silent (logged once)

    def serve(self, races: int | None = 1) -> int:
        """Serve races (None: until stopped); the number of races that ended."""
        races = None if races is None else validate.whole_number(races, 1, None, name="races")
        self.log(f"SCR server on {self.sock.getsockname()[0]}:{self.port}: waiting for a client to identify")
        ended = 0
        try:
            while not self.stopping and (races is None or ended < races):
                if self.client is None:
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
        if self.malformed > SHOWN_MALFORMED:
            self.log(f"{self.malformed} malformed messages ignored in all")
            self.malformed = SHOWN_MALFORMED  # said once
        self.sock.close()

    # --- clients -------------------------------------------------------------------------------
    def _identify(self) -> None:
        """Wait for a client's identification (every other message ignored)."""
        self.sock.settimeout(0.2)  # wakes up to see stop()
        while not self.stopping:
            try:
                message, addr = self.sock.recvfrom(4096)
            except TimeoutError:
                continue
            angles = parse_init(message)
            if angles is None:
                self._ignore(message, addr, "not an identification")
            elif self._accept(addr, angles):
                return

    def _accept(self, addr: tuple, angles: tuple[float, ...]) -> bool:
        """Make addr the client (its env ready for its angles); False, said why, when the angles
        are not SCR's 19 usable ones."""
        try:
            validate.angle_list(angles, name="sensor angles")
        except UsageError as exc:
            self.log(f"client {_who(addr)}: {exc}")
            return False
        if len(angles) != 19:
            self.log(f"client {_who(addr)} sent {len(angles)} sensor angles; SCR clients send 19")
            return False
        self.client, self.heard_at = addr, time.monotonic()
        self.waiting.discard(addr)
        self._send(IDENTIFIED)
        if self.env is None or angles != self.angles:
            if self.env is not None:
                self.env.close()
            self.env = TorcsEnv(**self.env_kwargs, track_sensor_angles_deg=angles)
            self.angles = angles
        self.log(f"client {_who(addr)} identified")
        return True

    def _ignore(self, message: bytes, addr: tuple, why: str) -> None:
        self.malformed += 1
        if self.malformed <= SHOWN_MALFORMED:
            more = "; more are counted, not shown" if self.malformed == SHOWN_MALFORMED else ""
            self.log(f"ignored a message from {_who(addr)} ({why}): {message[:60]!r}{more}")

    def _silent_s(self) -> float:
        return time.monotonic() - self.heard_at

    # --- a race --------------------------------------------------------------------------------
    def _race(self) -> bool:
        """One race with the identified client: True when it ended, False on a restart, a takeover
        or a lost client."""
        assert self.env is not None
        obs, info = self.env.reset()
        race, action = ScrRaceState(self.env), Action()
        self._send(race.sensors(obs, info["state"]))
        while not self.stopping:
            got = self._next_action(action)
            if got is None:
                self.log(f"the client was silent for {self.client_timeout_s:g} s; race stopped")
                self.client = None
                return False
            if isinstance(got, Takeover):
                old = _who(self.client)
                if self._accept(got.addr, got.angles):
                    self.log(f"client {_who(got.addr)} takes over from {old} (silent {self.client_timeout_s:g} s "
                             "or more); a new race")
                    return False
                continue
            if got is IDENTIFIED or action.restart:
                self._send(RESTART)
                self.log("the client asked for a restart")
                self.client = None  # it identifies again
                return False
            race.focus_deg = action.focus_deg
            obs, _, terminated, truncated, info = self.env.step(action.vector())
            race.dist_raced_m += info["progress_m"]
            if terminated or truncated:  # truncated: the race's end or a fault
                self.log(f"race over ({info['termination']}" + (f": {info['fault']})" if info["fault"] else ")"))
                self._send(SHUTDOWN)
                self.client = None
                return True
            self._send(race.sensors(obs, info["state"]))
        return False

    def _next_action(self, action: Action):
        """Read the client's answer into `action`: action (on time, or the last one when late),
        IDENTIFIED (it identified again: a restart), a Takeover, or None when it was silent for
        client_timeout_s."""
        deadline = time.monotonic() + self.answer_timeout_s
        while True:
            self.sock.settimeout(max(1e-3, deadline - time.monotonic()))
            try:
                message, addr = self.sock.recvfrom(4096)
            except TimeoutError:
                return None if self._silent_s() >= self.client_timeout_s else action  # late: the last one again
            if addr != self.client:
                if (other := self._other(message, addr)) is not None:
                    return other
            elif parse_init(message) is not None:
                self.heard_at = time.monotonic()
                return IDENTIFIED
            elif action.update(message):
                self.heard_at = time.monotonic()
                return action
            else:
                self._ignore(message, addr, "not an action message")
            if time.monotonic() >= deadline:
                return None if self._silent_s() >= self.client_timeout_s else action

    def _other(self, message: bytes, addr: tuple) -> Takeover | None:
        """A message from another address in a race: its identification takes over once the race's
        client has been silent for client_timeout_s; until then it is told to wait (WAIT, logged once)."""
        angles = parse_init(message)
        if angles is None:
            self._ignore(message, addr, "not from the race's client")
            return None
        if self._silent_s() >= self.client_timeout_s:
            return Takeover(addr, angles)
        self._send(WAIT + f" {self.client_timeout_s:g} s".encode(), addr)  # each time: the client asks again
        if addr not in self.waiting:
            self.waiting.add(addr)
            self.log(f"client {_who(addr)} identifies while another races; it takes over if that one is "
                     f"silent for {self.client_timeout_s:g} s")
        return None

    def _send(self, data: bytes, addr: tuple | None = None) -> None:
        """Send to `addr`, by default the race's client (none: nothing is sent)."""
        to = self.client if addr is None else addr
        if to is not None:
            try:
                self.sock.sendto(data, to)
            except OSError:
                pass  # a client that went away: noticed when it stays silent


def _who(addr: tuple | None) -> str:
    return "nobody" if addr is None else f"{addr[0]}:{addr[1]}"


def serve(port: int = 3001, track: str = "g-track-1", races: int | None = 1, **kwargs) -> int:
    """Run an SCR server on 127.0.0.1:port for `races` races (None: until interrupted)."""
    server = ScrServer(port=port, track=track, **kwargs)
    try:
        return server.serve(races)
    except KeyboardInterrupt:
        server.stop()
        return 0
