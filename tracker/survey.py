"""A survey of one frame: every blob that could be a marker, and how to ask for it.

Before a first track on their own footage a user needs to know what the
tracker can see: which compact blobs of one colour, or of white or black,
the frame holds, where, how big, and what ``--marker`` would follow each.
:func:`survey` finds them with the tracker's own masks (so what it lists is
what ``track`` will find) over a ring of hues and the two luminance tones.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .markers import COLOUR_HUES_DEG, MarkerSpec, balanced_hsv, find_blobs, white_balance_gains

#: Hues searched, 30° apart, each ±20°: every hue falls in at least one window.
SURVEY_HUES_DEG = tuple(range(0, 360, 30))


def _colour_name(hue_deg: float) -> str:
    """The named colour nearest a hue (for the label only)."""
    def gap(h: float) -> float:
        return abs((hue_deg - h + 180.0) % 360.0 - 180.0)
    return min(COLOUR_HUES_DEG, key=lambda k: gap(COLOUR_HUES_DEG[k]))


def survey(rgb: NDArray[np.uint8], min_area_px: int = 12, most: int = 12) -> pd.DataFrame:
    """Candidate markers in an RGB frame, the most marker-like first.

    Returns a table with ``x_px``, ``y_px`` (blob centroid), ``radius_px`` (of a
    disc of the same area), ``fill`` (area over its box; π/4 for a disc),
    ``aspect``, ``strip`` (a strip or a square, centred by its coverage's centroid
    when tracked), ``colour`` (``white``, ``black`` or the hue in degrees,
    rounded), ``name`` (the nearest colour name, for people) and ``marker``: the
    ``--marker`` value that follows it, e.g. ``m1=120@312,99``. Blobs found in
    two overlapping hue windows are listed once; strips and streaks are kept
    (the tracker follows them too) but a round blob of a marker's size ranks higher.
    """
    gains = white_balance_gains(rgb)
    hsv = balanced_hsv(rgb, gains)
    rows = []
    specs = [MarkerSpec("", float(h), 20.0, min_area_px=min_area_px) for h in SURVEY_HUES_DEG]
    specs += [MarkerSpec.from_colour("", tone) for tone in ("white", "black")]
    for spec in specs:
        for b in find_blobs(hsv, spec):
            if b.area < min_area_px:
                continue
            if spec.tone:
                colour, name = spec.tone, spec.tone
            else:
                colour, name = f"{spec.hue_deg:.0f}", _colour_name(spec.hue_deg)
            rows.append({"x_px": b.x, "y_px": b.y, "radius_px": b.radius, "area_px": b.area,
                         "fill": b.fill, "aspect": b.aspect, "colour": colour, "name": name,
                         "disc_like": b.disc_like(), "strip": b.elongated()})
    table = pd.DataFrame(rows, columns=["x_px", "y_px", "radius_px", "area_px", "fill",
                                        "aspect", "colour", "name", "disc_like", "strip"])
    if table.empty:
        return table.assign(marker=pd.Series(dtype=str))
    # Most marker-like first: disc-like, of a marker's size (a hand or a sign is larger
    # than 25 px in radius), then the roundest. One row per place: the same blob seen
    # through two neighbouring hue windows is listed once.
    table["roundness"] = (np.abs(table["fill"] - np.pi / 4)
                          + np.abs(np.log(table["aspect"].clip(lower=1e-3))))
    table["too_big"] = table["radius_px"] > 25.0
    table = table.sort_values(["disc_like", "too_big", "roundness"],
                              ascending=[False, True, True])
    kept: list[int] = []
    for i, r in table.iterrows():
        if all(np.hypot(r.x_px - table.at[j, "x_px"], r.y_px - table.at[j, "y_px"])
               > max(r.radius_px, 2.0) for j in kept):
            kept.append(i)
    table = table.loc[kept].head(most).drop(columns=["roundness", "too_big"])
    table = table.reset_index(drop=True)
    table["marker"] = [f"m{k + 1}={r.colour}@{r.x_px:.0f},{r.y_px:.0f}"
                       for k, r in table.iterrows()]
    return table
