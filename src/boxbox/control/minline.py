"""The minimum-curvature line over a given width, by a library QP solver (PIQP).

The line is p_i = c_i + a_i N_i: the middle point c_i, its unit left normal N_i and the offset a_i
(m, + left), for n samples of a closed lap. Its curvature at sample i is about u_i . (p_{i-1} - 2 p_i
+ p_{i+1}) / h_i^2, with u_i the line's unit normal and h_i half the chord from p_{i-1} to p_{i+1}.
With u and h taken from the previous line this is linear in a, so the sum of squared curvatures
with each a_i between -right_i and left_i is a sparse convex quadratic programme with box bounds,
solved by PIQP (Schwan et al., "PIQP: A Proximal Interior-Point Quadratic Programming Solver",
IEEE CDC 2023; `solve_box_qp`), a few times over (each time from the line before: sequential QP).
The QP is ill-conditioned (fourth differences): first-order solvers such as OSQP took minutes on
e-track-2's 2,690 samples where PIQP takes a fraction of a second. Without
the 1/h^2 the plain second difference would favour the inside of every turn (it is curvature times
spacing squared, and the spacing shrinks there).
This is the usual minimum-curvature racing line (Braghin et al., "Race driver model", Computers &
Structures 86, 2008; Heilmeier et al., "Minimum curvature trajectory planning and control for an
autonomous race car", Vehicle System Dynamics 58, 2020), a close and fast stand-in for the
minimum-time line; `boxbox limit` checks the lap time of the lines it gets.
"""

from __future__ import annotations

import numpy as np


def _check(arrays: dict[str, np.ndarray]) -> int:
    lengths = {a.shape for a in arrays.values()}
    if len(lengths) != 1 or len(next(iter(lengths))) != 1:
        raise ValueError(f"{', '.join(arrays)} must be 1-D arrays of one length")
    n = next(iter(lengths))[0]
    if n < 5:
        raise ValueError("a closed line needs at least 5 samples")
    for name, a in arrays.items():
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite")
    return n


def min_curvature_offsets(x_m: np.ndarray, y_m: np.ndarray, normal_x: np.ndarray, normal_y: np.ndarray,
                          left_m: np.ndarray, right_m: np.ndarray, iterations: int = 3) -> np.ndarray:
    """Offsets a (m, + left, -right_m <= a <= left_m) of the closed line of least summed squared
    curvature through the middle points (x_m, y_m) along the unit left normals."""
    x, y = np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float)
    nx, ny = np.asarray(normal_x, dtype=float), np.asarray(normal_y, dtype=float)
    lo, hi = -np.asarray(right_m, dtype=float), np.asarray(left_m, dtype=float)
    n = _check({"x_m": x, "y_m": y, "normal_x": nx, "normal_y": ny, "left_m": hi, "right_m": lo})
    if np.any(hi < 0) or np.any(lo > 0):
        raise ValueError("left_m and right_m must be >= 0 (the middle must be inside the width)")
    off = np.zeros(n)
    for _ in range(iterations):
        a, c = curvature_rows(x, y, nx, ny, off)
        off = solve_box_qp((a.T @ a).tocsr(), a.T @ c, lo, hi)
    return off


def solve_box_qp(h, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, rows=None, rows_lo: np.ndarray | None = None,
                 rows_hi: np.ndarray | None = None) -> np.ndarray:
    """min 1/2 x'Hx + g'x subject to lo <= x <= hi and, with `rows` (a sparse matrix G),
    rows_lo <= G x <= rows_hi; H sparse symmetric positive semi-definite (a scipy.sparse matrix).
    H is scaled to a unit diagonal first; the optimum does not change.  RuntimeError when PIQP does
    not solve it (an infeasible G included)."""
    import piqp
    import scipy.sparse as sp

    scale = 1.0 / (float(np.abs(h.diagonal()).max()) or 1.0)
    solver = piqp.SparseSolver()
    solver.settings.eps_abs = 1e-10
    solver.settings.eps_rel = 1e-12
    solver.settings.eps_duality_gap_abs = 1e-12
    solver.settings.eps_duality_gap_rel = 1e-12
    solver.settings.max_iter = 500
    solver.setup(sp.triu(h * scale).tocsc(), g * scale, G=None if rows is None else sp.csc_matrix(rows),
                 h_l=rows_lo, h_u=rows_hi, x_l=lo, x_u=hi)
    status = solver.solve()
    if status != piqp.PIQP_SOLVED:
        raise RuntimeError(f"the QP solver stopped with {status}")
    return np.clip(solver.result.x, lo, hi)


def curvature_rows(x: np.ndarray, y: np.ndarray, nx: np.ndarray, ny: np.ndarray, off: np.ndarray):
    """The line's curvature at every sample as A a + c, linear in the offsets a: the second difference
    projected on the current line's unit normal u_i, over its current spacing squared."""
    import scipy.sparse as sp

    n = len(x)
    idx = np.arange(n)
    prv, nxt = np.roll(idx, 1), np.roll(idx, -1)
    px, py = x + off * nx, y + off * ny
    tx, ty = px[nxt] - px[prv], py[nxt] - py[prv]
    half_chord = np.maximum(0.5 * np.hypot(tx, ty), 1e-9)
    ux, uy = -ty / (2 * half_chord), tx / (2 * half_chord)
    w = 1.0 / (half_chord * half_chord)
    c = w * (ux * (x[prv] - 2 * x + x[nxt]) + uy * (y[prv] - 2 * y + y[nxt]))
    # row i: w_i u_i . (a_{i-1} N_{i-1} - 2 a_i N_i + a_{i+1} N_{i+1}) + c_i
    vals = np.concatenate((w * (ux * nx[prv] + uy * ny[prv]), -2.0 * w * (ux * nx + uy * ny),
                           w * (ux * nx[nxt] + uy * ny[nxt])))
    a = sp.csr_matrix((vals, (np.tile(idx, 3), np.concatenate((prv, idx, nxt)))), shape=(n, n))
    return a, c


def closed_curvature(x_m: np.ndarray, y_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed curvature (1/m, + left) at each point of a closed polyline, from the circle through it
    and its two neighbours, and the distance (m) from each point to the next."""
    x, y = np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float)
    _check({"x_m": x, "y_m": y})
    ax, ay, bx, by = np.roll(x, 1), np.roll(y, 1), np.roll(x, -1), np.roll(y, -1)
    cross = (x - ax) * (by - ay) - (y - ay) * (bx - ax)
    d_in, d_out, d_across = np.hypot(x - ax, y - ay), np.hypot(bx - x, by - y), np.hypot(bx - ax, by - ay)
    if np.any(d_out <= 0):
        raise ValueError("two consecutive points coincide")
    return 2.0 * cross / np.maximum(d_in * d_out * d_across, 1e-12), d_out
