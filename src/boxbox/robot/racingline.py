"""A per-track racing line: the track middle line sampled every few metres, then the lateral offset
that minimises the curvature of the driven path while staying inside the track.

Computed once per track (`RacingLine(track)`: 0.1-0.4 s for the recorded tracks, up to 7 km).
While driving, `point_at` gives a look-ahead steering target and `curvature_at` feeds the speed
profile; those lookups are plain Python (lists and one linear interpolation), no numpy per call.

Method.  The line is R_i = P_i + n_i N_i (middle point, left unit normal, offset n_i in metres,
+ left).  Its curvature at sample i is the second difference of R projected on the line's own
normal, divided by the line's own spacing squared.  Linearised around the current line
(Gauss-Newton) this is k = A n + c with A cyclic tridiagonal, so "sum of squared curvatures,
subject to the track bounds" becomes a convex quadratic programme whose matrix is cyclic
pentadiagonal; it is solved by an interior point method with banded Cholesky steps, and the
linearisation is refreshed until the line stops moving (5-15 passes).  A soft cap keeps each
corner's peak curvature below the middle line's (see `_min_curvature_offsets`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve_banded, cholesky_banded
from scipy.ndimage import maximum_filter1d, uniform_filter1d

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
    curvature_1pm: np.ndarray  # exact curvature of the middle line from the segments, + left

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
    # a little room is always left so the bounds never pinch to a point (the optimiser needs it)
    half = np.maximum(0.5 * width.astype(float) - margin_m, 0.05)
    with np.errstate(divide="ignore"):
        k = np.where(turn, sign / np.where(radius > 0, radius, math.inf), 0.0)
    return MiddleLine(length_m=length_m, step_m=length_m / n, dist_m=dist_m, x_m=x, y_m=y,
                      heading_rad=heading, half_left_m=half, half_right_m=half.copy(),
                      friction=seg["friction"].astype(float)[ids], seg_id=ids, curvature_1pm=k)


class _CyclicRows:
    """An n x n matrix with one row per sample and entries only at columns i-1, i, i+1 (cyclic):
    the linearised curvature, k = A n + c."""

    def __init__(self, prev: np.ndarray, mid: np.ndarray, nxt: np.ndarray) -> None:
        self.p, self.m, self.q = prev, mid, nxt

    def dot(self, x: np.ndarray) -> np.ndarray:
        return self.p * np.roll(x, 1) + self.m * x + self.q * np.roll(x, -1)

    def tdot(self, v: np.ndarray) -> np.ndarray:
        """A' v"""
        return np.roll(self.p * v, -1) + self.m * v + np.roll(self.q * v, 1)

    def gram(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A' diag(w) A as its three upper cyclic diagonals d0[j] = M[j, j], d1[j] = M[j, j+1],
        d2[j] = M[j, j+2] (indices mod n)."""
        p, m, q = self.p, self.m, self.q
        d0 = np.roll(w * p * p, -1) + w * m * m + np.roll(w * q * q, 1)
        d1 = w * m * q + np.roll(w * p * m, -1)
        d2 = np.roll(w * p * q, -1)
        return d0, d1, d2


class _CyclicSolver:
    """Solves symmetric positive definite systems with the cyclic pentadiagonal pattern
    (three upper cyclic diagonals).  Ordering the unknowns 0, n-1, 1, n-2, 2, ... turns the
    cyclic pattern into a plain band of half-width 4, so each solve is a banded Cholesky (LAPACK,
    ~0.5 ms for 3500 samples) instead of a general sparse factorisation."""

    BAND = 4

    def __init__(self, n: int) -> None:
        if n < 5:
            raise ValueError("need at least 5 samples")
        i = np.arange(n)
        self.pos = np.where(i < (n + 1) // 2, 2 * i, 2 * (n - 1 - i) + 1)  # sample -> band index
        self.order = np.argsort(self.pos)  # band index -> sample
        self.n = n
        # where each entry of the three cyclic diagonals lands in LAPACK's upper band storage
        self.cells: list[tuple[np.ndarray, np.ndarray]] = []
        for d in (0, 1, 2):
            r, c = self.pos[i], self.pos[(i + d) % n]
            self.cells.append((self.BAND + np.minimum(r, c) - np.maximum(r, c), np.maximum(r, c)))

    def factor(self, diags: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
        ab = np.zeros((self.BAND + 1, self.n))
        for (row, col), d in zip(self.cells, diags):
            ab[row, col] = d
        return cholesky_banded(ab, check_finite=False)

    def solve(self, chol: np.ndarray, b: np.ndarray) -> np.ndarray:
        xp = cho_solve_banded((chol, False), b[self.order], check_finite=False)
        return xp[self.pos]


def _step_to_boundary(v: np.ndarray, dv: np.ndarray) -> float:
    """Largest alpha with v + alpha dv >= 0 (v > 0)."""
    neg = dv < 0
    return float(np.min(-v[neg] / dv[neg])) if neg.any() else math.inf


def _solve_line_qp(solver: _CyclicSolver, a: _CyclicRows, c: np.ndarray, capped: np.ndarray,
                   cap: np.ndarray, cap_weight: float, lo: np.ndarray, hi: np.ndarray,
                   x0: np.ndarray, max_iter: int = 80, tol: float = 1e-9) -> np.ndarray:
    """Offsets x minimising  1/2 |A x + c|^2 + 1/2 eps |x|^2 + cap_weight/2 * sum e_i^2
    subject to lo <= x <= hi and |(A x + c)_i| <= cap_i + e_i on the capped rows.

    The e_i make the caps soft, so a cap the track cannot give costs a little excess instead of
    making the problem infeasible.  Primal-dual interior point with Mehrotra's predictor-corrector:
    ~20-30 Newton steps whatever the contact pattern.  (Active-set pivoting was tried first and
    cycles here: with a fourth-difference operator the line touches a bound at isolated samples
    and the pivoting flips alternate samples forever.)  With the slack e eliminated, every Newton
    step is one cyclic pentadiagonal solve."""
    n = len(c)
    ones = np.ones(n)
    base = a.gram(ones)
    scale = float(base[0].mean())
    eps = 1e-9 * scale + 1e-12  # makes the problem strictly convex (a straight has a free shift)
    mu_e = cap_weight * capped  # weight of e; rows that are not capped carry no e at all
    cap_c = np.where(capped, cap, 0.0)

    x = np.clip(x0, lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo))
    k = a.dot(x) + c
    e = np.where(capped, np.maximum(np.abs(k) - cap_c, 0.0) + 0.1 * cap_c + 1e-6, 0.0)
    s1, s2 = x - lo, hi - x
    s3 = np.where(capped, cap_c - k + e, 1.0)
    s4 = np.where(capped, cap_c + k + e, 1.0)
    z1 = np.full(n, 1e-2 * scale)
    z2 = z1.copy()
    z3 = np.where(capped, 1e-2 * scale * 1e-2, 0.0)
    z4 = z3.copy()
    m_all = 2 * n + 2 * int(np.count_nonzero(capped))
    g_tol = tol * scale * max(1.0, float(np.abs(hi - lo).max()))

    for _ in range(max_iter):
        k = a.dot(x) + c
        r_x = a.tdot(k) + eps * x - z1 + z2 + a.tdot(z3 - z4)
        r_e = np.where(capped, mu_e * e - z3 - z4, 0.0)
        gap = float(s1 @ z1 + s2 @ z2 + capped @ (s3 * z3 + s4 * z4)) / m_all
        if gap < tol * scale and float(np.abs(r_x).max()) < g_tol and float(np.abs(r_e).max()) < g_tol:
            break
        d1, d2 = z1 / s1, z2 / s2
        d3, d4 = np.where(capped, z3 / s3, 0.0), np.where(capped, z4 / s4, 0.0)
        m_e = np.where(capped, mu_e + d3 + d4, 1.0)
        w = 1.0 + d3 + d4 - (d4 - d3) ** 2 / m_e
        d0, dd1, dd2 = a.gram(w)
        chol = solver.factor((d0 + eps + d1 + d2, dd1, dd2))

        def newton(rc1: np.ndarray, rc2: np.ndarray, rc3: np.ndarray, rc4: np.ndarray
                   ) -> tuple[np.ndarray, ...]:
            """Newton step for complementarity targets s_j dz_j + z_j ds_j = rc_j."""
            t3 = np.where(capped, rc3 / s3, 0.0)
            t4 = np.where(capped, rc4 / s4, 0.0)
            q = np.where(capped, -r_e + t3 + t4, 0.0)
            rhs = -r_x + rc1 / s1 - rc2 / s2 - a.tdot(t3 - t4) - a.tdot((d4 - d3) * q / m_e)
            dx = solver.solve(chol, rhs)
            adx = a.dot(dx)
            de = np.where(capped, (q + (d3 - d4) * adx) / m_e, 0.0)
            ds3, ds4 = -adx + de, adx + de
            dz3 = np.where(capped, (rc3 - z3 * ds3) / s3, 0.0)
            dz4 = np.where(capped, (rc4 - z4 * ds4) / s4, 0.0)
            return dx, de, (rc1 - z1 * dx) / s1, (rc2 + z2 * dx) / s2, dz3, dz4, ds3, ds4

        def longest(step: tuple[np.ndarray, ...]) -> float:
            dx, _, dz1, dz2, dz3, dz4, ds3, ds4 = step
            pairs = ((s1, dx), (s2, -dx), (z1, dz1), (z2, dz2), (s3[capped], ds3[capped]),
                     (s4[capped], ds4[capped]), (z3[capped], dz3[capped]), (z4[capped], dz4[capped]))
            return min(_step_to_boundary(v, dv) for v, dv in pairs)

        # predictor: plain Newton on the complementarity conditions; its progress sets the
        # centring; corrector: aim at sigma * gap, compensating the predictor's second-order term
        aff = newton(-s1 * z1, -s2 * z2, -s3 * z3, -s4 * z4)
        alpha = min(1.0, longest(aff))
        dx, _, dz1, dz2, dz3, dz4, ds3, ds4 = aff
        gap_aff = float((s1 + alpha * dx) @ (z1 + alpha * dz1) + (s2 - alpha * dx) @ (z2 + alpha * dz2)
                        + capped @ ((s3 + alpha * ds3) * (z3 + alpha * dz3)
                                    + (s4 + alpha * ds4) * (z4 + alpha * dz4))) / m_all
        sg = (gap_aff / gap) ** 3 * gap
        step = newton(-s1 * z1 + sg - dx * dz1, -s2 * z2 + sg + dx * dz2,
                      -s3 * z3 + sg - ds3 * dz3, -s4 * z4 + sg - ds4 * dz4)
        alpha = min(1.0, 0.99 * longest(step))
        dx, de, dz1, dz2, dz3, dz4, ds3, ds4 = step
        x = x + alpha * dx
        e = e + alpha * de
        s1, s2 = np.maximum(x - lo, 1e-14), np.maximum(hi - x, 1e-14)
        s3 = np.where(capped, np.maximum(s3 + alpha * ds3, 1e-14), 1.0)
        s4 = np.where(capped, np.maximum(s4 + alpha * ds4, 1e-14), 1.0)
        z1, z2 = z1 + alpha * dz1, z2 + alpha * dz2
        z3, z4 = z3 + alpha * dz3, z4 + alpha * dz4
    return np.clip(x, lo, hi)


def _closed_curvature(x_m: np.ndarray, y_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed curvature (+ left), heading (unwrapped) and chord length to the next point for a
    closed polyline of n distinct points.

    Curvature: the circle through each point and its two neighbours (exact on sampled arcs).  An
    interpolating cubic spline rings where the track's curvature jumps (straight to turn), giving
    +-20 % spikes at every turn entry; the three-point circle does not."""
    ax, ay = np.roll(x_m, 1), np.roll(y_m, 1)
    bx, by = np.roll(x_m, -1), np.roll(y_m, -1)
    cross = (x_m - ax) * (by - ay) - (y_m - ay) * (bx - ax)
    d_in = np.hypot(x_m - ax, y_m - ay)
    d_out = np.hypot(bx - x_m, by - y_m)
    d_across = np.hypot(bx - ax, by - ay)
    k = 2.0 * cross / np.maximum(d_in * d_out * d_across, 1e-12)
    heading = np.unwrap(np.arctan2(by - ay, bx - ax))
    return k, heading, d_out


def _min_curvature_offsets(mid: MiddleLine, peak_cap: float, cap_window_m: float,
                           max_passes: int = 20, cap_weight: float = 1e3) -> np.ndarray:
    """Lateral offsets (n samples) of the minimum-curvature line inside the bounds of `mid`.

    Objective: sum of squared curvatures, plus a stiff penalty wherever |k| exceeds
    peak_cap * (the middle line's largest |k| within +-cap_window_m).  A pure sum-of-squares line
    spreads curvature into long spirals and, in long or S-shaped turns, ends up with a sharper apex
    than the middle line (+10 to +18 % on e-track-2, g-track-1, michigan); the cap keeps every
    corner more open than the track's own radius, which is what sets the corner speed.  The middle
    line satisfies the cap when peak_cap >= 1, so values a little below 1 are (nearly) always
    feasible.  peak_cap = inf gives the plain minimum-curvature line.
    """
    n = mid.n
    px, py = mid.x_m[:n], mid.y_m[:n]
    nx, ny = -np.sin(mid.heading_rad[:n]), np.cos(mid.heading_rad[:n])
    lo, hi = -mid.half_right_m[:n], mid.half_left_m[:n]
    solver = _CyclicSolver(n)
    nx_p, ny_p, nx_n, ny_n = np.roll(nx, 1), np.roll(ny, 1), np.roll(nx, -1), np.roll(ny, -1)

    k_mid = np.abs(mid.curvature_1pm[:n])
    size = min(n, 2 * int(round(cap_window_m / mid.step_m)) + 1)
    envelope = maximum_filter1d(k_mid, size, mode="wrap")
    # only near turns: long straights stay free so the line can cross the track between corners
    capped = (envelope > 0.0) & math.isfinite(peak_cap)
    cap = np.where(capped, min(peak_cap, 1e9) * envelope, 0.0)

    off = np.zeros(n)
    for _ in range(max(1, max_passes)):
        # Gauss-Newton: linearise k_i = u_i . (R_{i+1} - 2 R_i + R_{i-1}) / ds_i^2 around the
        # current line R_j = P_j + n_j N_j (u_i: its unit normal, ds_i: half the chord from
        # i-1 to i+1).  The spacing term matters: with ds frozen, moving out of a circle looks
        # like more curvature (the points spread) and the line would hug the inside
        x, y = px + off * nx, py + off * ny
        xp, yp, xn, yn = np.roll(x, 1), np.roll(y, 1), np.roll(x, -1), np.roll(y, -1)
        ds = np.maximum(0.5 * np.hypot(xn - xp, yn - yp), 1e-6)
        tx, ty = (xn - xp) / (2 * ds), (yn - yp) / (2 * ds)
        ux, uy = -ty, tx
        w = 1.0 / (ds * ds)
        k0 = w * (ux * (xn - 2 * x + xp) + uy * (yn - 2 * y + yp))
        # d ds_i / d n_(i+-1) = +- t_i . N_(i+-1) / 2  and  dk = w du - 2 k / ds * d ds
        a = _CyclicRows(w * (ux * nx_p + uy * ny_p) + k0 / ds * (tx * nx_p + ty * ny_p),
                        -2.0 * w * (ux * nx + uy * ny),
                        w * (ux * nx_n + uy * ny_n) - k0 / ds * (tx * nx_n + ty * ny_n))
        c = k0 - a.dot(off)  # k ~ A n + c near the current line
        new = _solve_line_qp(solver, a, c, capped, cap, cap_weight, lo, hi, off)
        change = float(np.max(np.abs(new - off)))
        # done when the line stops moving, or when it only drifts along a flat valley (a long
        # straight where a slow sideways shift changes no curvature worth mentioning)
        k_change = float(np.max(np.abs(a.dot(new - off))))
        off = new
        if change < 0.01 or k_change < 1e-3 * float(np.max(np.abs(k0))):
            break
    return off


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
    runs = [(int(b0) + 1, int(b1) + 1) for b0, b1 in zip(edges[::2], edges[1::2])]
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


def _is_sound(k_line: np.ndarray, mid: MiddleLine, window_m: float) -> bool:
    """False when the line curves clearly more than the track anywhere near: the sign of a cap
    the track cannot give (the optimiser then pushes the turning just outside the capped
    stretch, into a kink far sharper than the corner)."""
    n = mid.n
    size = min(n, 2 * int(round(2.0 * window_m / mid.step_m)) + 1)
    near = maximum_filter1d(np.abs(mid.curvature_1pm[:n]), size, mode="wrap")
    # far from any turn, allow what crossing the track on a straight takes (radius >= 500 m)
    return bool(np.all(np.abs(k_line) <= np.maximum(1.02 * near, 2e-3)))


class RacingLine:
    """Minimum-curvature line of one track.

    Arrays (n + 1 samples every `step_m` along the middle line, the last one closing the loop):
    dist_m, offset_m (to_middle of the line, + left), x_m, y_m, heading_rad, curvature_1pm (signed,
    + left, lightly smoothed), curvature_raw_1pm, length_factor (racing-line metres per middle-line
    metre), and `middle` (the sampled middle line with its bounds).

    blend: 0 = the middle line, 1 = the optimised line, in between a linear mix of the offsets.
    margin_m: kept from each track edge (car half width ~0.95 m + safety).
    peak_cap: no corner of the line curves more than this times the middle line's sharpest
    curvature within +-cap_window_m (see `_min_curvature_offsets`; inf: the plain minimum-curvature
    line).  Should the track be too tight for it, the cap is raised towards 1, at worst dropped
    (`peak_cap_used` tells the value kept).
    """

    def __init__(self, track: Track, step_m: float = 2.0, margin_m: float = 1.2, blend: float = 1.0,
                 peak_cap: float = 0.95, cap_window_m: float = 60.0, smooth_m: float = 6.0,
                 max_passes: int = 20) -> None:
        mid = middle_line(track, step_m, margin_m)
        self.middle = mid
        self.blend = float(blend)
        self.margin_m = float(margin_m)
        self.step_m = mid.step_m
        self.length_m = mid.length_m
        n = mid.n
        px, py = mid.x_m[:n], mid.y_m[:n]
        nx, ny = -np.sin(mid.heading_rad[:n]), np.cos(mid.heading_rad[:n])
        lo, hi = -mid.half_right_m[:n], mid.half_left_m[:n]

        # an infeasible cap (a corner that cannot be opened that much) makes the optimiser push
        # turning outside the capped stretch: check, and retry with looser caps, the last one
        # being none at all (the plain minimum-curvature line)
        caps = [peak_cap] if peak_cap >= 1.0 else [peak_cap, 0.5 * (peak_cap + 1.0), 1.0]
        for cap in caps + [math.inf]:
            off = _min_curvature_offsets(mid, cap, cap_window_m, max_passes)
            if _is_sound(_closed_curvature(px + off * nx, py + off * ny)[0], mid, cap_window_m):
                break
        self.peak_cap_used = cap
        self.optimal_offset_m = off

        off = np.clip(self.blend * self.optimal_offset_m, lo, hi)
        x, y = px + off * nx, py + off * ny
        k_raw, heading, chord = _closed_curvature(x, y)
        # a short moving average: takes the corners off the curvature steps where straights meet
        # turns (the speed profile then ramps instead of jumping) without overshoot (savgol rings
        # at such steps by ~7 %) and without lowering any turn's plateau longer than the window
        win = max(1, int(round(smooth_m / self.step_m)) | 1)
        k = uniform_filter1d(k_raw, win, mode="wrap") if 1 < win < n else k_raw
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
