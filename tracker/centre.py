"""A marker's refined centre (px) with its 1-σ, and the simplest estimator of it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Centre:
    """A refined centre (px), its per-axis 1-σ (px), radius (px) and fit quality."""

    x: float
    y: float
    sigma: float
    radius: float
    ok: bool
    rms_residual: float = np.nan
    #: Fitted coverage gain: ≈ 1 for a whole marker of the learned colour.
    gain: float = np.nan
    #: All fitted parameters (cx, cy, r, s, a, b), to warm-start the next frame.
    params: tuple[float, ...] | None = None
    #: Σα over the fit window, px²: the visible marker area, whatever the fit's
    #: radius/blur/gain trade-off (a partly covered marker shows less).
    area: float = np.nan
    #: The circle through the rim (:mod:`.outline`), not the disc fit: its robust
    #: fit has already weighed out what covers or sticks to the marker.
    rim: bool = False


def weighted_centroid(alpha: NDArray, x0: float, y0: float, guess: tuple[float, float],
                      radius: float, iterations: int = 3, noise_alpha: float | None = None
                      ) -> Centre:
    """α-weighted centroid in a circular window of ``radius`` + 2 px.

    Parameters
    ----------
    alpha : ndarray (h, w)
        Coverage image of the patch.
    x0, y0 : float
        Image coordinates of the patch's top-left pixel centre.
    guess : (x, y)
        Starting centre, image px.
    radius : float
        Expected marker radius, px.
    noise_alpha : float, optional
        1-σ of α per pixel; estimated from outside the window when omitted.
    """
    h, w = alpha.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    xx += x0
    yy += y0
    cx, cy = guess
    win_r = radius + 2.0
    for _ in range(iterations):
        win = ((xx - cx) ** 2 + (yy - cy) ** 2 <= win_r**2) & np.isfinite(alpha)
        a = alpha[win]
        total = float(a.sum())
        if not total > 0:
            return Centre(np.nan, np.nan, np.nan, radius, False)
        cx = float((a * xx[win]).sum() / total)
        cy = float((a * yy[win]).sum() / total)
    if noise_alpha is None:
        outside = alpha[((xx - cx) ** 2 + (yy - cy) ** 2 > (radius + 3.0) ** 2)
                        & np.isfinite(alpha)]
        noise_alpha = float(np.std(outside)) if outside.size > 10 else 0.05
    var = float(((xx[win] - cx) ** 2).sum()) * noise_alpha**2 / total**2
    return Centre(cx, cy, float(np.sqrt(var)), float(np.sqrt(total / np.pi)), True)
