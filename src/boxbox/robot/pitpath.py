"""The path into the own pit box: lateral offset against distance from the pit entry.

Seven points, as in the tutorial: entry (the line the car is on), start of the speed limit (pit
lane offset), one box length before the own box, the box, one box length after, end of the pit lane
(speed limit end), exit (back on the line).  Distances are along the track from the pit entry
("spline coordinates"); the start line may lie anywhere between entry and exit.

The curve is scipy's cubic Hermite spline with zero slope at every point but the first and last
(kind="hermite"), where it takes the line's own slope (`entry_slope`, `exit_slope`): it joins the
line tangentially, and between the inner points it is monotone, so it never leaves the band between
the lane and the box.  A C2 `CubicSpline` through the same points (kind="cubic") swings up to ~10 m
across the track middle on the recorded tracks (the 5 m box bump over 15 m excites the long spans),
so it is kept only for comparison.

Lateral offsets follow State.to_middle_m: + left.  The pit lane offset is |box offset| - pit lane
width (the box row is one lane width outside the lane).  The suggested "track width/2 + side width"
does not fit the recorded data: the side recorded along the boxes is often a 0.5 m wall strip
(e-track-2: 6.5 m while the box is at 18.5 m) and on g-track-1 it would put the lane (22.5 m) beyond
the box (20 m).

Everything per step (`to_spline_coord`, `offset_at`, `is_on_path`, `signed_coord`, `slope_at_s`) is
plain float arithmetic on lists (offset and slope) precomputed on a 1 m grid.
"""

from __future__ import annotations

import math
from functools import cached_property
from pathlib import Path

import numpy as np

from boxbox.cache import cached_array
from boxbox.model.car import Car
from boxbox.model.constants import G_MPS2
from boxbox.model.track import LEFT, Track

SPEED_MARGIN_MPS = 0.5  # stay this much under the pit speed limit
MIN_KNOT_GAP_M = 1.0  # points pushed apart when the box is next to the speed limit start / end


class PitPath:
    """Pit path of `car` on `track` (which must have a pit lane and the car a box)."""

    def _knot_positions(self, track_name: str) -> list[float]:
        """The spline's 7 points along the path (entry, limit start, box - 1, box, box + 1, limit
        end, exit), kept strictly increasing around the fixed box (first or last box of the row)."""
        x = [0.0, self.limit_start_m, self.box_m - self.box_length_m, self.box_m,
             self.box_m + self.box_length_m, self.limit_end_m, self.exit_m]
        for i in (2, 1):
            x[i] = min(x[i], x[i + 1] - MIN_KNOT_GAP_M)
        for i in (4, 5):
            x[i] = max(x[i], x[i - 1] + MIN_KNOT_GAP_M)
        x[6] = max(x[6], x[5] + MIN_KNOT_GAP_M)
        if x[1] <= x[0]:
            raise ValueError(f"{track_name}: pit entry too close to the box")
        return x

    def __init__(self, track: Track, car: Car, *, entry_offset_m: float = 0.0, exit_offset_m: float = 0.0,
                 lane_offset_m: float | None = None, kind: str = "hermite", grid_m: float = 1.0,
                 entry_slope: float = 0.0, exit_slope: float = 0.0) -> None:
        pit = track.pit
        if pit is None or car.pit_seg < 0:
            raise ValueError(f"{track.name}: no pit lane or no box for this car")
        if kind not in ("hermite", "cubic"):
            raise ValueError(f"kind must be 'hermite' or 'cubic', got {kind!r}")
        seg = track.seg
        starts = seg["start_dist_m"]
        lengths = seg["length_m"]
        self.track_length_m = float(track.length_m)
        self.entry_from_start_m = float(starts[pit.entry_seg])

        rel = self.to_spline_coord
        self.entry_m = 0.0
        self.limit_start_m = rel(float(starts[pit.start_seg]))
        self.box_m = rel(track.dist_of(car.pit_seg, car.pit_to_start))
        self.limit_end_m = rel(float(starts[pit.end_seg] + lengths[pit.end_seg]))
        self.exit_m = rel(float(starts[pit.exit_seg] + lengths[pit.exit_seg]))
        if not 0.0 < self.box_m < self.exit_m:
            raise ValueError(f"{track.name}: box at {self.box_m:.1f} m is not between entry and exit")

        self.side = int(pit.side)
        sign = 1.0 if self.side == LEFT else -1.0
        self.box_length_m = float(pit.box_length_m)
        self.lane_width_m = float(pit.width_m)
        self.speed_limit_mps = float(pit.speed_limit_mps) - SPEED_MARGIN_MPS
        # TORCS gives the box's toMiddle unsigned; the side gives the sign
        self.box_offset_m = sign * abs(float(car.pit_to_middle_m))
        self.lane_offset_m = (sign * (abs(self.box_offset_m) - self.lane_width_m)
                              if lane_offset_m is None else float(lane_offset_m))

        x = self._knot_positions(track.name)
        lane = self.lane_offset_m
        y = [float(entry_offset_m), lane, lane, self.box_offset_m, lane, lane, float(exit_offset_m)]
        self.knots_m: tuple[float, ...] = tuple(x)
        self.knot_offsets_m: tuple[float, ...] = tuple(y)
        # the line's own lateral slope (d offset / d s) where the path leaves and rejoins it: a path
        # joining a line that crosses the track (aalborg's pit exit in a chicane) with zero slope
        # kinks it, and the car spun out of the pit lane at 33 m/s
        if not (math.isfinite(entry_slope) and math.isfinite(exit_slope)):
            raise ValueError("entry_slope and exit_slope must be finite")
        self.knot_slopes: tuple[float, ...] = (float(entry_slope), 0.0, 0.0, 0.0, 0.0, 0.0, float(exit_slope))
        self.kind = kind
        self.exit_m = x[6]

        self._build_tables(float(grid_m))
        self._track = track
        self.surface_friction = self._lane_friction(track, car)

    def _build_tables(self, grid_m: float) -> None:
        """Per-step lookup tables: offset, slope and bend on a grid, kept in the cache (a race then
        needs no scipy import: scipy.interpolate alone takes about a second to load)."""
        self.grid_m = grid_m
        n = int(math.ceil(self.exit_m / self.grid_m)) + 1
        self._grid_s = np.minimum(np.arange(n) * self.grid_m, self.exit_m)

        def tables() -> np.ndarray:
            sp = self.spline
            return np.vstack([sp(self._grid_s), sp(self._grid_s, 1), sp(self._grid_s, 2)])

        key = repr((self.kind, self.grid_m, self.knots_m, self.knot_offsets_m, self.knot_slopes))
        table = cached_array("pit-paths", [Path(__file__).read_bytes(), key.encode()], tables)
        self._offsets: list[float] = table[0].tolist()
        self._slopes: list[float] = table[1].tolist()  # d offset / d s
        self._bends = table[2]  # d2 offset / d s2
        self._n = n

    # --- per step -----------------------------------------------------------------------------
    def to_spline_coord(self, dist_from_start_m: float) -> float:
        """Distance along the track from the pit entry, in [0, track length)."""
        return (dist_from_start_m - self.entry_from_start_m) % self.track_length_m

    def signed_coord(self, dist_from_start_m: float) -> float:
        """Like to_spline_coord, but negative (metres to go) before the entry: in [exit - L, exit]."""
        s = (dist_from_start_m - self.entry_from_start_m) % self.track_length_m
        return s if s <= self.exit_m else s - self.track_length_m

    def is_on_path(self, dist_from_start_m: float) -> bool:
        return (dist_from_start_m - self.entry_from_start_m) % self.track_length_m <= self.exit_m

    def offset_at_s(self, s_m: float) -> float:
        """Offset (to_middle, + left) at spline coordinate s_m in [0, exit_m] (clamped).

        Cubic Hermite between the grid's offsets and slopes: a few multiplications, and within
        millimetres of the spline (linear interpolation would cut the box corner by ~2 cm)."""
        if s_m <= 0.0:
            return self._offsets[0]
        f = s_m / self.grid_m
        i = int(f)
        if i >= self._n - 1:
            return self._offsets[-1]
        h = self.grid_m if i < self._n - 2 else self.exit_m - i * self.grid_m  # the last cell is shorter
        t = (s_m - i * self.grid_m) / h if h > 0.0 else 1.0
        y0, y1 = self._offsets[i], self._offsets[i + 1]
        m0, m1 = self._slopes[i] * h, self._slopes[i + 1] * h
        t2 = t * t
        t3 = t2 * t
        return (y0 * (2.0 * t3 - 3.0 * t2 + 1.0) + m0 * (t3 - 2.0 * t2 + t)
                + y1 * (3.0 * t2 - 2.0 * t3) + m1 * (t3 - t2))

    def slope_at_s(self, s_m: float) -> float:
        """d offset / d s at s_m (linear between grid points; 0 outside the path)."""
        if s_m <= 0.0 or s_m >= self.exit_m:
            return 0.0
        f = s_m / self.grid_m
        i = int(f)
        if i >= self._n - 1:
            return self._slopes[-1]
        a = self._slopes[i]
        h = self.grid_m if i < self._n - 2 else self.exit_m - i * self.grid_m  # the last cell is shorter
        return a + (self._slopes[i + 1] - a) * ((s_m - i * self.grid_m) / h if h > 0.0 else 1.0)

    def offset_at(self, dist_from_start_m: float, default_m: float = 0.0) -> float:
        """Offset of the path at a distance from the start line; default_m when off the path."""
        s = (dist_from_start_m - self.entry_from_start_m) % self.track_length_m
        if s > self.exit_m:
            return default_m
        return self.offset_at_s(s)

    # --- per track ----------------------------------------------------------------------------
    @cached_property
    def spline(self):
        """The scipy spline through the seven points (built on first use)."""
        from scipy.interpolate import CubicHermiteSpline, CubicSpline

        x, y = self.knots_m, self.knot_offsets_m
        if self.kind == "hermite":
            return CubicHermiteSpline(x, y, np.asarray(self.knot_slopes))
        return CubicSpline(x, y, bc_type="clamped")

    def _lane_friction(self, track: Track, car: Car) -> float:
        """Lowest friction the car meets between entry and exit: the main surface, and the side on
        the pit side where that side is wide enough to carry the car (narrow sides are walls/kerbs)."""
        pit = track.pit
        assert pit is not None
        seg = track.seg
        n = track.n_segments
        ids = [(pit.entry_seg + k) % n for k in range((pit.exit_seg - pit.entry_seg) % n + 1)]
        side = "left" if self.side == LEFT else "right"
        mu = min(float(seg["friction"][i]) for i in ids)
        for i in ids:
            if float(seg[f"{side}_side_width_m"][i]) >= car.width_m:
                mu = min(mu, float(seg[f"{side}_side_friction"][i]))
        return mu

    def curvature_at(self, s_m: np.ndarray) -> np.ndarray:
        """Curvature (1/m, + left) of the path: track curvature at that offset plus the spline's bend.

        Small-angle approximation (the path's slope stays below ~0.2 before the box)."""
        track = self._track
        d = (np.asarray(s_m, dtype=float) + self.entry_from_start_m) % self.track_length_m
        idx = np.clip(np.searchsorted(track.seg["start_dist_m"], d, side="right") - 1, 0, track.n_segments - 1)
        k_track = track.curvature()[idx]
        y = np.interp(s_m, self._grid_s, self._offsets)
        with np.errstate(divide="ignore", invalid="ignore"):
            k_offset = np.where(np.abs(1.0 - k_track * y) > 1e-6, k_track / (1.0 - k_track * y), 0.0)
        return k_offset + np.interp(s_m, self._grid_s, self._bends)

    def _grip_speeds(self, s_m: np.ndarray, mu: float, g_mps2: float, max_speed_mps: float) -> np.ndarray:
        """The path's grip limit sqrt(mu g / |k|) (m/s, no downforce) at s_m, at most max_speed_mps."""
        k = np.abs(self.curvature_at(s_m))
        with np.errstate(divide="ignore"):
            return np.minimum(np.sqrt(mu * g_mps2 / k), max_speed_mps)

    def exit_speed_caps(self, mu: float, decel_mps2: float, g_mps2: float = G_MPS2,
                        max_speed_mps: float = 100.0) -> tuple[float, list[float]]:
        """(start s_m, speed cap per metre from there to the exit): the grip limit sqrt(mu g / |k|) of
        the path from the end of the speed limit back to the line, without downforce, lowered
        ahead of each tight part to the speed from which decel_mps2 slows the car to it in time.
        The line's own speed profile is for the line's curvature: a path rejoining a line that
        swings across the track (aalborg's exit into a turn) bends harder, and at the line's speed
        the car slid off its outside (1100 damage at each stop)."""
        if not (mu > 0.0 and decel_mps2 > 0.0 and math.isfinite(mu + decel_mps2)):
            raise ValueError(f"mu ({mu}) and decel_mps2 ({decel_mps2}) must be positive and finite")
        start = self.limit_end_m
        s = np.arange(start, self.exit_m + 1e-9, 1.0)
        if len(s) == 0:
            return start, []
        v = self._grip_speeds(s, mu, g_mps2, max_speed_mps)
        for i in range(len(v) - 2, -1, -1):  # braking ahead: v^2 = v_next^2 + 2 a (1 m)
            v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * decel_mps2))
        return float(start), v.tolist()

    def entry_speed_constraints(self, mu: float, g_mps2: float = G_MPS2,
                                max_speed_mps: float = 100.0) -> list[tuple[float, float]]:
        """(s_m, speed_mps) where the path from the entry to the speed limit start is slowest.

        Grip limit v = sqrt(mu g / |k|) without downforce (conservative), sampled every metre; the
        local minima below max_speed_mps are returned in path order.  A brake filter that meets
        these speeds (and the speed limit) brakes exactly as early as the entry needs.
        """
        end = min(self.limit_start_m, self.knots_m[1])
        s = np.arange(0.0, end + 1e-9, 1.0)
        if len(s) < 3:
            return []
        v = self._grip_speeds(s, mu, g_mps2, max_speed_mps)
        out: list[tuple[float, float]] = []
        for i in range(len(v)):
            lo = v[i - 1] if i > 0 else math.inf
            hi = v[i + 1] if i + 1 < len(v) else math.inf
            if v[i] < max_speed_mps and v[i] <= lo and v[i] < hi:
                out.append((float(s[i]), float(v[i])))
        return out
