"""A track's segments and a car's constants exactly as the bridge sends them to a robot, without a
race to drive: a 0-lap race of the recorder robot (robot/recorder.py, under a second), kept under
the cache folder per track, car and wire layout (`CACHE/tracks/TRACK-CAR-KEY.npz`), so the next
call reads a file.  The limit lap (bench/limit.py) and `boxbox.testing` read them from here."""

from __future__ import annotations

import hashlib
import shutil
import tempfile
from pathlib import Path

from boxbox.cache import cache_dir
from boxbox.errors import BoxboxError
from boxbox.model import Car, Track
from boxbox.robot.recorder import RECORD_FILE, load_track
from boxbox.torcs import wire


def record_key(track: str, car: str) -> str:
    """The cache key of a recorded track and car: a changed wire layout records them again."""
    layout = ",".join(wire.SEGMENT_FIELDS + wire.HANDLE_FIELDS + wire.CAR_FIELDS)
    return hashlib.sha256(f"{track}\0{car}\0{layout}".encode()).hexdigest()[:16]


def recorded_track(track: str, car: str) -> tuple[Track, Car]:
    """The track's segments and the car's constants as the bridge sends them: from the cache, else
    from a 0-lap race of the recorder robot (under a second), then cached.  Unknown names are a
    one-line UsageError naming the nearest ones (torcs/checks.py)."""
    path = cache_dir() / "tracks" / f"{track}-{car}-{record_key(track, car)}.npz"
    if not path.exists():
        from boxbox.torcs import checks, launch, setup  # only to record: a cached pair reads a file

        overlay = setup.ensure_ready()
        category, _ = checks.check_race(track, car, 1, [], [], 1)
        path.parent.mkdir(parents=True, exist_ok=True)
        run = Path(tempfile.mkdtemp(prefix="record-", dir=path.parent))
        try:
            cfg = launch.RaceConfig(track=track, category=category, car=car, laps=0, telemetry=False,
                                    robots=["boxbox.robot.recorder:Recorder"], robot_names=["recorder 1"],
                                    run_dir=run, learning="off")
            result = launch.run_race(cfg, overlay)
            if result.error or not (run / RECORD_FILE).exists():
                raise BoxboxError(f"could not record {track} with {car}: {result.error or 'no track file'}")
            (run / RECORD_FILE).replace(path)
        finally:
            shutil.rmtree(run, ignore_errors=True)
    return load_track(path)
