"""Scale from two points in the picture a known distance apart: a ruler's ends.

A ball dropped or tossed in front of a metre stick, a pendulum beside a tape
measure: the thing filmed carries no second marker whose distance to it is fixed,
but something in the picture has a known length. The user reads its two ends off
one frame (``cranktrack inspect``'s picture, whose edges carry a pixel scale, or any
viewer that shows a pixel's place) and types them with the length:
``--ruler X1,Y1,X2,Y2=MM``.

This is the same one-scale mapping as :mod:`.known_length`, and carries the same
assumptions: the camera looks square at the plane of motion and the lens does not
bend lines. It also assumes the ruler lies in that plane; one nearer the camera
than the motion makes every length too short by the ratio of their distances.

The plane frame puts the ruler's first end at the origin, +x along the image's x
and +y up the image, so a falling body's acceleration is negative in y. A run of
the crank-slider's markers moves it onto A and C as always.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CranktrackError
from .plane import PlaneCalibration, similarity

#: The 1-σ (px) taken for each typed end of a ruler: an end read off a picture to the
#: nearest pixel, where a mark a few pixels wide is not placed better than that.
END_SIGMA_PX = 0.5

#: Ends nearer than this (px) give a scale no better than END_SIGMA_PX / this: 5 %.
SHORTEST_PX = 10.0


@dataclass(frozen=True)
class Ruler:
    """Two points of the picture (px, the frame's x right and y down) ``length_mm``
    apart in the plane of motion."""

    first_px: tuple[float, float]
    second_px: tuple[float, float]
    length_mm: float

    def span_px(self, pixel_aspect: float = 1.0) -> float:
        """The ends' distance in square pixels (px of height): x widened by the
        pixels' aspect."""
        dx = pixel_aspect * (self.second_px[0] - self.first_px[0])
        return float(np.hypot(dx, self.second_px[1] - self.first_px[1]))

    def text(self) -> str:
        """The ruler as ``--ruler`` takes it."""
        (x1, y1), (x2, y2) = self.first_px, self.second_px
        return f"{x1:g},{y1:g},{x2:g},{y2:g}={self.length_mm:g}"


def parse_ruler(text: str) -> Ruler:
    """Parse ``"120,40,620,42=500"`` (x1, y1, x2, y2 in px; the length in mm).

    >>> parse_ruler("120,40,620,42=500").length_mm
    500.0
    """
    form = (f"--ruler {text!r} is not of the form X1,Y1,X2,Y2=MM (the ends of a known "
            "length in the picture, px, and that length in mm), e.g. 120,40,620,40=500")
    try:
        ends, value = text.split("=")
        x1, y1, x2, y2 = (float(v) for v in ends.split(","))
        length = float(value)
    except ValueError:
        raise CranktrackError(form) from None
    if not all(np.isfinite([x1, y1, x2, y2])):
        raise CranktrackError(form)
    if not 0 < length < float("inf"):
        raise CranktrackError(f"--ruler {text!r}: the length must be a positive number of mm")
    ruler = Ruler((x1, y1), (x2, y2), length)
    if ruler.span_px() < SHORTEST_PX:
        raise CranktrackError(
            f"--ruler {text!r}: its ends are {ruler.span_px():.1f} px apart, too near to "
            f"give a scale (at least {SHORTEST_PX:g} px; the longer the better)")
    return ruler


def check_ruler_in_frame(ruler: Ruler, size: tuple[int, int]) -> None:
    """Refuse a ruler whose ends lie outside a ``size`` (width, height) frame."""
    width, height = size
    for x, y in (ruler.first_px, ruler.second_px):
        if not (0 <= x <= width - 1 and 0 <= y <= height - 1):
            raise CranktrackError(
                f"--ruler {ruler.text()}: the end ({x:g}, {y:g}) lies outside the "
                f"{width}x{height} frame (x from 0 to {width - 1}, y from 0 to {height - 1})")


def ruler_calibration(ruler: Ruler, image_size: tuple[int, int],
                      pixel_aspect: float = 1.0) -> PlaneCalibration:
    """The one-scale mapping ``ruler`` gives a frame of ``image_size`` (width, height):
    origin at its first end, +x along the image's x, +y up. ``mm_per_px`` is per pixel
    of height, as in :func:`.known_length.calibrate_known_length`; its relative σ is
    that of two ends each placed to :data:`END_SIGMA_PX`."""
    check_ruler_in_frame(ruler, image_size)
    span = ruler.span_px(pixel_aspect)
    mm_per_px = ruler.length_mm / span
    quality = {
        "mm_per_px": mm_per_px,
        **({} if pixel_aspect == 1.0 else {"pixel_aspect": pixel_aspect}),
        "scale_rel_sigma": float(np.hypot(END_SIGMA_PX, END_SIGMA_PX) / span),
        "origin_px": list(ruler.first_px),
        "x_axis_deg": 0.0,
        "ruler": ruler.text(),
        "ruler_px": span,
        "ruler_mm": ruler.length_mm,
    }
    square = np.diag([pixel_aspect, 1.0, 1.0])
    origin = (pixel_aspect * ruler.first_px[0], ruler.first_px[1])
    homography = similarity(mm_per_px, origin, 0.0) @ square
    return PlaneCalibration("ruler", homography, tuple(image_size), None, quality, ())
