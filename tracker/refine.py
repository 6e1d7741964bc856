"""Sub-pixel marker centres with a 1-σ uncertainty.

All methods work on a small patch around a coarse detection and on the
*chroma* of the pixels: RGB minus its grey component, in a 2-D basis of the
plane orthogonal to (1, 1, 1). Grey and near-neutral things (links, wire,
board, shadows that only darken) have almost no chroma, so a pixel that is a
mix ``α·marker + (1 − α)·grey`` has chroma ``α·marker_chroma`` whatever the
grey is. Projecting each pixel's chroma, minus the background's (sampled on a
ring just outside the marker, :func:`local_coverage`), on the marker's gives
the coverage ``α`` of each pixel, linear in the data.

Two estimators use that coverage image:

- :func:`weighted_centroid`: the α-weighted centroid inside a circular
  window re-centred on the estimate a few times.
- :func:`fit_disc`: least squares of a blurred-disc model
  ``α = b + a·Φ((r − d)/s)`` (centre, radius, edge width, gain, offset) by
  Gauss–Newton; σ from the residual and the Jacobian.

``bench/accuracy.py`` measures both against ``truth.csv`` and the
Cramér–Rao bound; ``bench/README.md`` says which won.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.special import erf

#: Orthonormal basis of the chroma plane (rows), orthogonal to grey (1, 1, 1).
CHROMA_BASIS = np.array(
    [[1.0, -1.0, 0.0], [1.0, 1.0, -2.0]], dtype=np.float32
) / np.array([[np.sqrt(2.0)], [np.sqrt(6.0)]], dtype=np.float32)


def chroma(rgb: NDArray) -> NDArray[np.float32]:
    """Chroma of RGB pixels, shape (..., 2), in DN."""
    return np.asarray(rgb, dtype=np.float32) @ CHROMA_BASIS.T


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


def _disc_model(params: NDArray, xx: NDArray, yy: NDArray, J: NDArray) -> NDArray:
    """Model values; fills the Jacobian ``J`` (n, 6) in place."""
    cx, cy, r, s, a, b = params
    dx, dy = xx - cx, yy - cy
    d = np.sqrt(dx * dx + dy * dy) + 1e-9
    z = (r - d) / s
    phi = 0.5 * (1.0 + erf(z * _SQRT_HALF))
    g = (a / s) * _INV_SQRT_2PI * np.exp(-0.5 * z * z)  # a · dΦ/dz / s
    gd = g / d
    J[:, 0] = gd * dx
    J[:, 1] = gd * dy
    J[:, 2] = g
    J[:, 3] = -g * z
    J[:, 4] = phi
    J[:, 5] = 1.0
    return b + a * phi


_SQRT_HALF = np.sqrt(0.5)
_INV_SQRT_2PI = 1.0 / np.sqrt(2.0 * np.pi)


def fit_disc(alpha: NDArray, x0: float, y0: float, guess: tuple[float, float],
             radius: float, iterations: int = 8, tol_px: float = 1e-3,
             init: tuple[float, ...] | None = None) -> Centre:
    """Gauss–Newton fit of a blurred disc to a coverage patch.

    The model is ``b + a·Φ((r − d)/s)`` with ``d`` the distance to the centre
    and ``Φ`` the normal CDF: a disc whose edge is blurred by a Gaussian of
    width ``s`` (area sampling gives s ≈ 0.3 px; H.264's chroma subsampling
    more). Only pixels within ``radius + 3`` px of the guess enter the fit.
    σ of the centre is ``√(RSS/(n−6) · (JᵀJ)⁻¹)``. ``init`` carries the
    previous frame's (r, s, a, b) (or a full parameter tuple) so the fit
    starts near its answer; it stops when the centre moves less than
    ``tol_px``.
    """
    h, w = alpha.shape
    xs = np.arange(w, dtype=np.float64) + x0
    ys = np.arange(h, dtype=np.float64) + y0
    alpha = np.asarray(alpha, np.float64)
    use = (((xs[None, :] - guess[0]) ** 2 + (ys[:, None] - guess[1]) ** 2 <= (radius + 3.0) ** 2)
           & np.isfinite(alpha))
    iy, ix = np.nonzero(use)
    X, Y, A = xs[ix], ys[iy], alpha[use]
    J = np.empty((A.size, 6))
    shape = (radius, 0.5, 1.0, 0.0) if init is None else tuple(init)[-4:]
    p = np.array([guess[0], guess[1], *shape], dtype=np.float64)
    for _ in range(iterations):
        res = A - _disc_model(p, X, Y, J)
        JtJ = J.T @ J
        try:
            step = np.linalg.solve(JtJ + 1e-9 * np.eye(6), J.T @ res)
        except np.linalg.LinAlgError:
            return Centre(np.nan, np.nan, np.nan, radius, False)
        p = p + step
        p[3] = max(p[3], 0.05)
        if abs(step[0]) < tol_px and abs(step[1]) < tol_px:
            break
    res = A - _disc_model(p, X, Y, J)
    dof = max(A.size - 6, 1)
    s2 = float(res @ res) / dof
    try:
        cov = np.linalg.inv(J.T @ J) * s2
    except np.linalg.LinAlgError:
        return Centre(np.nan, np.nan, np.nan, radius, False)
    moved = np.hypot(p[0] - guess[0], p[1] - guess[1])
    var = 0.5 * (cov[0, 0] + cov[1, 1])
    # A near-singular fit can invert to a negative variance: no centre can be trusted then.
    well_posed = bool(np.isfinite(var) and var >= 0)
    ok = bool(np.all(np.isfinite(p)) and moved < radius and 0 < p[2] < 3 * radius
              and well_posed)
    sigma = float(np.sqrt(var)) if well_posed else float("nan")
    return Centre(float(p[0]), float(p[1]), sigma, float(p[2]), ok, float(np.sqrt(s2)),
                  float(p[4]), tuple(float(v) for v in p), float(A.sum()))


def local_coverage(patch_rgb: NDArray, x0: float, y0: float, centre: tuple[float, float],
                   radius: float, marker: NDArray | None = None
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Coverage α by unmixing chroma against a per-pixel background.

    Each pixel within ``radius + 2`` px of ``centre`` is unmixed as
    ``q = α·m + (1 − α)·b`` in the chroma plane, where ``m`` is the marker's
    chroma and ``b`` the background's along the same ray from the centre,
    sampled just outside the disc (``radius`` + 3…5 px). Links and the wire
    leave a marker radially, so the sample sees what lies under the marker's
    edge; uneven light is followed too. Pixels farther out are NaN.

    ``marker`` is the learned marker chroma; without it the median chroma of
    the pixels within 0.6·radius is used (only right when the marker is
    known to be there: at acquisition).

    Returns ``(alpha, marker_chroma_seen)``: the second is the median chroma
    of the middle of the patch, for following slow colour drift.
    """
    P = np.ascontiguousarray(chroma(patch_rgb))
    h, w = P.shape[:2]
    dx = (np.arange(w, dtype=np.float32) + np.float32(x0 - centre[0]))[None, :]
    dy = (np.arange(h, dtype=np.float32) + np.float32(y0 - centre[1]))[:, None]
    rho = np.sqrt(dx * dx + dy * dy) + np.float32(1e-6)
    inner = rho <= 0.6 * radius
    seen = np.median(P[inner], axis=0) if inner.sum() >= 3 else P[int(h / 2), int(w / 2)]
    m = seen if marker is None else np.asarray(marker, np.float32)
    ux, uy = dx / rho, dy / rho
    cx, cy = np.float32(centre[0] - x0), np.float32(centre[1] - y0)
    # One remap samples the three ring radii, laid side by side.
    ks = np.array([3.0, 4.0, 5.0], dtype=np.float32)[:, None, None] + np.float32(radius)
    mx = np.concatenate(list(cx + ks * ux), axis=1)
    my = np.concatenate(list(cy + ks * uy), axis=1)
    ring = cv2.remap(P, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    b = (ring[:, :w] + ring[:, w : 2 * w] + ring[:, 2 * w :]) / np.float32(3.0)
    d = m[None, None, :] - b
    denom = (d * d).sum(axis=-1)
    alpha = ((P - b) * d).sum(axis=-1) / np.maximum(denom, 1e-6)
    alpha = alpha.astype(np.float64)
    alpha[rho > radius + 2.0] = np.nan
    return alpha, seen
