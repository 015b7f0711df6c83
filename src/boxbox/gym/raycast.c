/* boxbox gym: range finders to the track edges, the per-step hot loop of gym/sensors.py.
 *
 * Copyright (C) 2026 the boxbox authors.  GPL-2.0-or-later.
 *
 * lines: n rows of (ax, ay, ex, ey), each edge chord from A to A + E.  For every ray from P = (x, y)
 * at angle yaw + rays[r] (radians, counter-clockwise; k <= BB_MAX_RAYS), out[r] is the smallest t
 * in [0, range_m) with P + t D on a chord, or range_m when there is none.  With W = A - P and 2-D
 * cross products: t = (W x E) / (D x E) and the chord's parameter u = (W x D) / (D x E) in [0, 1];
 * the tests are done multiplied out (no division unless a nearer hit is found).  With `ahead`
 * set (every ray within 90 degrees of the heading), a chord wholly behind the car, or wholly more
 * than range_m ahead of it, is skipped: no ray can meet it within range.
 */
#include <math.h>

#define BB_MAX_RAYS 64

long bb_cast(const double *lines, long n, double x, double y, double yaw, const double *rays, long k,
             double range_m, long ahead, double *out) {
    double dx[BB_MAX_RAYS], dy[BB_MAX_RAYS];
    double hx = cos(yaw), hy = sin(yaw);
    if (k > BB_MAX_RAYS) return -1;
    for (long r = 0; r < k; r++) {
        dx[r] = cos(yaw + rays[r]);
        dy[r] = sin(yaw + rays[r]);
        out[r] = range_m;
    }
    for (long j = 0; j < n; j++) {
        const double *l = lines + 4 * j;
        double wx = l[0] - x, wy = l[1] - y, ex = l[2], ey = l[3];
        if (ahead) {
            double along = wx * hx + wy * hy, along_end = along + ex * hx + ey * hy;
            if ((along < 0.0 && along_end < 0.0) || (along > range_m && along_end > range_m)) continue;
        }
        double wxe = wx * ey - wy * ex;  /* W x E: the same for every ray */
        for (long r = 0; r < k; r++) {
            double den = dx[r] * ey - dy[r] * ex;
            double wxd = wx * dy[r] - wy * dx[r];
            if (den < 0.0) { den = -den; wxd = -wxd; if (-wxe < 0.0 || -wxe >= out[r] * den) continue; }
            else if (den > 0.0) { if (wxe < 0.0 || wxe >= out[r] * den) continue; }
            else continue;
            if (wxd < 0.0 || wxd > den) continue;
            out[r] = fabs(wxe) / den;
        }
    }
    return k;
}
