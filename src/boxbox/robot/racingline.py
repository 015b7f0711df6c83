"""A per-track racing line: the track middle line sampled every few metres, then the lateral offset
that minimises the curvature of the driven path while staying inside the track.

Computed once per track (`RacingLine(track)`, well under a second for a 7 km track).  While
driving, `point_at` gives a look-ahead steering target and `curvature_at` feeds the speed profile;
those lookups are plain Python (lists and one linear interpolation), no numpy per call.

Method: the line is P_i + n_i * N_i (middle point, left normal, offset n_i in metres, + left).
The curvature at sample i is approximated by the second difference of the line points projected on
the line's own normal, divided by the local spacing squared.  With the normal and spacing taken from
the previous estimate this is linear in n, so "sum of squared curvatures, subject to the track
bounds" is a sparse convex quadratic programme; it is solved by an active-set method on the
bound constraints, and the linearisation is refreshed a few times (sequential QP).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from boxbox.cache import cached_array
from boxbox.control import minline
from boxbox.control.minline import closed_curvature, curvature_rows, solve_box_qp
from boxbox.model.track import LEFT, STRAIGHT, Track

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, eq=False)
class MiddleLine:
    """The track middle line at a uniform distance step; every array has n + 1 samples, the last one
    at dist_m == length_m closing the loop (it should coincide with the first)."""

    length_m: float
    step_m: float  # actual step: length_m / n, close to the requested one
    dist_m: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    heading_rad: np.ndarray  # direction of travel, unwrapped (continuous over the lap)
    half_left_m: np.ndarray  # usable room left of the middle (width / 2 - margin)
    half_right_m: np.ndarray  # usable room right of the middle, positive
    friction: np.ndarray
    seg_id: np.ndarray  # segment holding each sample
    seg_frac: np.ndarray  # how far along that segment (0..1)
    curvature_1pm: np.ndarray  # exact curvature of the middle line from the segments, + left
    z_m: np.ndarray  # elevation of the middle (linear along each segment, as TORCS has it)
    bank_rad: np.ndarray  # the road's roll, + where the left edge is higher (TORCS's banking angle)

    @property
    def n(self) -> int:
        """Number of distinct samples (the closing sample excluded)."""
        return len(self.dist_m) - 1


def middle_line(track: Track, step_m: float = 2.0, margin_m: float = 0.0) -> MiddleLine:
    """Sample the middle line every ~step_m metres from the start line round to the start line."""
    seg = track.seg
    length_m = float(track.length_m)
    n = max(8, int(round(length_m / step_m)))
    dist_m = np.linspace(0.0, length_m, n + 1)

    starts = seg["start_dist_m"].astype(float)
    ids = np.clip(np.searchsorted(starts, dist_m, side="right") - 1, 0, len(starts) - 1)
    local_m = dist_m - starts[ids]
    # float32 track data: the last segment may end a few cm before/after length_m; clamp the local
    # distance so no sample is extrapolated past its segment end (except that last tiny bit)
    seg_len = seg["length_m"].astype(float)[ids]
    frac = np.clip(local_m / np.where(seg_len > 0, seg_len, 1.0), 0.0, 1.0)

    typ = seg["type"][ids].astype(int)
    h0 = seg["start_angle_rad"].astype(float)[ids]
    radius = seg["radius_m"].astype(float)[ids]
    arc = seg["arc_rad"].astype(float)[ids]

    # straights: linear between the start and end midpoints (the midpoint of the two vertices)
    sx = 0.5 * (seg["start_left_x"] + seg["start_right_x"])[ids]
    sy = 0.5 * (seg["start_left_y"] + seg["start_right_y"])[ids]
    ex = 0.5 * (seg["end_left_x"] + seg["end_right_x"])[ids]
    ey = 0.5 * (seg["end_left_y"] + seg["end_right_y"])[ids]
    x = sx + frac * (ex - sx)
    y = sy + frac * (ey - sy)
    heading = h0.copy()

    # turns: the middle is an arc of radius_m around the centre; the left normal is (-sin h, cos h),
    # so a left turn's centre lies at +R * normal (middle = centre + R * (sin h, -cos h)) and a right
    # turn's at -R * normal; the heading turns by the swept angle
    turn = typ != STRAIGHT
    sign = np.where(typ == LEFT, 1.0, -1.0)
    h = h0 + sign * frac * arc
    cx, cy = seg["center_x"].astype(float)[ids], seg["center_y"].astype(float)[ids]
    x = np.where(turn, cx + sign * radius * np.sin(h), x)
    y = np.where(turn, cy - sign * radius * np.cos(h), y)
    heading = np.where(turn, h, heading)
    heading = np.unwrap(heading)

    width = seg["start_width_m"][ids] + frac * (seg["end_width_m"][ids] - seg["start_width_m"][ids])
    half = np.maximum(0.5 * width.astype(float) - margin_m, 0.0)
    with np.errstate(divide="ignore"):
        k = np.where(turn, sign / np.where(radius > 0, radius, math.inf), 0.0)
    z0 = seg["start_z_m"].astype(float)[ids]
    no_bank = np.zeros(len(starts))  # tracks recorded before the bridge sent banking
    b0 = seg.get("banking_start_rad", no_bank).astype(float)[ids]
    b1 = seg.get("banking_end_rad", no_bank).astype(float)[ids]
    return MiddleLine(length_m=length_m, step_m=length_m / n, dist_m=dist_m, x_m=x, y_m=y,
                      heading_rad=heading, half_left_m=half, half_right_m=half.copy(),
                      friction=seg["friction"].astype(float)[ids], seg_id=ids, seg_frac=frac, curvature_1pm=k,
                      z_m=z0 + frac * (seg["end_z_m"].astype(float)[ids] - z0), bank_rad=b0 + frac * (b1 - b0))


def road_height_m(track: Track, dist_m: np.ndarray, to_middle_m: np.ndarray) -> np.ndarray:
    """The road's height (m) at distances from the start line and offsets from the middle (+ left),
    as TORCS computes it (RtTrackHeightL, without a surface's roughness): the right edge rises
    linearly along each segment, and across it the road climbs by tan(banking), the banking
    itself linear along the segment.  So the height's slope jumps where segments meet."""
    seg = track.seg
    starts = seg["start_dist_m"].astype(float)
    d = np.asarray(dist_m, dtype=float) % track.length_m
    ids = np.clip(np.searchsorted(starts, d, side="right") - 1, 0, len(starts) - 1)
    length = seg["length_m"].astype(float)[ids]
    frac = np.clip((d - starts[ids]) / np.where(length > 0, length, 1.0), 0.0, 1.0)
    no_bank = np.zeros(len(starts))
    b0 = seg.get("banking_start_rad", no_bank).astype(float)[ids]
    b1 = seg.get("banking_end_rad", no_bank).astype(float)[ids]
    w0, w1 = seg["start_width_m"].astype(float)[ids], seg["end_width_m"].astype(float)[ids]
    right0 = seg["start_z_m"].astype(float)[ids] - 0.5 * w0 * np.tan(b0)
    right1 = seg["end_z_m"].astype(float)[ids] - 0.5 * w1 * np.tan(b1)
    width = w0 + frac * (w1 - w0)
    bank = b0 + frac * (b1 - b0)
    return right0 + frac * (right1 - right0) + (0.5 * width + np.asarray(to_middle_m, dtype=float)) * np.tan(bank)


def _closed_curvature(x_m: np.ndarray, y_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed curvature (+ left, the circle through each point and its two neighbours: exact on
    sampled arcs, where an interpolating spline rings at every turn entry), heading (unwrapped) and
    chord length to the next point for a closed polyline of n distinct points."""
    k, d_out = closed_curvature(x_m, y_m)
    heading = np.unwrap(np.arctan2(np.roll(y_m, -1) - np.roll(y_m, 1), np.roll(x_m, -1) - np.roll(x_m, 1)))
    return k, heading, d_out


def _min_curvature_offsets(mid: MiddleLine, iterations: int, peak_cap: float, cap_window_m: float) -> np.ndarray:
    """Lateral offsets (n samples) of the minimum-curvature line inside the bounds of `mid`.

    Objective: sum of squared curvatures, subject to |k| <= peak_cap * (the middle line's largest
    |k| within +-cap_window_m).  Pure sum-of-squares lines spread curvature into spirals and, in
    long or S-shaped turns, end up with a sharper apex than the middle line; the cap keeps every
    corner at least as open as the track's own radius, which is what sets the corner speed.  It is a
    constraint, not a penalty: a penalty pulling k towards the cap also held short hairpins at the
    track's own radius where the free line opens them up (aalborg: 12.6 m against 17-22 m).
    Where the width cannot meet the cap, the cap is widened until it can.
    """
    # scipy is imported here only: a cached line needs none of it (and it takes a second to load)
    from scipy.ndimage import maximum_filter1d

    n = mid.n
    px, py = mid.x_m[:n], mid.y_m[:n]
    nx, ny = -np.sin(mid.heading_rad[:n]), np.cos(mid.heading_rad[:n])
    lo, hi = -mid.half_right_m[:n], mid.half_left_m[:n]
    k_mid = np.abs(mid.curvature_1pm[:n])
    win = 2 * int(round(cap_window_m / mid.step_m)) + 1
    envelope = maximum_filter1d(k_mid, min(win, n), mode="wrap")
    # only near turns: long straights stay free so the line can cross the track between corners
    capped = np.flatnonzero(envelope > 0.0)
    cap = peak_cap * envelope[capped]

    off = np.zeros(n)
    for _ in range(max(1, iterations)):
        new = _capped_step(px, py, nx, ny, off, lo, hi, capped, cap)
        done = np.max(np.abs(new - off)) < 2e-3
        off = new
        if done:
            break
    return off


def _capped_step(px: np.ndarray, py: np.ndarray, nx: np.ndarray, ny: np.ndarray, off: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray, capped: np.ndarray, cap: np.ndarray) -> np.ndarray:
    """One sequential-QP pass: min |A a + c|^2 with the curvature linearised about the line `off`,
    |k| <= cap on the `capped` rows (widened by 10 % at a time while infeasible)."""
    import scipy.sparse as sp

    n = len(off)
    a, c = curvature_rows(px, py, nx, ny, off)
    h = (a.T @ a).tocsr()
    # a tiny pull to the middle makes H strictly positive definite (a straight track alone
    # would leave a free sideways shift) without moving the line measurably
    h = h + sp.identity(n, format="csr") * (1e-9 * float(h.diagonal().mean()) + 1e-12)
    g = a.T @ c
    rows, base = a[capped], c[capped]
    for widen in (1.0, 1.1, 1.21, 1.33, 1.46, 1.61):
        try:
            return solve_box_qp(h, g, lo, hi, rows, -cap * widen - base, cap * widen - base)
        except RuntimeError:
            continue
    return solve_box_qp(h, g, lo, hi)


def turn_regions(mid: MiddleLine, merge_m: float = 60.0) -> list[np.ndarray]:
    """Sample indices of each corner: runs of turn samples, merged across straights shorter than
    merge_m (a kink just before a hairpin belongs to the hairpin).  A track that is all turn is one
    region."""
    n = mid.n
    turn = mid.curvature_1pm[:n] != 0.0
    if turn.all() or not turn.any():
        return [np.arange(n)] if turn.any() else []
    start = int(np.argmin(turn))  # a straight sample: runs then never wrap past the end
    order = np.roll(np.arange(n), -start)
    t = turn[order]
    edges = np.flatnonzero(np.diff(t.astype(np.int8)))
    if t[-1]:  # a turn running up to the origin's straight sample ends there
        edges = np.append(edges, n - 1)
    runs = [(int(b0) + 1, int(b1) + 1) for b0, b1 in zip(edges[::2], edges[1::2], strict=False)]
    merged: list[list[int]] = []
    for r0, r1 in runs:
        if merged and (r0 - merged[-1][1]) * mid.step_m < merge_m:
            merged[-1][1] = r1
        else:
            merged.append([r0, r1])
    regions = [order[r0:r1] for r0, r1 in merged]
    # the last corner may also be close to the first one across the sampling origin
    if len(merged) > 1 and (merged[0][0] + n - merged[-1][1]) * mid.step_m < merge_m:
        regions[0] = np.concatenate((order[merged[-1][0]:], order[:merged[0][1]]))
        regions.pop()
    return regions


def vertical_curvature(z_m: np.ndarray, step_m: float, smooth_m: float = 6.0) -> np.ndarray:
    """Second derivative of the elevation along a closed lap (1/m, + in a dip, - over a crest).

    TORCS elevations are linear per segment, so the raw second difference is a train of spikes
    where the slope changes; a Gaussian of `smooth_m` (about the wheelbase and suspension travel
    that the car itself smooths over) spreads each spike over the stretch the car feels it.
    """
    from scipy.ndimage import gaussian_filter1d

    sigma = max(smooth_m / step_m, 0.5)
    # smooth, then difference: a Gaussian second-derivative kernel cut at 4 sigma does not sum to
    # zero and would read altitude itself as a crest; a plain second difference is exact for it
    z = gaussian_filter1d(np.asarray(z_m, dtype=float), sigma, mode="wrap")
    return (np.roll(z, -1) - 2.0 * z + np.roll(z, 1)) / (step_m * step_m)


def road_roughness(z_m: np.ndarray, step_m: float, short_m: float = 2.0, long_m: float = 6.0,
                   span_m: float = 10.0, floor_1pm: float = 0.005) -> np.ndarray:
    """Short-wave vertical curvature (1/m, >= 0): what the elevation curves at `short_m` smoothing
    beyond its curvature at `long_m` (the car's scale, `vertical_curvature`), the largest within
    `span_m`, so a washboard reads as one rough stretch, not as alternating bumps and gaps.

    Below `floor_1pm`, 0: the kinks where TORCS's linear segments meet stay below 0.0035 on every
    recorded road track, while dirt-2's washboard reaches 0.05.
    """
    from scipy.ndimage import maximum_filter1d

    short = vertical_curvature(z_m, step_m, short_m) - vertical_curvature(z_m, step_m, long_m)
    size = max(1, int(round(span_m / step_m)) | 1)
    rough = maximum_filter1d(np.abs(short), size, mode="wrap")
    return np.where(rough >= floor_1pm, rough, 0.0)


def _moving_average_wrap(a: np.ndarray, win: int) -> np.ndarray:
    """Centred moving average over an odd window on a closed loop."""
    half = win // 2
    padded = np.concatenate((a[-half:], a, a[:half]))
    return np.convolve(padded, np.full(win, 1.0 / win), mode="valid")


def _optimal_offsets(mid: MiddleLine, iterations: int, peak_cap: float, cap_window_m: float,
                     cache: bool) -> np.ndarray:
    """_min_curvature_offsets, cached: the same track and settings give the same line."""
    def solve() -> np.ndarray:
        return _min_curvature_offsets(mid, iterations, peak_cap, cap_window_m)

    if not cache:
        return solve()
    key = [Path(__file__).read_bytes(), Path(minline.__file__).read_bytes(),
           repr((iterations, peak_cap, cap_window_m)).encode(),
           *(np.ascontiguousarray(a).tobytes() for a in (mid.x_m, mid.y_m, mid.half_left_m, mid.half_right_m))]
    return cached_array("racing-lines", key, solve)


def washboard(roughness_1pm: np.ndarray, step_m: float, min_length_m: float = 30.0,
              join_gap_m: float = 20.0) -> np.ndarray:
    """Per sample of a closed lap: True inside a washboard, a rough stretch (roughness > 0, gaps
    under `join_gap_m` bridged) at least `min_length_m` long. Bumps that repeat shake the car at its
    own frequency and bottom it out (dirt-2); a single kink (a jump's lip, a slope change) is one
    kick the suspension absorbs."""
    rough = np.asarray(roughness_1pm, dtype=float) > 0.0
    if rough.ndim != 1 or step_m <= 0 or min_length_m < 0 or join_gap_m < 0:
        raise ValueError("roughness_1pm must be 1-D, step_m > 0, lengths >= 0")
    n = len(rough)
    if not rough.any():
        return rough
    if rough.all():
        return rough if n * step_m >= min_length_m else np.zeros(n, bool)
    start = int(np.argmin(rough))  # walk the loop from a smooth sample: no run wraps past it
    order = np.roll(np.arange(n), -start)
    flags, out = rough[order], np.zeros(n, bool)
    edges = np.flatnonzero(np.diff(np.r_[0, flags.astype(int), 0]))
    runs = [[int(a), int(b)] for a, b in zip(edges[::2], edges[1::2], strict=True)]
    joined = [runs[0]]
    for a, b in runs[1:]:
        if (a - joined[-1][1]) * step_m < join_gap_m:
            joined[-1][1] = b
        else:
            joined.append([a, b])
    for a, b in joined:
        if (b - a) * step_m >= min_length_m:
            out[order[a:b]] = True
    return out


def _road_profiles(z_m: np.ndarray, step_m: float, cache: bool) -> tuple[np.ndarray, np.ndarray]:
    """(vertical curvature, roughness), cached like the line: scipy.ndimage's filters cost a race
    ~0.3 s of imports alone."""
    def compute() -> np.ndarray:
        return np.stack((vertical_curvature(z_m, step_m), road_roughness(z_m, step_m)))

    if not cache:
        kv, rough = compute()
        return kv, rough
    kv, rough = cached_array("road-profiles", [Path(__file__).read_bytes(), repr(step_m).encode(),
                                               np.ascontiguousarray(z_m).tobytes()], compute)
    return kv, rough


class RacingLine:
    """Minimum-curvature line of one track.

    Arrays (n + 1 samples every `step_m` along the middle line, the last one closing the loop):
    dist_m, offset_m (to_middle of the line, + left), x_m, y_m, heading_rad, curvature_1pm (signed,
    + left, smoothed), curvature_raw_1pm (unsmoothed), length_factor (racing-line metres per
    middle-line metre), and `middle` (the sampled middle line with its bounds).

    blend: 0 = the middle line, 1 = the optimised line, in between a linear mix of the offsets.
    margin_m: kept from each track edge (car half width ~0.95 m + safety).
    bounds_m: (left, right) room for the line per sample instead (robot/drivable.py).
    """

    def __init__(self, track: Track, step_m: float = 2.0, margin_m: float = 1.2, blend: float = 1.0,
                 iterations: int = 12, smooth_m: float = 6.0, peak_cap: float = 0.97,
                 cap_window_m: float = 60.0, cache: bool = True,
                 bounds_m: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        mid = middle_line(track, step_m, margin_m)
        if bounds_m is not None:  # the room left and right per sample (n), instead of width / 2 - margin
            mid = dataclasses.replace(mid, half_left_m=np.append(bounds_m[0], bounds_m[0][0]),
                                      half_right_m=np.append(bounds_m[1], bounds_m[1][0]))
        self.middle = mid
        self.blend = float(blend)
        self.margin_m = float(margin_m)
        self.step_m = mid.step_m
        self.length_m = mid.length_m
        n = mid.n
        px, py = mid.x_m[:n], mid.y_m[:n]
        nx, ny = -np.sin(mid.heading_rad[:n]), np.cos(mid.heading_rad[:n])
        lo, hi = -mid.half_right_m[:n], mid.half_left_m[:n]
        self.optimal_offset_m = _optimal_offsets(mid, iterations, peak_cap, cap_window_m, cache)
        off = np.clip(self.blend * self.optimal_offset_m, lo, hi)
        x, y = px + off * nx, py + off * ny
        k_raw, heading, chord = _closed_curvature(x, y)
        # a short moving average: takes the corners off the curvature steps where straights meet
        # turns (the speed profile then ramps instead of jumping) without overshoot (savgol rings
        # at such steps by ~7 %) and without lowering any turn's plateau longer than the window
        win = max(1, int(round(smooth_m / self.step_m)) | 1)
        k = _moving_average_wrap(k_raw, win) if 1 < win < n else k_raw
        factor = 0.5 * (chord + np.roll(chord, 1)) / self.step_m

        def closed(a: np.ndarray, wrap_add: float = 0.0) -> np.ndarray:
            return np.append(a, a[0] + wrap_add)

        turns = TWO_PI * round((mid.heading_rad[n] - mid.heading_rad[0]) / TWO_PI)
        self.dist_m = mid.dist_m
        self.offset_m = closed(off)
        self.x_m = closed(x)
        self.y_m = closed(y)
        self.heading_rad = closed(heading, turns)
        self.curvature_raw_1pm = closed(k_raw)
        self.curvature_1pm = closed(k)
        self.length_factor = closed(factor)
        self.path_length_m = float(chord.sum())
        # the road's height under the line, not under the middle: where the banking changes, the
        # edges rise and fall against the middle (ole-road-1: 15 -> 5 degrees in 35 m lifts the inner
        # edge 0.7 m more than the middle, a crest that threw the car off its wheels at 80 m/s)
        kv, rough = _road_profiles(mid.z_m[:n] + off * np.sin(mid.bank_rad[:n]), self.step_m, cache)
        self.vertical_curvature_1pm = closed(kv)
        self.roughness_1pm = closed(rough)

        # plain lists for the per-step lookups
        self._n = n
        self._off = self.offset_m.tolist()
        self._x = self.x_m.tolist()
        self._y = self.y_m.tolist()
        self._h = self.heading_rad.tolist()
        self._k = self.curvature_1pm.tolist()
        self._f = self.length_factor.tolist()


    # ---- per-step lookups: plain Python, linear interpolation between samples -----------------

    def _locate(self, dist_m: float) -> tuple[int, float]:
        pos = (dist_m % self.length_m) / self.step_m
        i = int(pos)
        if i >= self._n:  # dist_m % length_m rounding up to length_m
            i = self._n - 1
        return i, pos - i

    def offset_at(self, dist_m: float) -> float:
        """to_middle (m, + left) of the line at a distance from the start line."""
        i, f = self._locate(dist_m)
        a = self._off
        return a[i] + f * (a[i + 1] - a[i])

    def curvature_at(self, dist_m: float) -> float:
        """Smoothed signed curvature (1/m, + left) of the line at a distance from the start line."""
        i, f = self._locate(dist_m)
        a = self._k
        return a[i] + f * (a[i + 1] - a[i])

    def point_at(self, dist_m: float) -> tuple[float, float]:
        """(x_m, y_m) of the line at a distance (along the middle line) from the start line."""
        i, f = self._locate(dist_m)
        xs, ys = self._x, self._y
        return xs[i] + f * (xs[i + 1] - xs[i]), ys[i] + f * (ys[i + 1] - ys[i])

    def heading_at(self, dist_m: float) -> float:
        """Direction of the line (rad, in [-pi, pi]) at a distance from the start line."""
        i, f = self._locate(dist_m)
        a = self._h
        return math.remainder(a[i] + f * (a[i + 1] - a[i]), TWO_PI)

    def length_factor_at(self, dist_m: float) -> float:
        """Racing-line metres per middle-line metre (< 1 on the inside of turns)."""
        i, f = self._locate(dist_m)
        a = self._f
        return a[i] + f * (a[i + 1] - a[i])
