"""The SCR server with a small UDP client written here from the protocol's description (the SCR
championship's manual): identification with sensor angles, sensor and action strings, focus,
a restart asked with `meta 1`, and the shutdown at the end of the race."""

from __future__ import annotations

import math
import os
import re
import socket
import subprocess
import time

import pytest

from boxbox.gym.env import TorcsEnv
from helpers import BOXBOX, GRID_IN_UNITS, ROOT, processes_mentioning, run_boxbox

GROUP = re.compile(r"\((\w+)([^()]*)\)")
ANGLES = [-45 + 5 * i for i in range(19)]  # not SCR's default: the server must use these


class Client:
    def __init__(self, port: int) -> None:
        self.addr = ("127.0.0.1", port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(10.0)
        self.gear = 1

    def identify(self, angles) -> None:
        """Send the identification until the server answers, as SCR clients do."""
        message = ("SCR(init " + " ".join(str(a) for a in angles) + ")").encode()
        self.sock.settimeout(0.5)
        for _ in range(40):
            self.sock.sendto(message, self.addr)
            try:
                answer, _ = self.sock.recvfrom(1000)
            except TimeoutError:
                continue
            if answer.startswith(b"***wait***"):  # another client races: ask again
                time.sleep(0.05)
                continue
            assert answer == b"***identified***", answer
            self.sock.settimeout(10.0)
            return
        raise AssertionError("the server never answered the identification")

    def receive(self) -> dict[str, list[float]] | str:
        data = self.sock.recvfrom(2000)[0].decode()
        if data.startswith("***"):
            return data
        return {name: [float(v) for v in values.split()] for name, values in GROUP.findall(data)}

    def act(self, sensors: dict, focus: float = 360.0, meta: int = 0) -> None:
        """A plain driver: steer along the axis at about 80 km/h, shift by engine speed."""
        steer = (sensors["angle"][0] - 0.5 * sensors["trackPos"][0]) / 0.366
        accel = max(0.0, min(1.0, (80.0 - sensors["speedX"][0]) / 20.0))
        rpm = sensors["rpm"][0]
        if rpm > 7000 and self.gear < 6:
            self.gear += 1
        elif rpm < 3000 and self.gear > 1:
            self.gear -= 1
        message = f"(accel {accel})(brake 0)(gear {self.gear})(steer {max(-1, min(1, steer))})(clutch 0)" \
                  f"(focus {focus})(meta {meta})"
        self.sock.sendto(message.encode(), self.addr)


@pytest.fixture
def start_server(overlay):
    """start_server(*options) -> (the scr-server process, its port); killed at the end."""
    started = []

    def start(*options: str) -> tuple[subprocess.Popen, int]:
        proc = subprocess.Popen([*BOXBOX, "scr-server", "--port", "0", "--track", "g-track-1", *options],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                                env=dict(os.environ, PYTHONUNBUFFERED="1"))
        started.append(proc)
        first = proc.stderr.readline()
        return proc, int(re.search(r"127\.0\.0\.1:(\d+)", first).group(1))

    yield start
    for proc in started:
        proc.kill()
        proc.wait()


@pytest.fixture
def server(start_server):
    return start_server("--opponents", "bt:2")


def test_an_scr_client_drives_restarts_and_is_shut_down_at_the_race_end(server):
    proc, port = server
    client = Client(port)
    client.identify(ANGLES)
    s = client.receive()
    assert set(s) == {"angle", "curLapTime", "damage", "distFromStart", "distRaced", "fuel", "gear", "lastLapTime",
                      "opponents", "racePos", "rpm", "speedX", "speedY", "speedZ", "track", "trackPos",
                      "wheelSpinVel", "z", "focus"}
    assert len(s["track"]) == 19 and len(s["opponents"]) == 36 and len(s["wheelSpinVel"]) == 4
    assert s["focus"] == [-1.0] * 5
    # the same race in the env, with the client's angles, sees the same (TORCS is deterministic)
    env = TorcsEnv(track="g-track-1", opponents=["bt:2"], track_sensor_angles_deg=ANGLES, **GRID_IN_UNITS)
    obs, info = env.reset()
    env.close()
    assert s["track"] == pytest.approx(obs["track_edges_m"].tolist(), rel=1e-5)
    assert s["speedX"][0] == pytest.approx(info["state"].speed_x_mps * 3.6, abs=1e-4)
    assert s["rpm"][0] == pytest.approx(info["state"].rpm * 60 / (2 * math.pi), rel=1e-5)
    assert min(s["opponents"]) < 30.0 and 0.0 < s["z"][0] < 1.0
    for _ in range(300):
        client.act(s, focus=0.0)
        s = client.receive()
    assert 60.0 < s["speedX"][0] < 100.0  # km/h
    assert all(0 < f <= 200 for f in s["focus"]) and s["distRaced"][0] > 50.0

    client.act(s, meta=1)
    assert client.receive() == "***restart***"
    client.identify(ANGLES)
    s = client.receive()
    assert s["distRaced"] == [0.0] and s["distFromStart"][0] > 2000.0  # a fresh race, on the grid again

    started = time.monotonic()
    steps = 0
    while isinstance(s, dict) and steps < 20_000:
        last = s
        client.act(s)
        s = client.receive()
        steps += 1
    assert s == "***shutdown***", s
    assert last["distRaced"][0] > 2000.0 and steps > 3000  # a whole lap of 2058 m, from the grid
    assert time.monotonic() - started < 60
    assert proc.wait(timeout=10) == 0  # one race served
    assert "1 race(s) served" in proc.stderr.read()
    assert processes_mentioning(f"boxbox-gym-{proc.pid}-") == []  # the server's TORCS (its folder has its pid)


def test_scr_server_and_bench_gym_refuse_bad_input_in_one_line(overlay):
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", 0))
    port = str(taken.getsockname()[1])
    for args, message in ((["scr-server", "--track", "g-track-9"], "unknown track 'g-track-9'"),
                          (["scr-server", "--port", port], f"UDP port {port} on 127.0.0.1 cannot be used"),
                          (["scr-server", "--opponents", "bt:2,bt:2"], "opponent bt:2 is given twice"),
                          (["scr-server", "--port", "70000"], "70000 is not in the range"),
                          (["scr-server", "--client-timeout-s", "nan"], "'--client-timeout-s': nan is not a finite"),
                          (["scr-server", "--client-timeout-s", "0"], "0.0 is not in the range 0.1<=x<=3600."),
                          (["bench-gym", "--track", "nowhere"], "unknown track 'nowhere'")):
        proc = run_boxbox(*args, timeout=60)
        assert proc.returncode == 2, proc.stderr
        lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("boxbox: error:")]
        assert len(lines) == 1 and message in lines[0], proc.stderr
    taken.close()


def drive_to_the_end(client: Client, s, limit: int = 20_000):
    steps = 0
    while isinstance(s, dict) and steps < limit:
        client.act(s)
        s = client.receive()
        steps += 1
    return s, steps


def test_malformed_datagrams_are_ignored_and_a_good_client_then_races_to_the_end(start_server):
    """A bad datagram is ignored with a line (a ValueError in the parser must not kill the server),
    before a client and from the identified client alike."""
    proc, port = start_server("--client-timeout-s", "5")
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for junk in (b"SCR(init " + b"- " * 19 + b")", b"(accel -)", b"\xff\x00(init .)", b"", b"ID(init 1e999)"):
        raw.sendto(junk, ("127.0.0.1", port))
    client = Client(port)
    client.identify(ANGLES)
    s = client.receive()
    for junk in (b"(accel -)", b"(accel 0.5)(brake .)", b"(gear e)", b"\x00" * 100):
        client.sock.sendto(junk, client.addr)
    s = client.receive()  # after the answer time the server steps on with the last action
    assert isinstance(s, dict) and s["distRaced"] == [0.0]
    last, steps = drive_to_the_end(client, s)
    assert last == "***shutdown***" and steps > 3000
    assert proc.wait(timeout=10) == 0
    err = proc.stderr.read()
    assert "1 race(s) served" in err and err.count("ignored a message from") == 5
    assert "more are counted, not shown" in err and "9 malformed messages ignored in all" in err
    assert "Traceback" not in err


def test_a_restarted_client_takes_over_once_the_old_one_is_silent(start_server):
    """A restarted SCR client comes from a new port: it takes over after --client-timeout-s of the old
    one's silence (snakeoil gives up after about 7 s), not before, and says so."""
    proc, port = start_server("--client-timeout-s", "1", "--races", "0")
    old = Client(port)
    old.identify(ANGLES)
    s = old.receive()
    new = Client(port)
    init = ("SCR(init " + " ".join(str(a) for a in ANGLES) + ")").encode()
    new.sock.settimeout(0.05)
    new.sock.settimeout(2.0)
    for _ in range(30):  # the old client drives on: the new one is told to wait, each time it asks
        new.sock.sendto(init, new.addr)
        old.act(s)
        s = old.receive()
        assert new.sock.recvfrom(1000)[0] == b"***wait*** another client is racing; identify again: this one " \
                                             b"takes over once that one is silent for 1 s"
    silent_since = time.monotonic()  # the old client is gone (killed, say)
    new.identify(ANGLES)
    took = time.monotonic() - silent_since
    assert 0.9 < took < 3.0, took
    s = new.receive()
    assert s["distRaced"] == [0.0]  # a new race
    for _ in range(50):
        new.act(s)
        s = new.receive()
    assert s["distRaced"][0] > 0.0
    assert proc.poll() is None
    proc.kill()
    err = proc.stderr.read()
    assert "identifies while another races; it takes over if that one is silent for 1 s" in err
    # whichever comes first: the new client's identification, or the answer time running out
    assert "takes over from 127.0.0.1:" in err or "the client was silent for 1 s; race stopped" in err
    assert err.count("identified") == 2
