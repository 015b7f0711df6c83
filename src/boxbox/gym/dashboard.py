"""The dashboard strip (`dashboard=True`): the car's speed, steering and gear as bars, drawn over the
bottom rows of its view (as Gymnasium's CarRacing draws its indicators) and below render()'s frame.

Across the strip: the speed field (3/8 of the width: a bar from its left, full at SPEED_SPAN_MPS),
the steering field (3/8: a bar from the tick in its middle, to the left for + steer (left), to the
field's edge at full lock), the gear field (the rest: a dim tick per gear, R N 1 .. the car's top
gear, the one engaged lit).  The bars span the strip's rows but its first and last.  The layout and
the background are made here once per strip; render.c's bb_strip copies the background and fills the
bars (Dashboard.bars is the same in numpy, without a C compiler).
"""

from __future__ import annotations

import ctypes
import math

import numpy as np

from boxbox.gym.spaces import SPEED_SPAN_MPS

BACKGROUND = (0, 0, 0)
TICK = (80, 80, 80)  # the steering field's middle and each gear's place
SPEED_BAR = (255, 255, 255)
STEER_BAR = (0, 255, 0)
GEAR_LIT = (255, 255, 0)
VIEW_SHARE = 8  # the strip is an eighth of the view's height (12 rows of 96, as CarRacing's) ...
MIN_ROWS = 4  # ... and at least this
FRAME_ROWS = 32  # the strip below render()'s frame (a multiple of 16, as video codecs want)


def view_rows(height: int) -> int:
    """Rows of the strip over a view `height` rows high."""
    return max(MIN_ROWS, height // VIEW_SHARE)


class Dashboard:
    """The strip for one size (rows, width) and one car's gears; `draw` fills an image's last rows."""

    def __init__(self, rows: int, width: int, top_gear: int, lib: ctypes.CDLL | None = None) -> None:
        self.rows, self.width, self.lib = rows, width, lib
        self.field = 3 * width // 8  # the speed's and the steering's
        self.middle = self.field + self.field // 2  # the steering field's middle tick
        self.gears = max(top_gear, 1) + 2  # R, N, 1 .. top gear
        self.r0, self.r1 = 1, rows - 1
        self.template = np.empty((rows, width, 3), dtype=np.uint8)
        self.template[:] = BACKGROUND
        self.template[self.r0:self.r1, self.middle] = TICK
        for slot in range(self.gears):
            c0, c1 = self._gear_cols(slot)
            self.template[self.r0:self.r1, c0:c1] = TICK
        self.colours = (SPEED_BAR, STEER_BAR, GEAR_LIT)
        self.packed = bytes(SPEED_BAR + STEER_BAR + GEAR_LIT)
        # bb_strip's arguments that stay, as addresses (looking one up costs microseconds a frame)
        self.layout = np.array([rows, self.r0, self.r1, self.field, self.middle, self.gears],
                               dtype=np.dtype(ctypes.c_long))
        self.layout_at, self.template_at = self.layout.ctypes.data, self.template.ctypes.data

    def _gear_cols(self, slot: int) -> tuple[int, int]:
        """The columns of a gear's tick (slot 0 is reverse), a column apart."""
        start, span = 2 * self.field, self.width - 2 * self.field
        c0, c1 = start + slot * span // self.gears, start + (slot + 1) * span // self.gears - 1
        return c0, min(max(c0 + 1, c1), self.width)

    def bars(self, speed_mps: float, steer: float, gear: float) -> tuple[int, int, int, int, int, int]:
        """The three bars' columns, [c0, c1) each: speed, steering, the gear engaged (render.c's
        bb_strip computes the same; NaN draws no bar and neutral)."""
        share = min(abs(speed_mps) / SPEED_SPAN_MPS, 1.0) if speed_mps == speed_mps else 0.0
        turn = min(abs(steer), 1.0) if steer == steer else 0.0
        reach = math.floor(turn * (self.field // 2 - 1) + 0.5)
        t0, t1 = (self.middle - reach, self.middle) if steer > 0.0 else (self.middle + 1, self.middle + 1 + reach)
        slot = math.floor(min(max(gear, -1.0), self.gears) + 0.5) + 1 if gear == gear else 1
        return (1, 1 + math.floor(share * (self.field - 2) + 0.5), t0, t1, *self._gear_cols(min(slot, self.gears - 1)))

    def draw(self, image: np.ndarray, address: int, speed_mps: float, steer: float, gear: float) -> None:
        """The strip over the last `rows` rows of `image` (C-contiguous, `width` pixels wide; its
        data at `address`, which the view has looked up already)."""
        if self.lib is not None:
            self.lib.bb_strip(address, image.shape[0], self.width, self.template_at, self.layout_at, speed_mps,
                              SPEED_SPAN_MPS, steer, gear, self.packed)
            return
        strip = image[image.shape[0] - self.rows:]
        strip[:] = self.template
        cols = self.bars(speed_mps, steer, gear)
        for bar, colour in enumerate(self.colours):
            strip[self.r0:self.r1, cols[2 * bar]:cols[2 * bar + 1]] = colour
