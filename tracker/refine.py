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

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

#: Orthonormal basis of the chroma plane (rows), orthogonal to grey (1, 1, 1).
CHROMA_BASIS = np.array(
    [[1.0, -1.0, 0.0], [1.0, 1.0, -2.0]], dtype=np.float32
) / np.array([[np.sqrt(2.0)], [np.sqrt(6.0)]], dtype=np.float32)


#: The same basis in double precision, for the compiled coverage kernel.
_BASIS64 = CHROMA_BASIS.astype(np.float64)


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


# The per-marker work below runs on every frame for every marker, about a
# thousand pixels each time; as numpy it was ~1.5 ms per marker, mostly the
# overhead of many small array operations, which kept tracking slower than
# decoding. Compiled (numba), one pass over the pixels does each step, and
# ``nogil`` lets the decoder thread run beside it.

_SQRT_HALF = math.sqrt(0.5)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


@njit(cache=True, nogil=True)
def _disc_point(p: NDArray, x: float, y: float, jrow: NDArray) -> float:
    """Model value at one pixel; its gradient over (cx, cy, r, s, a, b) into ``jrow``."""
    dx, dy = x - p[0], y - p[1]
    d = math.sqrt(dx * dx + dy * dy) + 1e-9
    z = (p[2] - d) / p[3]
    phi = 0.5 * (1.0 + math.erf(z * _SQRT_HALF))
    g = (p[4] / p[3]) * _INV_SQRT_2PI * math.exp(-0.5 * z * z)  # a · dΦ/dz / s
    jrow[0] = g * dx / d
    jrow[1] = g * dy / d
    jrow[2] = g
    jrow[3] = -g * z
    jrow[4] = phi
    jrow[5] = 1.0
    return p[5] + p[4] * phi


@njit(cache=True, nogil=True)
def _normal_equations(p: NDArray, X: NDArray, Y: NDArray, A: NDArray, n: int,
                      JtJ: NDArray, Jtr: NDArray) -> float:
    """Fill JᵀJ and Jᵀr at ``p`` over the first ``n`` pixels; return the RSS."""
    jrow = np.empty(6)
    JtJ[:, :] = 0.0
    Jtr[:] = 0.0
    rss = 0.0
    for k in range(n):
        r = A[k] - _disc_point(p, X[k], Y[k], jrow)
        rss += r * r
        for i in range(6):
            Jtr[i] += jrow[i] * r
            for j in range(i + 1):
                JtJ[i, j] += jrow[i] * jrow[j]
    for i in range(6):
        for j in range(i):
            JtJ[j, i] = JtJ[i, j]
    return rss


@njit(cache=True, nogil=True)
def _cholesky(M: NDArray) -> tuple[NDArray, bool]:
    """Lower Cholesky factor of a symmetric matrix, and whether it is positive definite."""
    n = M.shape[0]
    L = np.zeros_like(M)
    for i in range(n):
        for j in range(i + 1):
            acc = M[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            if i == j:
                if not acc > 0.0:
                    return L, False
                L[i, i] = math.sqrt(acc)
            else:
                L[i, j] = acc / L[j, j]
    return L, True


@njit(cache=True, nogil=True)
def _cho_solve(L: NDArray, b: NDArray) -> NDArray:
    n = L.shape[0]
    y = np.empty(n)
    for i in range(n):
        acc = b[i]
        for k in range(i):
            acc -= L[i, k] * y[k]
        y[i] = acc / L[i, i]
    x = np.empty(n)
    for i in range(n - 1, -1, -1):
        acc = y[i]
        for k in range(i + 1, n):
            acc -= L[k, i] * x[k]
        x[i] = acc / L[i, i]
    return x


@njit(cache=True, nogil=True)
def _fit_disc_compiled(alpha: NDArray, x0: float, y0: float, gx: float, gy: float,
                       radius: float, p: NDArray, iterations: int, tol_px: float
                       ) -> tuple[NDArray, NDArray, float, int, float, bool]:
    """Gauss–Newton of :func:`fit_disc` from ``p``; returns (p, (JᵀJ)⁻¹, RSS,
    pixels used, Σα, whether JᵀJ was positive definite at the end)."""
    h, w = alpha.shape
    X, Y, A = np.empty(h * w), np.empty(h * w), np.empty(h * w)
    reach2 = (radius + 3.0) ** 2
    n = 0
    total = 0.0
    for i in range(h):
        for j in range(w):
            a = alpha[i, j]
            xv, yv = x0 + j, y0 + i
            if np.isfinite(a) and (xv - gx) ** 2 + (yv - gy) ** 2 <= reach2:
                X[n], Y[n], A[n] = xv, yv, a
                total += a
                n += 1
    JtJ, Jtr = np.empty((6, 6)), np.empty(6)
    inv = np.full((6, 6), np.nan)
    if n < 7:
        return p, inv, np.nan, n, total, False
    L = np.empty((6, 6))
    rss = np.nan
    for _ in range(iterations):
        rss = _normal_equations(p, X, Y, A, n, JtJ, Jtr)
        for i in range(6):
            JtJ[i, i] += 1e-9
        L, ok = _cholesky(JtJ)
        if not ok:
            return p, inv, np.nan, n, total, False
        step = _cho_solve(L, Jtr)
        p = p + step
        p[3] = max(p[3], 0.05)
        if abs(step[0]) < tol_px and abs(step[1]) < tol_px:
            break
    # The covariance uses the last pass's JᵀJ and RSS, taken before its step:
    # the step is under ``tol_px`` at convergence, so another pass over the
    # pixels (a third of a typical fit's time) would change them by its square.
    e = np.zeros(6)
    for k in range(6):
        e[:] = 0.0
        e[k] = 1.0
        inv[:, k] = _cho_solve(L, e)
    return p, inv, rss, n, total, True


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
    shape = (radius, 0.5, 1.0, 0.0) if init is None else tuple(init)[-4:]
    p0 = np.array([guess[0], guess[1], *shape], dtype=np.float64)
    p, inv, rss, n, total, posdef = _fit_disc_compiled(
        np.asarray(alpha, np.float64), float(x0), float(y0), float(guess[0]),
        float(guess[1]), float(radius), p0, int(iterations), float(tol_px))
    if not posdef:
        return Centre(np.nan, np.nan, np.nan, radius, False)
    s2 = rss / max(n - 6, 1)
    var = 0.5 * (inv[0, 0] + inv[1, 1]) * s2
    moved = np.hypot(p[0] - guess[0], p[1] - guess[1])
    ok = bool(np.all(np.isfinite(p)) and moved < radius and 0 < p[2] < 3 * radius
              and np.isfinite(var) and var >= 0)
    sigma = float(np.sqrt(var)) if np.isfinite(var) and var >= 0 else float("nan")
    return Centre(float(p[0]), float(p[1]), sigma, float(p[2]), ok, float(np.sqrt(s2)),
                  float(p[4]), tuple(float(v) for v in p), float(total))


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
    known = marker is not None
    m = np.asarray(marker if known else (0.0, 0.0), np.float64)
    # The patch goes in as it is (a uint8 view of the frame): the kernel reads it
    # pixel by pixel, so a float copy per marker per frame would be wasted.
    alpha, seen = _coverage_compiled(np.asarray(patch_rgb), _BASIS64,
                                     float(centre[0] - x0), float(centre[1] - y0),
                                     float(radius), m, known)
    return alpha, seen


@njit(cache=True, nogil=True)
def _bilinear(P: NDArray, x: float, y: float, out: NDArray) -> None:
    """Add P sampled at (x, y) (bilinear, edges replicated) to ``out`` (2,)."""
    h, w = P.shape[0], P.shape[1]
    x = min(max(x, 0.0), w - 1.0)
    y = min(max(y, 0.0), h - 1.0)
    i, j = min(int(y), h - 2), min(int(x), w - 2)
    fy, fx = y - i, x - j
    for c in range(2):
        out[c] += ((1 - fy) * ((1 - fx) * P[i, j, c] + fx * P[i, j + 1, c])
                   + fy * ((1 - fx) * P[i + 1, j, c] + fx * P[i + 1, j + 1, c]))


@njit(cache=True, nogil=True)
def _coverage_compiled(rgb: NDArray, basis: NDArray, cx: float, cy: float, radius: float,
                       marker: NDArray, known: bool) -> tuple[NDArray, NDArray]:
    """:func:`local_coverage` on an RGB patch (h, w, 3), centre in patch px."""
    h, w = rgb.shape[0], rgb.shape[1]
    P = np.empty((h, w, 2))
    for i in range(h):
        for j in range(w):
            for c in range(2):
                P[i, j, c] = (basis[c, 0] * rgb[i, j, 0] + basis[c, 1] * rgb[i, j, 1]
                              + basis[c, 2] * rgb[i, j, 2])
    inner_x, inner_y = np.empty(h * w), np.empty(h * w)
    n_inner = 0
    for i in range(h):
        for j in range(w):
            if math.hypot(j - cx, i - cy) + 1e-6 <= 0.6 * radius:
                inner_x[n_inner] = P[i, j, 0]
                inner_y[n_inner] = P[i, j, 1]
                n_inner += 1
    seen = np.empty(2)
    if n_inner >= 3:
        seen[0] = np.median(inner_x[:n_inner])
        seen[1] = np.median(inner_y[:n_inner])
    else:
        seen[0], seen[1] = P[h // 2, w // 2, 0], P[h // 2, w // 2, 1]
    m = marker if known else seen
    alpha = np.full((h, w), np.nan)
    b = np.empty(2)
    for i in range(h):
        for j in range(w):
            dx, dy = j - cx, i - cy
            rho = math.sqrt(dx * dx + dy * dy) + 1e-6
            if rho > radius + 2.0:
                continue
            ux, uy = dx / rho, dy / rho
            b[:] = 0.0
            for k in (3.0, 4.0, 5.0):
                _bilinear(P, cx + (radius + k) * ux, cy + (radius + k) * uy, b)
            b /= 3.0
            d0, d1 = m[0] - b[0], m[1] - b[1]
            denom = max(d0 * d0 + d1 * d1, 1e-6)
            alpha[i, j] = ((P[i, j, 0] - b[0]) * d0 + (P[i, j, 1] - b[1]) * d1) / denom
    return alpha, seen
