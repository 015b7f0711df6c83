"""The minimum-curvature line over a given width, by a library solver (scipy's bounded least squares).

The line is p_i = c_i + a_i N_i: the middle point c_i, its unit left normal N_i and the offset a_i
(m, + left), for n samples of a closed lap. The second difference p_{i-1} - 2 p_i + p_{i+1} is
ds^2 times the line's curvature vector where the samples are evenly spaced, and it is linear in a:
minimising the sum of its squares with each a_i between -right_i and left_i is a bounded linear
least-squares problem, a sparse convex quadratic programme with box bounds, solved by OSQP (Stellato
et al., "OSQP: an operator splitting solver for quadratic programs", Math. Prog. Comp. 12, 2020).
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
                          left_m: np.ndarray, right_m: np.ndarray) -> np.ndarray:
    """Offsets a (m, + left, -right_m <= a <= left_m) of the closed line of least summed squared
    second differences through the middle points (x_m, y_m) along the unit left normals."""
    import osqp
    import scipy.sparse as sp

    x, y = np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float)
    nx, ny = np.asarray(normal_x, dtype=float), np.asarray(normal_y, dtype=float)
    lo, hi = -np.asarray(right_m, dtype=float), np.asarray(left_m, dtype=float)
    n = _check({"x_m": x, "y_m": y, "normal_x": nx, "normal_y": ny, "left_m": hi, "right_m": lo})
    if np.any(hi < 0) or np.any(lo > 0):
        raise ValueError("left_m and right_m must be >= 0 (the middle must be inside the width)")
    idx = np.arange(n)
    prv, nxt = np.roll(idx, 1), np.roll(idx, -1)
    rows = np.tile(idx, 3)
    cols = np.concatenate((prv, idx, nxt))

    def block(normal: np.ndarray) -> sp.csr_matrix:
        vals = np.concatenate((normal[prv], -2.0 * normal, normal[nxt]))
        return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))

    a = sp.vstack((block(nx), block(ny))).tocsr()
    b = -np.concatenate((x[prv] - 2 * x + x[nxt], y[prv] - 2 * y + y[nxt]))
    h = (a.T @ a).tocsc()  # 0.5 |A a - b|^2 = 0.5 a'H a - (A'b)'a + const
    solver = osqp.OSQP()
    solver.setup(sp.triu(h, format="csc"), -(a.T @ b), sp.identity(n, format="csc"), lo, hi, verbose=False,
                 eps_abs=1e-7, eps_rel=1e-7, max_iter=50_000, polishing=True)
    result = solver.solve()
    if result.x is None or not np.all(np.isfinite(result.x)):
        raise ValueError(f"the line's QP did not solve ({result.info.status})")
    return np.clip(result.x, lo, hi)


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
