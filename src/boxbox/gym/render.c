/* boxbox gym: the pixel observation's hot loops, for gym/render.py (numpy needs ~150 us a 96x96 view,
 * this ~15 us).
 *
 * Copyright (C) 2026 the boxbox authors.  GPL-2.0-or-later.
 *
 * Images are rows of RGB bytes.  bb_view fills a vh x vw view from the raster (rh x rw): the view
 * pixel (r, c) centre lies `ahead` = (car_row - r - 0.5) * scale raster pixels ahead of the car and
 * `left` = (car_col - c - 0.5) * scale to its left; the car is at raster (col0, row0) heading
 * (cs, sn) (cos and sin of TORCS's yaw; the raster's rows grow downwards, -y).  A view pixel off the
 * raster takes `fill`.  bb_box colours the pixels whose centres are inside an oriented rectangle.
 */
#include <math.h>
#include <string.h>

void bb_view(const unsigned char *raster, long rh, long rw, double col0, double row0, double cs, double sn,
             double scale, double car_row, double car_col, long vh, long vw, unsigned char *out,
             const unsigned char *fill) {
    for (long r = 0; r < vh; r++) {
        double a = (car_row - (double)r - 0.5) * scale;
        double col_a = col0 + a * cs, row_a = row0 - a * sn;
        unsigned char *o = out + 3 * r * vw;
        for (long c = 0; c < vw; c++, o += 3) {
            double l = (car_col - (double)c - 0.5) * scale;
            double col = col_a - l * sn, row = row_a - l * cs;  /* truncation is floor where both are >= 0 */
            const unsigned char *p = fill;
            if (col >= 0.0 && row >= 0.0 && col < (double)rw && row < (double)rh) p = raster + 3 * ((long)row * rw + (long)col);
            o[0] = p[0]; o[1] = p[1]; o[2] = p[2];
        }
    }
}

void bb_box(unsigned char *image, long h, long w, double col, double row, double axis_col, double axis_row,
            double half_len, double half_wid, const unsigned char *colour) {
    double reach = half_len + half_wid;
    long c0 = (long)(col - reach), c1 = (long)(col + reach) + 2;
    long r0 = (long)(row - reach), r1 = (long)(row + reach) + 2;
    if (c0 < 0) c0 = 0;
    if (r0 < 0) r0 = 0;
    if (c1 > w) c1 = w;
    if (r1 > h) r1 = h;
    for (long r = r0; r < r1; r++) {
        double dr = (double)r + 0.5 - row;
        for (long c = c0; c < c1; c++) {
            double dc = (double)c + 0.5 - col;
            double along = dc * axis_col + dr * axis_row, across = dr * axis_col - dc * axis_row;
            if (fabs(along) <= half_len && fabs(across) <= half_wid) memcpy(image + 3 * (r * w + c), colour, 3);
        }
    }
}

/* bb_strip: the dashboard strip (gym/dashboard.py lays it out): `template` (its background and
 * ticks, `size` bytes) copied over `strip`, then three bars on rows r0..r1 (end excluded), each the
 * columns [c0, c1) of its pair in `cols` (6 numbers) in its colour of `colours` (3 RGB). */
void bb_strip(unsigned char *strip, const unsigned char *template, long size, long w, long r0, long r1,
              const long *cols, const unsigned char *colours) {
    memcpy(strip, template, (size_t)size);
    for (long bar = 0; bar < 3; bar++) {
        long c0 = cols[2 * bar], c1 = cols[2 * bar + 1];
        const unsigned char *colour = colours + 3 * bar;
        for (long r = r0; r < r1; r++)
            for (long c = c0; c < c1; c++) memcpy(strip + 3 * (r * w + c), colour, 3);
    }
}
