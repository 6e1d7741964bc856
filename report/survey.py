"""The survey picture: one frame with every candidate marker outlined and labelled."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import CranktrackError
from ..files import write_text_atomic


def survey_image(rgb: NDArray[np.uint8], table: pd.DataFrame,
                 placed: Sequence[tuple[str, float, float, float]] = ()
                 ) -> NDArray[np.uint8]:
    """The frame (RGB) with each blob of ``table`` (:func:`cranktrack.tracker.survey.survey`)
    circled and labelled with its ``--marker`` value, its radius (px) and whether it
    moves; disc-like ones in yellow, strips and streaks in cyan. A pixel scale runs
    along the top and left edges (:func:`_pixel_scale`). A part of a larger
    blob (``on``) is labelled with its ``m…`` alone. ``placed``: template markers the
    user placed (label, x, y, radius px), each drawn at its radius in magenta. Each
    label lies inside the frame and clear of those before it, beside its circle where
    there is room."""
    img = np.ascontiguousarray(rgb).copy()
    h, w = img.shape[:2]
    scale = max(w / 800.0, 0.4)
    font, size = cv2.FONT_HERSHEY_SIMPLEX, 0.45 * scale
    thick = max(2, int(3 * scale))
    taken = _pixel_scale(img, font, size, thick, scale)
    for label, x, y, radius in placed:
        centre, ring, colour = (round(x), round(y)), max(round(radius), 1), (255, 0, 255)
        cv2.circle(img, centre, ring, colour, max(1, int(scale)), cv2.LINE_AA)
        cv2.drawMarker(img, centre, colour, cv2.MARKER_CROSS, max(5, ring // 4),
                       max(1, int(scale)))
        (tw, th), base = cv2.getTextSize(label, font, size, thick)
        box = _label_box(centre, ring, tw, th + base, w, h, taken)
        taken.append(box)
        cv2.putText(img, label, (box[0], box[1] + th), font, size, (0, 0, 0), thick,
                    cv2.LINE_AA)
        cv2.putText(img, label, (box[0], box[1] + th), font, size, colour, max(1, int(scale)),
                    cv2.LINE_AA)
    for _, r in table.iterrows():
        colour = (255, 220, 0) if r.disc_like else (0, 220, 255)
        centre = (round(r.x_px), round(r.y_px))
        ring = round(r.radius_px * 1.6 + 3)
        cv2.circle(img, centre, ring, colour, max(1, int(scale)), cv2.LINE_AA)
        if r.get("on", ""):
            label = r.marker.split("=")[0]
        else:
            label = (f"{r.marker}  r{r.radius_px:.0f}"
                     + ("  moves" if r.get("moves", False) else ""))
        (tw, th), base = cv2.getTextSize(label, font, size, thick)
        box = _label_box(centre, ring, tw, th + base, w, h, taken)
        taken.append(box)
        at = (box[0], box[1] + th)
        cv2.putText(img, label, at, font, size, (0, 0, 0), thick, cv2.LINE_AA)
        cv2.putText(img, label, at, font, size, colour, max(1, int(scale)), cv2.LINE_AA)
    return img


#: The survey picture's pixel scale along its top and left edges: a tick every
#: TICK_PX, a longer one every 5, numbered every NUMBER_PX (frame px).
TICK_PX = 10
NUMBER_PX = 100


def _pixel_scale(img: NDArray[np.uint8], font: int, size: float, thick: int,
                 scale: float) -> list[tuple[int, int, int, int]]:
    """Draw a pixel scale along ``img``'s top and left edges, in place: what a user reads
    a ruler's ends (``--ruler X1,Y1,X2,Y2=MM``) or a template's place off. The picture
    keeps the frame's size, so its pixels are the frame's. Returns the numbers' boxes,
    which the markers' labels keep clear of."""
    h, w = img.shape[:2]
    colour, line = (230, 230, 230), max(1, int(scale))
    boxes = []
    for axis, extent in ((0, w), (1, h)):
        for at in range(TICK_PX, extent, TICK_PX):
            reach = 4 if at % (5 * TICK_PX) else 8
            a, b = ((at, 0), (at, reach)) if axis == 0 else ((0, at), (reach, at))
            cv2.line(img, a, b, colour, line)
            if at % NUMBER_PX:
                continue
            text = str(at)
            (tw, th), base = cv2.getTextSize(text, font, 0.8 * size, 1)
            x, y = (at + 2, 10 + th) if axis == 0 else (10, at + th // 2)
            if x + tw >= w or y >= h:
                continue
            cv2.putText(img, text, (x, y), font, 0.8 * size, (0, 0, 0), thick, cv2.LINE_AA)
            cv2.putText(img, text, (x, y), font, 0.8 * size, colour, 1, cv2.LINE_AA)
            boxes.append((x, y - th, x + tw, y + base))
    return boxes


def _label_box(centre: tuple[int, int], ring: int, tw: int, th: int, w: int, h: int,
               taken: list[tuple[int, int, int, int]]) -> tuple[int, int, int, int]:
    """Where a label ``tw`` × ``th`` px goes (left, top, right, bottom): right of its
    circle, else left of it, clamped into the ``w`` × ``h`` frame, and moved down (then
    up) a line at a time until it overlaps none of ``taken``."""
    x = centre[0] + ring + 3
    if x + tw > w:
        x = centre[0] - ring - 3 - tw
    x = int(min(max(x, 0), max(w - tw, 0)))
    y0 = int(min(max(centre[1] - th // 2, 0), max(h - th, 0)))

    def clear(y: int) -> bool:
        return all(x >= b[2] or x + tw <= b[0] or y >= b[3] or y + th <= b[1] for b in taken)

    for step in range(0, h // max(th, 1) + 1):
        for y in (y0 + step * th, y0 - step * th):
            if 0 <= y <= h - th and clear(y):
                return x, y, x + tw, y + th
    return x, y0, x + tw, y0 + th


def write_survey_png(path: Path, rgb: NDArray[np.uint8], table: pd.DataFrame,
                     placed: Sequence[tuple[str, float, float, float]] = ()) -> Path:
    """Write :func:`survey_image` as a PNG (atomically)."""
    ok, data = cv2.imencode(".png", cv2.cvtColor(survey_image(rgb, table, placed),
                                                 cv2.COLOR_RGB2BGR))
    if not ok:
        raise CranktrackError(f"could not encode the survey picture for {path}")
    return write_text_atomic(path, data.tobytes())
