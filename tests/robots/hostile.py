"""Robots that test the runtime around them (issue 14's cases), one way each."""

import subprocess
import sys
import time

from boxbox import Controls
from boxbox.robot.simple import MiddleRobot


class ExitsInDrive(MiddleRobot):
    """sys.exit() in drive: the robot exiting, reported at once (not a hang after the budget)."""

    def drive(self, state):
        if state.sim_time_s > 1.0:
            sys.exit()
        return super().drive(state)


class ExitsInOnTrack(MiddleRobot):
    def on_track(self, track, car):
        sys.exit(3)


class StartsSessionChild(MiddleRobot):
    """Starts a child in a session of its own (setsid) and a double-forked one, then races on."""

    started = False

    def drive(self, state):
        if not self.started:
            self.started = True
            subprocess.Popen(["sleep", "600"], start_new_session=True)
            subprocess.Popen(["sh", "-c", "setsid sleep 601 & exit 0"], start_new_session=True).wait()
        return super().drive(state)


class NeverMoves(MiddleRobot):
    """Stands on the brakes: the race would never end without its simulated-time limit."""

    def drive(self, state):
        return Controls(steer=0.0, accel=0.0, brake=1.0, clutch=0.0, gear=1)


class NearItsBudget(MiddleRobot):
    """Takes 4 ms of every drive step: well within a 50 ms step budget, slow over a whole race."""

    def drive(self, state):
        time.sleep(0.004)
        return super().drive(state)


class AsksForAStopOnTheTrack(MiddleRobot):
    """Asks for a pit stop all race long but drives the middle of the track: never in the pit lane."""

    def drive(self, state):
        c = super().drive(state)
        c.pit_request = True
        return c


class Talks(MiddleRobot):
    """Prints on stdout and stderr (kept in RUN_DIR/host.log, shown live unless quiet)."""

    said = False

    def drive(self, state):
        if not self.said:
            self.said = True
            print("hello from the robot", flush=True)
            print("a warning from the robot", file=sys.stderr, flush=True)
        return super().drive(state)




class TalksThenFails(MiddleRobot):
    """Prints "line 1" .. "line 7" on its first drive steps (the last two on stderr, one without
    flush), reads its own prints back from host.log as the race runs, then raises."""

    name = "talker"
    step = 0

    def drive(self, state):
        self.step += 1
        if self.step <= 7:
            print(f"line {self.step}", file=sys.stderr if self.step > 5 else sys.stdout, flush=self.step != 6)
        elif self.step == 8:
            self.wait_for_own_prints()
        else:
            raise RuntimeError("done talking")
        return super().drive(state)

    @staticmethod
    def wait_for_own_prints() -> None:
        """As they happen: each line is in host.log, marked with the car, while the race runs."""
        import os
        from pathlib import Path

        log = Path(os.environ["BOXBOX_RUN_DIR"]) / "host.log"
        for _ in range(100):
            if "[talker 1] line 7" in log.read_text():
                return
            time.sleep(0.02)
        raise RuntimeError(f"my prints are not in host.log yet: {log.read_text()!r}")


class Crawls(MiddleRobot):
    """Follows the middle at walking pace (2 m/s): the race lasts longer than its simulated-time limit."""

    def drive(self, state):
        c = super().drive(state)
        fast = state.speed_x_mps > 2.0
        return Controls(steer=c.steer, accel=0.0 if fast else 0.3, brake=0.2 if fast else 0.0, clutch=0.0, gear=1)


class NumpyControls(MiddleRobot):
    """Answers with numpy scalars and 0-d arrays, and a gear as a whole float (as State.gear is)."""

    def drive(self, state):
        import numpy as np

        c = super().drive(state)
        return Controls(steer=np.float32(c.steer), accel=np.float64(c.accel), brake=np.array(c.brake),
                        clutch=np.float32(c.clutch), gear=np.int64(c.gear) if state.laps > 1 else float(c.gear))


class StopsTorcs(MiddleRobot):
    """After a second of racing, stops its own TORCS (SIGSTOP): TORCS no longer calls the robots,
    as when torcs-bin spins at full CPU mid-race."""

    stopped = False

    def drive(self, state):
        if state.sim_time_s > 1.0 and not self.stopped:
            import os
            import signal

            import psutil

            self.stopped = True
            run_dir = os.environ["BOXBOX_RUN_DIR"]
            for proc in psutil.process_iter(["name"]):
                try:
                    if "torcs" in (proc.info["name"] or "") and proc.environ().get("BOXBOX_RUN_DIR") == run_dir:
                        os.kill(proc.pid, signal.SIGSTOP)
                except (psutil.Error, OSError):
                    pass
        return super().drive(state)


class StartsDaemons(MiddleRobot):
    """Double-forks two daemons the classic way (fork, setsid, fork) without going through the shell:
    one runs `sleep 300.25` with an empty environment, the other sleeps in Python, never exec'd (so
    both lack the race's BOXBOX_RUN_DIR in their environment as the system shows it)."""

    started = False

    def drive(self, state):
        if not self.started:
            import os
            import time

            self.started = True
            for execs in (True, False):
                if os.fork() == 0:
                    os.setsid()
                    if os.fork() == 0:
                        if execs:
                            os.execve("/bin/sleep", ["sleep", "300.25"], {})
                        time.sleep(300)
                    os._exit(0)
                os.wait()
        return super().drive(state)


class TakesTooMuchMemory(MiddleRobot):
    """Maps 3 GiB after a second of racing (numpy.empty: reserved, never touched, so no memory is used)."""

    def drive(self, state):
        if state.sim_time_s > 1.0:
            import numpy as np

            self.hoard = np.empty(3 << 30, dtype=np.uint8)
        return super().drive(state)
