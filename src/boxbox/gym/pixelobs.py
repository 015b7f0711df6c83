"""The pixel observation's options, checked together, and the observation they make (docs/gym.md,
"Pixels").

`pixels=True` observes the car's view (gym/render.py) instead of the numbers; `pixels_only=False`
observes both, as Gymnasium's `AddRenderObservation(env, render_only=False)` adds its image: one
`Dict`, the image under "pixels" beside the numbers' own keys (with `flat=True`, the flat vector
under "state").  So code written for that wrapper reads this env's observations as they are, and
Stable-Baselines3's MultiInputPolicy takes them (no nested Dict; the image uint8, height x width x
3).  `dashboard=True` draws speed, steering and gear into a strip of the view and of render()'s
frames (gym/dashboard.py); `view_ahead_m` sets how far ahead the view sees.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from boxbox import validate
from boxbox.gym.render import Drawing, check_pixel_size, pixel_space

PIXELS_KEY = "pixels"  # Gymnasium's AddRenderObservation's render_key and obs_key
NUMBERS_KEY = "state"
VIEW_AHEAD_M = (10.0, 500.0)  # from a car length or two to a long straight (the view's default: 42 m)


@dataclass(frozen=True)
class PixelOptions:
    """What the env observes and draws: `size` of the car's view (None: no pixel observation),
    `only` the view or the view and the numbers, the dashboard in the view and in render()'s frames,
    the view's look-ahead (None: its default)."""

    size: tuple[int, int] | None = None
    only: bool = True
    view_dashboard: bool = False
    frame_dashboard: bool = False
    ahead_m: float | None = None

    @property
    def numbers(self) -> bool:
        """Whether the numbers are observed (they need the range finders each step)."""
        return self.size is None or not self.only

    def drawing(self) -> Drawing:
        return Drawing(self.size, self.ahead_m, self.view_dashboard, self.frame_dashboard)

    def space(self, numbers: spaces.Space) -> spaces.Space:
        """The observation space, given the numbers' (a Dict or a flat Box)."""
        if self.size is None:
            return numbers
        image = pixel_space(self.size)
        if self.only:
            return image
        if isinstance(numbers, spaces.Dict):
            return spaces.Dict({PIXELS_KEY: image, **numbers.spaces})
        return spaces.Dict({NUMBERS_KEY: numbers, PIXELS_KEY: image})

    def observation(self, image: np.ndarray | None, numbers: Any) -> Any:
        """One observation of the car's view (None without pixels) and the numbers (None with the
        view alone)."""
        if image is None:
            return numbers
        if numbers is None:
            return image
        if isinstance(numbers, dict):
            return {PIXELS_KEY: image, **numbers}
        return {NUMBERS_KEY: numbers, PIXELS_KEY: image}


def check_pixel_options(pixels: Any, pixel_size: Any, pixels_only: Any, dashboard: Any, view_ahead_m: Any,
                        render_mode: str | None, frames_have_dashboard: bool = True) -> PixelOptions:
    """The options checked (UsageError, one line); one that would be ignored (it shapes a view that
    is off) is refused, as pixel_size without pixels is.  `frames_have_dashboard`: whether the env's
    render() draws the dashboard (the parallel env's frame shows every car, so it has none)."""
    on = validate.flag(pixels, name="pixels")
    size = check_pixel_size(pixel_size, on)
    only = validate.flag(pixels_only, name="pixels_only")
    strip = validate.flag(dashboard, name="dashboard")
    ahead = None if view_ahead_m is None else validate.finite_number(view_ahead_m, *VIEW_AHEAD_M, name="view_ahead_m")
    if not on and not only:
        validate.fail("False adds the numbers to the pixel observation, which is off; set pixels=True to observe "
                      "the car's view and the numbers, or leave pixels_only out.", "pixels_only")
    if not on and ahead is not None:
        validate.fail(f"{ahead:g} sets how far ahead the pixel observation sees, which is off; set pixels=True, "
                      "or leave view_ahead_m out.", "view_ahead_m")
    frames = strip and render_mode is not None and frames_have_dashboard
    if strip and not on and not frames:
        where, what = (("the pixel observation and render()'s frames, both", "pixels=True or render_mode='rgb_array'")
                       if frames_have_dashboard else ("each car's pixel observation, which is", "pixels=True"))
        validate.fail(f"True draws into {where} off; set {what}, or leave dashboard out.", "dashboard")
    return PixelOptions(size, only, strip and on, frames, ahead)
