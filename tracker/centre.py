"""A marker's refined centre (px) with its 1-σ, and the simplest estimator of it."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numba import njit
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
    #: Half the length and half the width of a blob (:func:`blob_centroid`), px, from
    #: the second moments of its coverage (√3·σ along each principal axis: exact for
    #: a strip, 0.87 of the radius for a disc).
    length_px: float = np.nan
    width_px: float = np.nan
    #: Skewness of a blob's coverage along its length (:func:`blob_centroid`): ≈ 0
    #: for a strip or a streak, large for a ball with a stalk.
    skew: float = np.nan
    #: The 90th percentile of α within 0.6 of the fitted radius: ≈ 1 for a marker
    #: at its learned brightness, covered or not; lower for one dimmed as a whole.
    peak: float = np.nan


#: A guess this far (px) or more from its patch cannot have a window on it.
LOST_GUESS_PX = 1e6


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
    cx, cy = guess
    if not (abs(cx - x0) < LOST_GUESS_PX and abs(cy - y0) < LOST_GUESS_PX):
        # A guess from a damaged frame can lie beyond float32's range (the window
        # below would be empty anyway, with an overflow warning on the way).
        return Centre(np.nan, np.nan, np.nan, radius, False)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    xx += x0
    yy += y0
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


#: Coverage above which a pixel belongs to the blob's core, and how far (px) the
#: core is widened to take in its blurred edge.
CORE_ALPHA = 0.5
EDGE_PX = 2
#: Coverage is taken within these bounds (see :func:`blob_centroid`).
ALPHA_CLIP = (-1.0, 2.0)


def blob_centroid(alpha: NDArray, x0: float, y0: float, guess: tuple[float, float],
                  reach_px: float) -> Centre:
    """The α-weighted centroid of a compact blob of any shape (a strip of tape, a
    square, a motion-blurred streak), with its 1-σ from the noise of α.

    The blob is the connected region of α > :data:`CORE_ALPHA` that holds the
    largest α within ``reach_px`` of ``guess``, widened by :data:`EDGE_PX` to take
    in its edge; a separate thing beside it (a paper clip, a neighbour) is left
    out. The first moment of the coverage is the blob's centre whatever its shape,
    and for a streak the middle of the exposure (the blur is a convolution, which
    moves no centroid).

    Parameters
    ----------
    alpha : ndarray (h, w)
        Coverage image of the patch (NaN where not computed).
    x0, y0 : float
        Image coordinates of the patch's top-left pixel centre.
    guess : (x, y)
        Where the blob should be, image px.
    reach_px : float
        How far from ``guess`` its core may lie, px.

    Returns
    -------
    Centre
        ``sigma`` the larger of the two axes' 1-σ (px), from the scatter of α
        outside the blob; ``radius`` that of a disc of the same area Σα (px);
        ``area`` Σα (px²); ``gain`` the 90th percentile of α over the core (≈ 1 for
        a marker of the learned colour seen whole and sharp); no fit residual.
    """
    h, w = alpha.shape
    yy, xx = np.mgrid[0:h, 0:w]
    finite = np.isfinite(alpha)
    # Where a ray's background sample fell on something as bright as the marker (a
    # neighbour, a bar), the unmixing divides by almost nothing (α of ±1000 seen on
    # a real clip): such a pixel says only "marker-like or not".
    a = np.clip(np.where(finite, alpha, 0.0), ALPHA_CLIP[0], ALPHA_CLIP[1])
    near = finite & ((xx + x0 - guess[0]) ** 2 + (yy + y0 - guess[1]) ** 2 <= reach_px**2)
    if not near.any():
        return Centre(np.nan, np.nan, np.nan, np.nan, False)
    seed = np.unravel_index(int(np.argmax(np.where(near, a, -np.inf))), a.shape)
    if a[seed] <= CORE_ALPHA:
        return Centre(np.nan, np.nan, np.nan, np.nan, False)
    _, labels = cv2.connectedComponents((a > CORE_ALPHA).astype(np.uint8), connectivity=8)
    core = labels == labels[seed]
    kernel = np.ones((2 * EDGE_PX + 1, 2 * EDGE_PX + 1), np.uint8)
    blob = (cv2.dilate(core.astype(np.uint8), kernel) > 0) & finite
    total = float(a[blob].sum())
    outside = finite & ~blob
    if not total > 0 or outside.sum() < 10 or blob.all():
        return Centre(np.nan, np.nan, np.nan, np.nan, False)
    cx = float((a[blob] * xx[blob]).sum() / total)
    cy = float((a[blob] * yy[blob]).sum() / total)
    noise = float(np.std(a[outside]))
    dx, dy = xx[blob] - cx, yy[blob] - cy
    var_x = float((dx**2).sum()) * noise**2 / total**2
    var_y = float((dy**2).sum()) * noise**2 / total**2
    weight = a[blob] / total
    moments = np.array([[(weight * dx * dx).sum(), (weight * dx * dy).sum()],
                        [(weight * dx * dy).sum(), (weight * dy * dy).sum()]])
    variances, axes = np.linalg.eigh(moments)
    lo, hi = np.sqrt(3.0 * np.clip(variances, 0.0, None))
    along = dx * axes[0, 1] + dy * axes[1, 1]
    skew = float((weight * along**3).sum() / max(variances[1], 1e-12) ** 1.5)
    return Centre(cx + x0, cy + y0, float(np.sqrt(max(var_x, var_y))),
                  float(np.sqrt(total / np.pi)), True, gain=float(np.percentile(a[core], 90)),
                  area=total, length_px=float(hi), width_px=float(lo), skew=skew)


def core_peak(alpha: NDArray, x0: float, y0: float, centre: Centre) -> float:
    """The 90th percentile of α within 0.6 radius of ``centre`` (the patch's top-left
    pixel at image ``x0``, ``y0``); NaN where no pixel is that close."""
    return _core_peak(np.asarray(alpha, np.float64), centre.x - x0, centre.y - y0,
                      0.6 * centre.radius)


@njit(cache=True, nogil=True)
def _core_peak(alpha: NDArray, cx: float, cy: float, reach: float) -> float:
    # Compiled: it runs for every disc marker on every frame (numpy's percentile
    # on a few dozen pixels cost 0.1 ms).
    h, w = alpha.shape
    values = np.empty(h * w)
    n = 0
    for i in range(max(int(cy - reach), 0), min(int(cy + reach) + 2, h)):
        for j in range(max(int(cx - reach), 0), min(int(cx + reach) + 2, w)):
            if (j - cx) ** 2 + (i - cy) ** 2 <= reach * reach:
                values[n] = alpha[i, j]
                n += 1
    if n == 0:
        return np.nan
    # The one order statistic, not a whole sort (4,000 pixels for a marker of radius
    # 60 px, about 5 % of tracking there). NaN (a wire's band left out) ranks last in
    # both, and the value is the same (3,000 random draws with NaN, a scratch check).
    k = int(0.9 * (n - 1))
    return np.partition(values[:n], k)[k]
