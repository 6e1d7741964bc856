"""The survey picture: one frame with every candidate marker outlined and labelled."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import CranktrackError
from ..files import write_text_atomic


def survey_image(rgb: NDArray[np.uint8], table: pd.DataFrame) -> NDArray[np.uint8]:
    """The frame (RGB) with each blob of ``table`` (:func:`cranktrack.tracker.survey.survey`)
    circled and labelled with its ``--marker`` value, its radius (px) and whether it
    moves; disc-like ones in yellow, strips and streaks in cyan."""
    img = np.ascontiguousarray(rgb).copy()
    scale = max(img.shape[1] / 800.0, 0.4)
    for _, r in table.iterrows():
        colour = (255, 220, 0) if r.disc_like else (0, 220, 255)
        centre = (round(r.x_px), round(r.y_px))
        cv2.circle(img, centre, round(r.radius_px * 1.6 + 3), colour, max(1, int(scale)),
                   cv2.LINE_AA)
        label = f"{r.marker}  r{r.radius_px:.0f}" + ("  moves" if r.get("moves", False) else "")
        at = (centre[0] + int(r.radius_px * 1.6 + 6), centre[1] + 4)
        cv2.putText(img, label, at, cv2.FONT_HERSHEY_SIMPLEX, 0.45 * scale, (0, 0, 0),
                    max(2, int(3 * scale)), cv2.LINE_AA)
        cv2.putText(img, label, at, cv2.FONT_HERSHEY_SIMPLEX, 0.45 * scale, colour,
                    max(1, int(scale)), cv2.LINE_AA)
    return img


def write_survey_png(path: Path, rgb: NDArray[np.uint8], table: pd.DataFrame) -> Path:
    """Write :func:`survey_image` as a PNG (atomically)."""
    ok, data = cv2.imencode(".png", cv2.cvtColor(survey_image(rgb, table), cv2.COLOR_RGB2BGR))
    if not ok:
        raise CranktrackError(f"could not encode the survey picture for {path}")
    return write_text_atomic(path, data.tobytes())
