"""The pixel observation's options (gym/pixelobs.py, gym/dashboard.py, gym/render.py): the view with
the numbers in one Dict that Gymnasium's checker and Stable-Baselines3's MultiInputPolicy take, the
dashboard strip drawn from the car's speed, steering and gear, the view's look-ahead, each option
checked in one line."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces

import trackdata
from boxbox.errors import UsageError
from boxbox.gym import render
from boxbox.gym.dashboard import FRAME_ROWS, GEAR_LIT, SPEED_BAR, STEER_BAR, TICK, Dashboard, view_rows
from boxbox.gym.pixelobs import PixelOptions, check_pixel_options
from boxbox.gym.render import OTHER_CAR, OWN_CAR, Car2D, CarView, Drawing, TrackRaster
from boxbox.gym.spaces import ObservationLayout
from boxbox.model import Car, State

# 200 m straight along y=0 heading +x, then a hairpin back (as test_render.py's oval)
OVAL = trackdata.build_track([("S", 200.0), ("L", 50.0, 180.0), ("S", 200.0), ("L", 50.0, 180.0)], width_m=12.0)
LAYOUT = ObservationLayout.make(19)
CAR = Car()  # top gear 6 before the race (model/car.py)


def state(**fields) -> State:
    return State(*([0.0] * 42))._replace(**fields)


@pytest.fixture(scope="module")
def raster() -> TrackRaster:
    return TrackRaster(OVAL)


# --- the Dict of the view and the numbers --------------------------------------------------------
@pytest.mark.parametrize("flat", [False, True])
def test_pixels_with_the_numbers_are_one_dict_of_the_image_and_the_numbers(flat):
    numbers = LAYOUT.space(flat, True)
    look = PixelOptions((84, 96), only=False)
    space = look.space(numbers)
    assert isinstance(space, spaces.Dict)
    assert space["pixels"] == spaces.Box(0, 255, (84, 96, 3), np.uint8)
    if flat:  # Gymnasium's AddRenderObservation(render_only=False) on a Box: {"pixels", "state"}
        assert set(space.spaces) == {"pixels", "state"} and space["state"] == numbers
    else:  # ... on a Dict: "pixels" beside its keys, nothing nested
        assert set(space.spaces) == {"pixels", *numbers.spaces}
        assert all(space[key] == numbers[key] for key in numbers.spaces)
    image = np.zeros((84, 96, 3), np.uint8)
    obs = look.observation(image, numbers.sample())
    assert space.contains(obs) and obs["pixels"] is image
    # the other forms as they were: the view alone, the numbers alone
    assert PixelOptions((84, 96)).space(numbers) == spaces.Box(0, 255, (84, 96, 3), np.uint8)
    assert PixelOptions().space(numbers) is numbers and PixelOptions().observation(None, obs) is obs
    assert PixelOptions((84, 96)).observation(image, None) is image


def test_stable_baselines3_takes_the_dict_for_its_multi_input_policy():
    preprocessing = pytest.importorskip("stable_baselines3.common.preprocessing")
    for flat in (False, True):
        space = PixelOptions((96, 96), only=False).space(LAYOUT.space(flat, True))
        preprocessing.check_for_nested_spaces(space)  # raises on a Dict in the Dict
        kinds = {key: preprocessing.is_image_space(sub) for key, sub in space.spaces.items()}
        assert kinds.pop("pixels") and not any(kinds.values())  # one image, channels last; the rest vectors


# --- the options' checks -----------------------------------------------------------------------
def refused(**kwargs) -> str:
    base = {"pixels": False, "pixel_size": None, "pixels_only": True, "dashboard": False, "view_ahead_m": None,
            "render_mode": None}
    with pytest.raises(UsageError) as error:
        check_pixel_options(**{**base, **kwargs})
    assert "\n" not in str(error.value)
    return str(error.value)


def test_each_option_is_checked_in_one_line_naming_it():
    assert refused(pixels_only="no").startswith("Invalid value for 'pixels_only': 'no' is not True or False")
    assert refused(dashboard=1.5).startswith("Invalid value for 'dashboard'")
    for bad in (float("nan"), float("inf"), -50, 5, 501, "far", (40,)):
        assert refused(pixels=True, view_ahead_m=bad).startswith("Invalid value for 'view_ahead_m'"), bad
    assert "is not in the range 10.0<=x<=500.0" in refused(pixels=True, view_ahead_m=1000)
    assert "is not a finite number" in refused(pixels=True, view_ahead_m=float("nan"))


def test_options_that_would_be_ignored_are_refused_with_what_to_do():
    assert refused(pixels_only=False) == ("Invalid value for 'pixels_only': False adds the numbers to the pixel "
                                          "observation, which is off; set pixels=True to observe the car's view "
                                          "and the numbers, or leave pixels_only out.")
    assert "sets how far ahead the pixel observation sees, which is off; set pixels=True" in refused(view_ahead_m=80)
    assert "set pixels=True or render_mode='rgb_array', or leave dashboard out" in refused(dashboard=True)
    # the parallel env's render() shows every car: its dashboard is each car's view's only
    with pytest.raises(UsageError, match="into each car's pixel observation, which is off; set pixels=True"):
        check_pixel_options(False, None, True, True, None, "rgb_array", frames_have_dashboard=False)


def test_the_options_say_where_the_dashboard_goes():
    look = check_pixel_options(True, (64, 64), False, True, 80, None)
    assert look == PixelOptions((64, 64), only=False, view_dashboard=True, frame_dashboard=False, ahead_m=80.0)
    assert look.numbers and not PixelOptions((64, 64)).numbers and PixelOptions().numbers
    frames_only = check_pixel_options(False, None, True, True, None, "rgb_array")
    assert frames_only.frame_dashboard and not frames_only.view_dashboard and frames_only.size is None


# --- the dashboard strip -----------------------------------------------------------------------
def columns_of(strip: np.ndarray, colour) -> np.ndarray:
    """The columns where the strip's middle row has that colour."""
    return np.flatnonzero((strip[strip.shape[0] // 2] == np.array(colour, np.uint8)).all(axis=1))


def test_the_strip_shows_speed_steering_and_gear_as_bars(raster):
    drawing = Drawing((96, 96), dashboard=True)
    drawing.new_track(OVAL)
    plain = Drawing((96, 96))
    plain.new_track(OVAL)
    rows = view_rows(96)
    assert rows == 12  # an eighth, as CarRacing's

    def strip(speed_mps=0.0, steer=0.0, gear=1.0) -> np.ndarray:
        s = state(x_m=100.0, speed_x_mps=speed_mps, gear=gear)
        out = drawing.observation(s, CAR, steer=steer)
        assert np.array_equal(out[:-rows], plain.observation(s, CAR)[:-rows])  # the view above it untouched
        return out[-rows:]

    slow, fast = strip(speed_mps=10.0), strip(speed_mps=60.0)
    assert not np.array_equal(slow, fast)
    bars = [len(columns_of(strip(speed_mps=v), SPEED_BAR)) for v in (0.0, 10.0, 50.0, 100.0, 300.0)]
    assert bars == [0, 3, 17, 34, 34]  # the field's 36 columns but one each side, full at 100 m/s
    assert columns_of(fast, SPEED_BAR).min() == 1  # from the left
    left, right, ahead = strip(steer=0.5), strip(steer=-1.0), strip(steer=0.0)
    middle = 36 + 18
    assert columns_of(left, STEER_BAR).max() < middle < columns_of(right, STEER_BAR).min()
    assert (len(columns_of(right, STEER_BAR)), len(columns_of(left, STEER_BAR))) == (17, 9)  # full lock, half
    assert len(columns_of(ahead, STEER_BAR)) == 0 and middle in columns_of(ahead, TICK)
    lit = [columns_of(strip(gear=g), GEAR_LIT).mean() for g in (-1, 0, 1, 2, 6)]
    assert lit == sorted(lit) and len(set(lit)) == 5  # R, N, 1, 2, ... left to right


def test_the_c_strip_draws_what_numpy_draws():
    fast, slow = Dashboard(12, 96, 6, render.load()), Dashboard(12, 96, 6)
    if fast.lib is None:
        pytest.skip("no C compiler")
    nan = float("nan")
    for speed, steer, gear in [(0, 0, 1), (50, 0.5, 3), (100, -1, 6), (-20, 0.2, -1), (150, 2, 9), (30, -0.01, 0),
                               (35.3, 0.25, -7), (1.5, -0.75, 2.4), (nan, nan, nan)]:
        a, b = np.full((40, 96, 3), 7, np.uint8), np.full((40, 96, 3), 7, np.uint8)
        fast.draw(a, a.ctypes.data, speed, steer, gear)
        slow.draw(b, 0, speed, steer, gear)
        assert np.array_equal(a, b) and (a[:-12] == 7).all(), (speed, steer, gear)
        assert (a[-12:] != 7).all()  # the whole strip drawn


def test_render_frames_get_the_strip_below_the_race():
    plain, with_strip = Drawing(None), Drawing(None, frame_dashboard=True)
    plain.new_track(OVAL)
    with_strip.new_track(OVAL)
    s = state(x_m=100.0, speed_x_mps=40.0, gear=3.0)
    frame, framed = plain.frame(s, CAR), with_strip.frame(s, CAR, steer=0.3)
    assert framed.shape == (frame.shape[0] + FRAME_ROWS, frame.shape[1], 3) and framed.shape[0] % 16 == 0
    assert np.array_equal(framed[:-FRAME_ROWS], frame)
    strip = framed[-FRAME_ROWS:]
    assert len(columns_of(strip, SPEED_BAR)) > 0 and len(columns_of(strip, GEAR_LIT)) > 0
    assert len(columns_of(strip, STEER_BAR)) > 0


# --- the look-ahead ------------------------------------------------------------------------------
def test_the_view_sees_as_far_ahead_as_asked(raster):
    assert render.view_width_m((96, 96), None) == 60.0  # the default: 42 m ahead, 18 behind
    assert render.view_width_m((96, 96), 42.0) == pytest.approx(60.0)
    assert render.view_width_m((64, 128), 100.0) == pytest.approx(100.0 / 0.7 * 2)  # square pixels
    me = Car2D(20.0, 0.0, 0.0, 4.5, 1.9, OWN_CAR)
    ahead_90 = Car2D(110.0, 0.0, 0.0, 4.5, 1.9, OTHER_CAR)  # 90 m up the straight
    near, far = CarView(raster), CarView(raster, width_m=render.view_width_m((96, 96), 100.0))
    assert not (near.frame(20.0, 0.0, 0.0, [me, ahead_90]) == OTHER_CAR).all(axis=2).any()
    seen = np.argwhere((far.frame(20.0, 0.0, 0.0, [me, ahead_90]) == OTHER_CAR).all(axis=2))
    assert len(seen) and abs(seen[:, 0].mean() - (67.2 - 90.0 / (100.0 / 67.2))) < 1.5  # 90 m of 100 up the view
    slow = CarView(raster, width_m=render.view_width_m((96, 96), 100.0), use_c=False)
    if far.lib is not None:  # the C loop reads the coarser raster as numpy does
        for x, y, yaw in [(20.0, 0.0, 0.0), (230.0, 40.0, 2.1), (-40.0, 60.0, -1.2)]:
            assert np.array_equal(far.frame(x, y, yaw, [me]), slow.frame(x, y, yaw, [me]))
    assert far.image_m_per_px == 1.0 and near.image is raster.image  # every second pixel at 1.5 m a view pixel
    drawing = Drawing((96, 96), view_ahead_m=100.0)
    drawing.new_track(OVAL)
    assert drawing.view is not None and drawing.view.m_per_px == pytest.approx(100.0 / 67.2)


@pytest.mark.parametrize("size", [(8, 8), (8, 1024), (1024, 9)])
def test_the_strip_fits_the_smallest_and_widest_views(size):
    rows = view_rows(size[0])
    for lib in (render.load(), None):
        strip = Dashboard(rows, size[1], 6, lib)
        image = np.full((*size, 3), 7, np.uint8)
        strip.draw(image, image.ctypes.data, 100.0, -1.0, 6.0)
        assert (image[:-rows] == 7).all() and (image[-rows:] != 7).all()
        assert len(columns_of(image[-rows:], GEAR_LIT)) >= 1  # the top gear lit, inside the image
