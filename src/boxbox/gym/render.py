"""The race drawn top-down from the track the bridge sends and the cars' states: no display, no TORCS
graphics, pure numpy.

The track is drawn once per track (`TrackRaster`: grass, the run-off beside the track, the track, the
pit lane and the start line, as convex quads of the segments' corners, at 0.5 m a pixel), so a frame
costs little: the whole race (`Overview`, `render_mode="rgb_array"`) is a copy of a reduced raster
with every car on it; a car's view (`CarView`, the pixel observation) is one gather from the raster
through the car's position and heading (heading up), with the cars drawn on it.  Every car is an
oriented rectangle of its own length and width, in its own colour.

Pixel coordinates: row 0 at the top (the largest y), column 0 at the left (the smallest x); TORCS's
yaw is counter-clockwise from +x, so a car heading +x points right and one heading +y points up.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from boxbox import validate
from boxbox.gym import raycast
from boxbox.gym.dashboard import FRAME_ROWS, Dashboard, view_rows
from boxbox.model import Car, State, Track
from boxbox.model.constants import DRIVE_STEP_S
from boxbox.model.state import CAR_STATE_NO_SIMU
from boxbox.model.track import LEFT

GRASS = (46, 110, 52)
RUN_OFF = (150, 140, 100)  # the sides beside the track (sand, grass strips, kerbs)
ROAD = (110, 110, 110)
PIT_LANE = (70, 70, 80)
START_LINE = (240, 240, 240)
# the cars' colours by car (the learning car first); a car's own view draws it in OWN_CAR
CAR_COLOURS = ((230, 40, 40), (40, 90, 230), (240, 200, 30), (160, 60, 200), (30, 200, 210), (250, 130, 20),
               (240, 240, 240), (20, 20, 20), (120, 230, 80), (230, 100, 170))
OWN_CAR = CAR_COLOURS[0]
OTHER_CAR = CAR_COLOURS[1]

M_PER_PX = 0.5  # the track raster's resolution
MARGIN_M = 80.0  # grass around the track's outermost corners (a view near the edge stays on the raster)
RUN_OFF_MAX_M = 15.0  # run-off drawn at most this wide
VIEW_WIDTH_M = 60.0  # a car's view, across
VIEW_CAR_ROW = 0.7  # the car's place in its view, from the top (it sees more ahead than behind)
OVERVIEW_PX = 640  # the whole race's image, its longer side at most (a multiple of 16: video codecs)
MIN_CAR_HALF_PX = (2.5, 1.5)  # half length and width of a car in the overview, at least (else a dot)


SOURCE = Path(__file__).with_name("render.c")
_lib: ctypes.CDLL | None = None
_tried = False


def load() -> ctypes.CDLL | None:
    """render.c's loops (built like raycast.c, once per source version), once per process; None without
    a C compiler (numpy does the same, about ten times slower)."""
    global _lib, _tried
    if not _tried:
        _tried = True
        try:
            path = raycast.build(SOURCE)
            lib = ctypes.CDLL(str(path)) if path is not None else None
        except OSError:
            lib = None
        if lib is not None:
            d, p, n = ctypes.c_double, ctypes.c_void_p, ctypes.c_long
            lib.bb_view.argtypes = [p, n, n, d, d, d, d, d, d, d, n, n, p, p]
            lib.bb_view.restype = None
            lib.bb_box.argtypes = [p, n, n, d, d, d, d, d, d, p]
            lib.bb_box.restype = None
            lib.bb_strip.argtypes = [p, n, n, p, p, d, d, d, d, p]
            lib.bb_strip.restype = None
        _lib = lib
    return _lib


@dataclass(frozen=True)
class Car2D:
    """A car as drawn: centre (m), heading (rad, TORCS's yaw), length and width (m), colour."""

    x_m: float
    y_m: float
    yaw_rad: float
    length_m: float
    width_m: float
    colour: tuple[int, int, int]


def fill_quads(image: np.ndarray, quads: np.ndarray, colour: tuple[int, int, int]) -> None:
    """Colour every pixel whose centre is inside a convex quad; quads (n, 4, 2): corners as (col, row)
    in pixels, in order around the quad (either way round)."""
    h, w = image.shape[:2]
    for quad in quads:
        c0, r0 = np.floor(quad.min(axis=0)).astype(int)
        c1, r1 = np.ceil(quad.max(axis=0)).astype(int)
        c0, r0, c1, r1 = max(c0, 0), max(r0, 0), min(c1 + 1, w), min(r1 + 1, h)
        if c0 >= c1 or r0 >= r1:
            continue
        cols = np.arange(c0, c1) + 0.5
        rows = (np.arange(r0, r1) + 0.5)[:, None]
        signs = []
        for k in range(4):
            (ac, ar), (bc, br) = quad[k], quad[(k + 1) % 4]
            signs.append((bc - ac) * (rows - ar) - (br - ar) * (cols - ac))
        s = np.stack(signs)
        inside = np.all(s >= 0.0, axis=0) | np.all(s <= 0.0, axis=0)
        image[r0:r1, c0:c1][inside] = colour


def draw_box(image: np.ndarray, col: float, row: float, axis_col: float, axis_row: float, half_len_px: float,
             half_wid_px: float, colour: tuple[int, int, int], lib: ctypes.CDLL | None = None) -> None:
    """An oriented rectangle centred at (col, row) pixels, its length along the unit vector
    (axis_col, axis_row): the pixels whose centres are inside it take the colour (render.c's bb_box
    with `lib`, on a C-contiguous image)."""
    h, w = image.shape[:2]
    if lib is not None:
        lib.bb_box(image.ctypes.data, h, w, col, row, axis_col, axis_row, half_len_px, half_wid_px,
                   bytes(colour))
        return
    reach = half_len_px + half_wid_px  # a box around the rectangle, whatever its heading
    c0, c1 = max(int(col - reach), 0), min(int(col + reach) + 2, w)
    r0, r1 = max(int(row - reach), 0), min(int(row + reach) + 2, h)
    if c0 >= c1 or r0 >= r1:
        return
    dc = np.arange(c0, c1) + (0.5 - col)
    dr = (np.arange(r0, r1) + (0.5 - row))[:, None]
    along = dc * axis_col + dr * axis_row
    across = dr * axis_col - dc * axis_row
    inside = (np.abs(along) <= half_len_px) & (np.abs(across) <= half_wid_px)
    image[r0:r1, c0:c1][inside] = colour


def _edge_corners(seg: dict[str, np.ndarray]) -> tuple[np.ndarray, ...]:
    """Each segment's start and end corners, left and right: four (n, 2) arrays of (x, y)."""
    def xy(name: str) -> np.ndarray:
        return np.stack([seg[f"{name}_x"], seg[f"{name}_y"]], axis=1)
    return xy("start_left"), xy("end_left"), xy("start_right"), xy("end_right")


def _outward(inner: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Unit vectors from the other edge's corner through this edge's one (outward across the track)."""
    d = inner - other
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)


def _band(a: np.ndarray, b: np.ndarray, out_a: np.ndarray, out_b: np.ndarray, from_m, to_m) -> np.ndarray:
    """(n, 4, 2) world quads beside an edge from `from_m` to `to_m` metres outward of it."""
    f = np.asarray(from_m, dtype=float).reshape(-1, 1)
    t = np.asarray(to_m, dtype=float).reshape(-1, 1)
    return np.stack([a + out_a * f, b + out_b * f, b + out_b * t, a + out_a * t], axis=1)


def _pit_segments(track: Track) -> np.ndarray:
    """The segments from the pit entry to the pit exit (empty without a pit lane)."""
    pit, n = track.pit, track.n_segments
    if pit is None:
        return np.zeros(0, dtype=int)
    entry, exit_ = pit.entry_seg % n, pit.exit_seg % n
    return (entry + np.arange((exit_ - entry) % n + 1)) % n


class TrackRaster:
    """The track drawn once at M_PER_PX metres a pixel: `image` (H, W, 3) uint8."""

    def __init__(self, track: Track, m_per_px: float = M_PER_PX, margin_m: float = MARGIN_M) -> None:
        sl, el, sr, er = _edge_corners(track.seg)
        corners = np.concatenate([sl, el, sr, er])
        self.m_per_px = float(m_per_px)
        self.x0_m = float(corners[:, 0].min()) - margin_m
        self.y1_m = float(corners[:, 1].max()) + margin_m  # the top row's y
        width = int(math.ceil((corners[:, 0].max() + margin_m - self.x0_m) / m_per_px))
        height = int(math.ceil((self.y1_m - corners[:, 1].min() + margin_m) / m_per_px))
        self.image = np.empty((height, width, 3), dtype=np.uint8)
        self.image[:] = GRASS
        self._draw(track, sl, el, sr, er)
        self.flat = self.image.reshape(-1, 3)
        self._coarse: dict[int, np.ndarray] = {1: self.image}

    def coarse(self, step: int) -> np.ndarray:
        """The image at `step` x `step` pixels a pixel (each its block's middle pixel), made once a
        step: a view that spans several pixels a pixel reads this, so it touches no more memory
        than a view at the raster's detail (a 96x96 view 100 m ahead took about 1.5 times as long a
        frame reading the full raster, in an env on a loaded machine)."""
        if step not in self._coarse:
            self._coarse[step] = np.ascontiguousarray(self.image[step // 2::step, step // 2::step])
        return self._coarse[step]

    def to_px(self, xy: np.ndarray) -> np.ndarray:
        """World (x, y) metres to raster (col, row) pixels (any leading shape)."""
        out = np.empty_like(xy, dtype=float)
        out[..., 0] = (xy[..., 0] - self.x0_m) / self.m_per_px
        out[..., 1] = (self.y1_m - xy[..., 1]) / self.m_per_px
        return out

    def _draw(self, track: Track, sl, el, sr, er) -> None:
        seg = track.seg
        out_sl, out_el, out_sr, out_er = _outward(sl, sr), _outward(el, er), _outward(sr, sl), _outward(er, el)
        for side, (a, b, oa, ob) in (("left", (sl, el, out_sl, out_el)), ("right", (sr, er, out_sr, out_er))):
            width = np.minimum(seg.get(f"{side}_side_width_m", np.zeros(len(a))), RUN_OFF_MAX_M)
            fill_quads(self.image, self.to_px(_band(a, b, oa, ob, 0.0, width)), RUN_OFF)
        fill_quads(self.image, self.to_px(np.stack([sl, el, er, sr], axis=1)), ROAD)
        pits = _pit_segments(track)
        if len(pits) and track.pit is not None:
            a, b, oa, ob = (sl, el, out_sl, out_el) if track.pit.side == LEFT else (sr, er, out_sr, out_er)
            band = _band(a[pits], b[pits], oa[pits], ob[pits], 0.0, float(track.pit.width_m))
            fill_quads(self.image, self.to_px(band), PIT_LANE)
        start = np.stack([sl[0], sl[0] + _dir(sl[0], el[0]), sr[0] + _dir(sr[0], er[0]), sr[0]])  # 1 m deep
        fill_quads(self.image, self.to_px(start[None]), START_LINE)


def _dir(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    return d / max(float(np.linalg.norm(d)), 1e-9)


_rasters: dict[tuple, TrackRaster] = {}  # the last few tracks' rasters, shared by the envs of a process


def raster_of(track: Track) -> TrackRaster:
    """The track's raster, drawn once per process (0.2 to 0.7 s) while its segments stay the same."""
    seg = track.seg
    key = (track.name, track.n_segments, float(track.length_m), float(seg["start_left_x"][0]),
           float(seg["start_left_y"][0]), track.pit is None)
    if key not in _rasters:
        if len(_rasters) >= 4:
            _rasters.pop(next(iter(_rasters)))
        _rasters[key] = TrackRaster(track)
    return _rasters[key]


def cars_of(state: State, length_m: float, width_m: float, colour=OWN_CAR, others=None) -> list[Car2D]:
    """The cars of one state to draw: the car itself and every opponent still in the race (coloured
    by `others`: a function of the opponent's car index, else OTHER_CAR)."""
    cars = [Car2D(state.x_m, state.y_m, state.yaw_rad, length_m, width_m, colour)]
    for o in state.opponents:
        if int(o.car_state) & CAR_STATE_NO_SIMU:
            continue
        cars.append(Car2D(o.x_m, o.y_m, o.yaw_rad, o.length_m, o.width_m,
                          others(int(o.car_index)) if others is not None else OTHER_CAR))
    return cars


class Overview:
    """The whole race (`render_mode="rgb_array"`): the raster reduced to at most `longest_px` pixels
    on its longer side (each side a multiple of 16), every car drawn on it; `strip_rows` more rows
    below it for the dashboard."""

    def __init__(self, raster: TrackRaster, longest_px: int = OVERVIEW_PX, strip_rows: int = 0) -> None:
        h, w = raster.image.shape[:2]
        step = max(1, math.ceil(max(h, w) / longest_px))
        small = raster.image[::step, ::step]
        h16, w16 = max(16, small.shape[0] // 16 * 16), max(16, small.shape[1] // 16 * 16)
        self.image = np.zeros((h16 + strip_rows, w16, 3), dtype=np.uint8)
        self.image[: min(h16, small.shape[0]), : min(w16, small.shape[1])] = small[:h16, :w16]
        self.raster, self.m_per_px = raster, raster.m_per_px * step
        self.lib = load()

    def frame(self, cars: list[Car2D]) -> np.ndarray:
        out = self.image.copy()
        r = self.raster
        for car in cars:
            col, row = (car.x_m - r.x0_m) / self.m_per_px, (r.y1_m - car.y_m) / self.m_per_px
            half_len = max(0.5 * car.length_m / self.m_per_px, MIN_CAR_HALF_PX[0])
            half_wid = max(0.5 * car.width_m / self.m_per_px, MIN_CAR_HALF_PX[1])
            draw_box(out, col, row, math.cos(car.yaw_rad), -math.sin(car.yaw_rad), half_len, half_wid, car.colour,
                     self.lib)
        return out


def view_width_m(size: tuple[int, int], ahead_m: float | None, car_row: float = VIEW_CAR_ROW) -> float:
    """Metres across a view of `size` (height, width) whose top row is `ahead_m` ahead of the car
    (square pixels); None: VIEW_WIDTH_M (42 m ahead at a square size)."""
    return VIEW_WIDTH_M if ahead_m is None else ahead_m * size[1] / (car_row * size[0])


class CarView:
    """A car-centred, heading-up view of the raster, (height, width) pixels covering `width_m` metres
    across, the car at `car_row` of the height from the top: the pixel observation."""

    def __init__(self, raster: TrackRaster, size: tuple[int, int] = (96, 96), width_m: float = VIEW_WIDTH_M,
                 car_row: float = VIEW_CAR_ROW, use_c: bool = True) -> None:
        h, w = size
        self.raster, self.size = raster, (h, w)
        self.m_per_px = width_m / w
        step = max(1, int(self.m_per_px / raster.m_per_px))  # whole raster pixels a view pixel spans
        self.image, self.image_m_per_px = raster.coarse(step), raster.m_per_px * step
        self.scale = self.m_per_px / self.image_m_per_px  # view pixels to the image's pixels
        self.car_col, self.car_row = 0.5 * w, car_row * h
        self.lib = load() if use_c else None
        self.grass = bytes(GRASS)
        self.image_at = self.image.ctypes.data  # (looking an address up costs a microsecond or two)
        self.reach = float(h + w)  # cars farther than this (view pixels) are not drawn

    def frame(self, x_m: float, y_m: float, yaw_rad: float, cars: list[Car2D],
              strip: tuple[Dashboard, float, float, float] | None = None) -> np.ndarray:
        """The view of a car at (x, y) heading yaw; `cars` are drawn on it (the car itself among them),
        then `strip`, a dashboard and its speed, steering and gear, over its last rows."""
        r = self.raster
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        col0, row0 = (x_m - r.x0_m) / self.image_m_per_px, (r.y1_m - y_m) / self.image_m_per_px
        out = np.empty((self.size[0], self.size[1], 3), dtype=np.uint8)
        address = 0
        if self.lib is not None:
            address = out.ctypes.data
            self.lib.bb_view(self.image_at, self.image.shape[0], self.image.shape[1], col0, row0, c, s, self.scale,
                             self.car_row, self.car_col, self.size[0], self.size[1], address, self.grass)
        else:
            self._gather(out, col0, row0, c, s)
        self._draw_cars(out, address, x_m, y_m, c, s, yaw_rad, cars)
        if strip is not None:
            strip[0].draw(out, address, *strip[1:])
        return out

    def _draw_cars(self, out: np.ndarray, address: int, x_m: float, y_m: float, c: float, s: float, yaw_rad: float,
                   cars: list[Car2D]) -> None:
        lib, h, w = self.lib, self.size[0], self.size[1]
        for car in cars:
            dx, dy = car.x_m - x_m, car.y_m - y_m
            ahead, left = (dx * c + dy * s) / self.m_per_px, (dy * c - dx * s) / self.m_per_px
            if abs(ahead) > self.reach or abs(left) > self.reach:
                continue
            turn = car.yaw_rad - yaw_rad  # its heading in the view: 0 is up
            col, row, axis_col, axis_row = self.car_col - left, self.car_row - ahead, -math.sin(turn), -math.cos(turn)
            half_len, half_wid = 0.5 * car.length_m / self.m_per_px, 0.5 * car.width_m / self.m_per_px
            if lib is not None:
                lib.bb_box(address, h, w, col, row, axis_col, axis_row, half_len, half_wid, bytes(car.colour))
            else:
                draw_box(out, col, row, axis_col, axis_row, half_len, half_wid, car.colour)

    def _gather(self, out: np.ndarray, col0: float, row0: float, c: float, s: float) -> None:
        """What render.c's bb_view does, in numpy (without a C compiler, and to check the C)."""
        h, w = self.size
        ahead = (self.car_row - (np.arange(h) + 0.5))[:, None] * self.scale
        left = (self.car_col - (np.arange(w) + 0.5))[None, :] * self.scale
        col = np.floor((col0 + ahead * c) - left * s)
        row = np.floor((row0 - ahead * s) - left * c)
        rh, rw = self.image.shape[:2]
        inside = (col >= 0) & (row >= 0) & (col < rw) & (row < rh)
        out[:] = GRASS
        out[inside] = self.image[row[inside].astype(np.intp), col[inside].astype(np.intp)]


# --- what an env draws ---------------------------------------------------------------------------
RENDER_MODES = ["rgb_array"]
MAX_PIXELS = 1024  # a side of the pixel observation, at most
DEFAULT_PIXEL_SIZE = (96, 96)  # (height, width), as Gymnasium's CarRacing observes


def check_render_mode(render_mode: Any) -> str | None:
    if render_mode is None:
        return None
    return validate.choice(render_mode, RENDER_MODES, name="render_mode")


def check_pixel_size(pixel_size: Any, pixels: bool) -> tuple[int, int] | None:
    """(height, width) of the pixel observation with `pixels` (None: DEFAULT_PIXEL_SIZE), each 8 to
    MAX_PIXELS; None without pixels, where a size given would be ignored, so it is refused."""
    if not pixels:
        if pixel_size is not None:
            validate.fail(f"{pixel_size!r:.60} sizes the pixel observation, which is off; set pixels=True to "
                          "observe the car's view, or leave pixel_size out.", "pixel_size")
        return None
    if pixel_size is None:
        return DEFAULT_PIXEL_SIZE
    values = validate.items(pixel_size, "pixel sizes", name="pixel_size")
    if len(values) != 2:
        validate.fail(f"{pixel_size!r:.60} is not (height, width); give two whole numbers, e.g. (96, 96).",
                      "pixel_size")
    height, width = (validate.whole_number(v, 8, MAX_PIXELS, name="pixel_size") for v in values)
    return height, width


def render_fps(action_repeat: int) -> float:
    """Frames a second of simulated time: one frame a step."""
    return 1.0 / (DRIVE_STEP_S * action_repeat)


def pixel_space(size: tuple[int, int]) -> spaces.Box:
    return spaces.Box(0, 255, shape=(size[0], size[1], 3), dtype=np.uint8)


class Drawing:
    """What an env draws of its race: the track raster (made once a track), the whole race for
    render() and, with pixels, each car's view as its observation; `view_ahead_m` sets how far
    ahead the view sees (None: view_width_m's default), `dashboard` draws the dashboard strip
    over the view's last rows and `frame_dashboard` below render()'s frame (gym/dashboard.py)."""

    def __init__(self, pixel_size: tuple[int, int] | None, view_ahead_m: float | None = None,
                 dashboard: bool = False, frame_dashboard: bool = False) -> None:
        self.pixel_size = pixel_size  # None: no pixel observation
        self.view_ahead_m, self.dashboard, self.frame_dashboard = view_ahead_m, dashboard, frame_dashboard
        self.track: Track | None = None
        self.overview: Overview | None = None
        self.view: CarView | None = None
        self.strips: dict[tuple[int, int], tuple[Car, Dashboard]] = {}  # by (rows, width): the car's

    def new_track(self, track: Track) -> None:
        if track is self.track:
            return
        raster = raster_of(track)
        self.track, self.overview = track, Overview(raster, strip_rows=FRAME_ROWS if self.frame_dashboard else 0)
        size = self.pixel_size
        self.view = CarView(raster, size, view_width_m(size, self.view_ahead_m)) if size is not None else None

    def observation(self, state: State, car: Car, others=None, steer: float = 0.0) -> np.ndarray:
        """The car's view (heading up), the car itself in OWN_CAR, the others in their colours; the
        dashboard (its `steer` the last action's) over its last rows."""
        view = self.view
        assert view is not None
        strip = ((self._strip(view_rows(view.size[0]), view.size[1], car), state.speed_x_mps, steer, state.gear)
                 if self.dashboard else None)
        return view.frame(state.x_m, state.y_m, state.yaw_rad, cars_of(state, car.length_m, car.width_m, OWN_CAR,
                                                                       others), strip)

    def frame(self, state: State | None, car: Car | None, colour=OWN_CAR, others=None,
              steer: float = 0.0) -> np.ndarray | None:
        """The whole race seen from above (the dashboard below it), or None before the first reset."""
        if self.overview is None or state is None or car is None:
            return None
        out = self.overview.frame(cars_of(state, car.length_m, car.width_m, colour, others))
        if self.frame_dashboard:
            self._strip(FRAME_ROWS, out.shape[1], car).draw(out, out.ctypes.data, state.speed_x_mps, steer, state.gear)
        return out

    def _strip(self, rows: int, width: int, car: Car) -> Dashboard:
        """The strip of that size for the car (made again when the car changes: a race's car is one
        object, and its max_gear costs microseconds a frame)."""
        held = self.strips.get((rows, width))
        if held is None or held[0] is not car:
            held = self.strips[(rows, width)] = (car, Dashboard(rows, width, car.max_gear, load()))
        return held[1]
