"""The top-down drawing (gym/render.py) on a constructed track: cars at known places and headings land
on known pixels, the car's view is heading-up, the C loops draw what numpy draws."""

from __future__ import annotations

import math

import numpy as np
import pytest

import trackdata
from boxbox.errors import UsageError
from boxbox.gym import render
from boxbox.gym.render import GRASS, OTHER_CAR, OWN_CAR, ROAD, Car2D, CarView, Overview, TrackRaster

# an oval: 200 m along y=0 heading +x (left edge y=+6, right edge y=-6), a left hairpin of radius
# 50 m, 200 m back along y=100, another hairpin
OVAL = trackdata.build_track([("S", 200.0), ("L", 50.0, 180.0), ("S", 200.0), ("L", 50.0, 180.0)], width_m=12.0)
VIEW_M_PER_PX = render.VIEW_WIDTH_M / 96  # 0.625 m
CAR_ROW, CAR_COL = 67, 48  # the pixel under the car's centre (0.7 of 96 from the top, the middle)


@pytest.fixture(scope="module")
def raster() -> TrackRaster:
    return TrackRaster(OVAL)


def pixel(raster: TrackRaster, x: float, y: float) -> tuple[int, ...]:
    col, row = raster.to_px(np.array([x, y]))
    return tuple(int(v) for v in raster.image[int(row), int(col)])


def car(x: float, y: float, yaw: float, colour=OWN_CAR) -> Car2D:
    return Car2D(x, y, yaw, 4.5, 1.9, colour)


def test_the_raster_has_the_road_where_the_track_is(raster):
    assert pixel(raster, 100.0, 0.0) == ROAD and pixel(raster, 100.0, 5.5) == ROAD and pixel(raster, 100, -5.5) == ROAD
    assert pixel(raster, 100.0, 7.0) == GRASS and pixel(raster, 100.0, -7.0) == GRASS
    assert pixel(raster, 100.0, 50.0) == GRASS  # the infield
    assert pixel(raster, 250.0, 50.0) == ROAD  # the hairpin's apex: centre (200, 50), radius 50
    assert pixel(raster, 100.0, 100.0) == ROAD  # the straight back


def test_the_car_sits_at_its_place_in_its_view_heading_up(raster):
    view = CarView(raster)
    frame = view.frame(100.0, 0.0, 0.0, [car(100.0, 0.0, 0.0)])
    assert frame.shape == (96, 96, 3) and frame.dtype == np.uint8
    assert tuple(frame[CAR_ROW, CAR_COL]) == OWN_CAR
    # 4.5 m long, up the view (7.2 px); 1.9 m wide, across (3 px)
    assert tuple(frame[CAR_ROW - 3, CAR_COL]) == OWN_CAR and tuple(frame[CAR_ROW + 3, CAR_COL]) == OWN_CAR
    assert tuple(frame[CAR_ROW, CAR_COL - 3]) != OWN_CAR and tuple(frame[CAR_ROW - 5, CAR_COL]) != OWN_CAR
    # heading +x along the straight: the road runs up the view, 12 m = 19 px wide, on every row
    edge_px = round(6.0 / VIEW_M_PER_PX)
    rows = [r for r in range(96) if abs(r - CAR_ROW) > 4]
    assert all(tuple(frame[r, CAR_COL]) == ROAD for r in rows)
    assert all(tuple(frame[r, CAR_COL - edge_px + 1]) == ROAD and tuple(frame[r, CAR_COL + edge_px - 1]) == ROAD
               for r in rows)
    assert all(tuple(frame[r, CAR_COL - edge_px - 2]) == GRASS and tuple(frame[r, CAR_COL + edge_px + 2]) == GRASS
               for r in rows)


def test_a_car_turned_across_the_road_sees_the_road_across_its_view(raster):
    frame = CarView(raster).frame(100.0, 0.0, math.pi / 2, [])  # heading +y: the left edge 6 m ahead
    ahead_6m = round(6.0 / VIEW_M_PER_PX)
    assert tuple(frame[CAR_ROW - ahead_6m + 2, CAR_COL]) == ROAD
    assert tuple(frame[CAR_ROW - ahead_6m - 2, CAR_COL]) == GRASS
    assert all(tuple(frame[CAR_ROW, c]) == ROAD for c in range(96))  # along the road, right and left of the car
    # the same stretch seen from the straight back (heading -x at y=100): the same picture as heading +x
    assert np.array_equal(CarView(raster).frame(100.0, 100.0, math.pi, []), CarView(raster).frame(100.0, 0.0, 0.0, []))


@pytest.mark.parametrize("yaw", [0.0, 0.7, 2.0, -2.5, math.pi])
def test_other_cars_land_where_they_are_from_the_car_whatever_its_heading(raster, yaw):
    x, y = 100.0, 0.0
    forward, left = np.array([math.cos(yaw), math.sin(yaw)]), np.array([-math.sin(yaw), math.cos(yaw)])
    ahead = (x, y) + 10.0 * forward  # 16 px up the view
    beside = (x, y) + 5.0 * left  # 8 px to the left
    across = (x, y) - 12.5 * forward  # 20 px down, turned a quarter: its length across the view
    cars = [car(*ahead, yaw, OTHER_CAR), car(*beside, yaw, OTHER_CAR), car(*across, yaw + math.pi / 2, OTHER_CAR)]
    frame = CarView(raster).frame(x, y, yaw, cars)
    assert tuple(frame[CAR_ROW - 16, CAR_COL]) == OTHER_CAR
    assert tuple(frame[CAR_ROW, CAR_COL - 8]) == OTHER_CAR
    assert tuple(frame[CAR_ROW + 20, CAR_COL - 3]) == OTHER_CAR and tuple(frame[CAR_ROW + 20, CAR_COL + 3]) == OTHER_CAR
    assert tuple(frame[CAR_ROW + 17, CAR_COL]) != OTHER_CAR  # 1.9 m wide: not 3 px up


def test_the_c_loops_draw_what_numpy_draws(raster):
    fast, slow = CarView(raster, (64, 80)), CarView(raster, (64, 80), use_c=False)
    if fast.lib is None:
        pytest.skip("no C compiler")
    for x, y, yaw in [(100.0, 0.0, 0.3), (230.0, 40.0, 2.1), (-40.0, 60.0, -1.2), (-500.0, -500.0, 0.0)]:
        cars = [car(x, y, yaw), car(x + 3.0, y + 4.0, yaw + 1.0, OTHER_CAR)]
        assert np.array_equal(fast.frame(x, y, yaw, cars), slow.frame(x, y, yaw, cars))


def test_the_overview_shows_every_car_where_it_is(raster):
    overview = Overview(raster, longest_px=256)
    frame = overview.frame([car(100.0, 0.0, 0.0), car(250.0, 50.0, math.pi / 2, OTHER_CAR)])
    assert frame.dtype == np.uint8 and frame.shape[0] % 16 == 0 and frame.shape[1] % 16 == 0
    assert max(frame.shape[:2]) <= 256
    for (x, y), colour in (((100.0, 0.0), OWN_CAR), ((250.0, 50.0), OTHER_CAR)):
        col = int((x - raster.x0_m) / overview.m_per_px)
        row = int((raster.y1_m - y) / overview.m_per_px)
        assert tuple(frame[row, col]) == colour
    assert not np.array_equal(frame, overview.image)  # the cars drawn on a copy
    assert tuple(overview.image[int((raster.y1_m - 0.0) / overview.m_per_px),
                                int((100.0 - raster.x0_m) / overview.m_per_px)]) == ROAD


def test_render_options_are_checked():
    assert render.check_render_mode(None) is None and render.check_render_mode("rgb_array") == "rgb_array"
    assert render.check_pixel_size((64, 128), True) == (64, 128)
    assert render.check_pixel_size(None, True) == (96, 96) and render.check_pixel_size(None, False) is None
    for bad in ("human", 1, "RGB"):
        with pytest.raises(UsageError, match="render_mode"):
            render.check_render_mode(bad)
    for bad in ((96,), (96, 96, 3), (4, 96), (96, 5000), "big", 96):
        with pytest.raises(UsageError, match="pixel_size"):
            render.check_pixel_size(bad, True)
    assert render.render_fps(1) == 50.0 and render.render_fps(5) == 10.0
