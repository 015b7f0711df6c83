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

static void fill(unsigned char *strip, long w, long r0, long r1, long c0, long c1, const unsigned char *colour) {
    for (long r = r0; r < r1; r++)
        for (long c = c0; c < c1; c++) memcpy(strip + 3 * (r * w + c), colour, 3);
}

/* bb_strip: the dashboard strip over the last rows of an image h x w (gym/dashboard.py, whose
 * Dashboard.bars is the same in Python): `template` (its background and ticks) copied, then on its
 * rows r0..r1 a bar from column 1 for the speed (full at `span`), one from the `middle` tick for
 * the steering (+: to the left) and the engaged gear's tick lit.  `layout`: rows, r0, r1, the
 * speed and steering fields' width, middle, the gears (R, N, 1 .. top).  `colours`: 3 RGB. */
void bb_strip(unsigned char *image, long h, long w, const unsigned char *template, const long *layout,
              double speed_mps, double span, double steer, double gear, const unsigned char *colours) {
    long rows = layout[0], r0 = layout[1], r1 = layout[2], field = layout[3], middle = layout[4], gears = layout[5];
    unsigned char *strip = image + 3 * (h - rows) * w;
    memcpy(strip, template, (size_t)(3 * rows * w));
    double share = fabs(speed_mps) / span, turn = fabs(steer);
    if (!(share <= 1.0)) share = share > 1.0 ? 1.0 : 0.0;  /* NaN: nothing */
    if (!(turn <= 1.0)) turn = turn > 1.0 ? 1.0 : 0.0;
    fill(strip, w, r0, r1, 1, 1 + (long)floor(share * (double)(field - 2) + 0.5), colours);
    long reach = (long)floor(turn * (double)(field / 2 - 1) + 0.5);
    if (steer > 0.0) fill(strip, w, r0, r1, middle - reach, middle, colours + 3);
    else fill(strip, w, r0, r1, middle + 1, middle + 1 + reach, colours + 3);
    long slot = gear == gear ? (long)floor(fmin(fmax(gear, -1.0), (double)gears) + 0.5) + 1 : 1;
    if (slot > gears - 1) slot = gears - 1;
    long start = 2 * field, gear_span = w - 2 * field;
    long c0 = start + slot * gear_span / gears, c1 = start + (slot + 1) * gear_span / gears - 1;
    if (c1 < c0 + 1) c1 = c0 + 1;
    if (c1 > w) c1 = w;
    fill(strip, w, r0, r1, c0, c1, colours + 6);
}
