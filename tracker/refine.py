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

Where every pixel has its own colour (RGB or 4:4:4 video, PNG images),
:func:`fit_edges` then refits the centre with the luminance of the edge's
clean sectors added (most of the information is there), sharing the
centre with the chroma coverage.

``bench/accuracy.py`` measures them against ``truth.csv`` and the
Cramér–Rao bound; ``bench/README.md`` says which won.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numba import njit
from numpy.typing import NDArray

#: Orthonormal basis of the chroma plane (rows), orthogonal to grey (1, 1, 1).
CHROMA_BASIS = np.array(
    [[1.0, -1.0, 0.0], [1.0, 1.0, -2.0]], dtype=np.float32
) / np.array([[np.sqrt(2.0)], [np.sqrt(6.0)]], dtype=np.float32)


#: The same basis in double precision, for the compiled coverage kernel.
_BASIS64 = CHROMA_BASIS.astype(np.float64)
#: A white or black marker has no chroma: it is unmixed on luminance alone (the
#: second axis is zero, so the kernel's plane collapses to a line).
LUMA_BASIS = np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]) / np.sqrt(3.0)


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
def _in_fit(a: float, dx: float, dy: float, reach2: float) -> bool:
    """Does a sample enter the disc fit: finite, within the window around the guess?"""
    return np.isfinite(a) and dx * dx + dy * dy <= reach2


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
            a, xv, yv = alpha[i, j], x0 + j, y0 + i
            if _in_fit(a, xv - gx, yv - gy, reach2):
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


@njit(cache=True, nogil=True)
def _sandwich_compiled(alpha: NDArray, x0: float, y0: float, gx: float, gy: float,
                       radius: float, p: NDArray, inv: NDArray, reach: int) -> float:
    """Per-axis variance of the centre with the residuals of samples up to
    ``reach`` apart taken as correlated (product Bartlett weights, which keep
    the estimate non-negative): Σ w·u_k·u_lᵀ over pairs of samples, where
    u_k = ((JᵀJ)⁻¹ J_kᵀ r_k) restricted to the centre. Same samples as the fit."""
    h, w = alpha.shape
    u = np.zeros((h, w, 2))
    used = np.zeros((h, w), np.bool_)
    reach2 = (radius + 3.0) ** 2
    jrow = np.empty(6)
    n = 0
    for i in range(h):
        for j in range(w):
            a, xv, yv = alpha[i, j], x0 + j, y0 + i
            if _in_fit(a, xv - gx, yv - gy, reach2):
                r = a - _disc_point(p, xv, yv, jrow)
                for c in range(2):
                    acc = 0.0
                    for k in range(6):
                        acc += inv[c, k] * jrow[k]
                    u[i, j, c] = acc * r
                used[i, j] = True
                n += 1
    if n < 7:
        return np.nan
    v = 0.0
    for i in range(h):
        for j in range(w):
            if not used[i, j]:
                continue
            v += u[i, j, 0] * u[i, j, 0] + u[i, j, 1] * u[i, j, 1]
            # Each pair once (the offsets after (0, 0) in reading order), twice over.
            for di in range(0, reach + 1):
                ii = i + di
                if ii >= h:
                    break
                for dj in range(-reach, reach + 1):
                    jj = j + dj
                    if (di == 0 and dj <= 0) or jj < 0 or jj >= w or not used[ii, jj]:
                        continue
                    weight = (1.0 - di / (reach + 1.0)) * (1.0 - abs(dj) / (reach + 1.0))
                    v += 2.0 * weight * (u[i, j, 0] * u[ii, jj, 0] + u[i, j, 1] * u[ii, jj, 1])
    return 0.5 * v * n / (n - 6)


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


#: Cells (2 px) over which a 4:2:0 frame's chroma residuals are taken as
#: correlated in :func:`fit_disc_cells`' σ. The codec quantizes chroma in
#: blocks, so neighbouring cells share errors; on the H.264 design renders the
#: still markers' σ came out the same within 10 % for reaches of 1, 2 and 3.
CELL_REACH = 2


@njit(cache=True, nogil=True)
def _cell_means(alpha: NDArray, ox: int, oy: int) -> NDArray:
    """Mean of each whole 2×2 cell from pixel (``ox``, ``oy``); a cell with a
    pixel outside the coverage window (NaN) is NaN, left out whole."""
    h, w = (alpha.shape[0] - oy) // 2, (alpha.shape[1] - ox) // 2
    out = np.empty((h, w))
    for i in range(h):
        for j in range(w):
            y, x = oy + 2 * i, ox + 2 * j
            out[i, j] = 0.25 * (alpha[y, x] + alpha[y, x + 1] + alpha[y + 1, x]
                                + alpha[y + 1, x + 1])
    return out


def fit_disc_cells(alpha: NDArray, x0: int, y0: int, pixel_fit: Centre) -> Centre:
    """The centre and σ of :func:`fit_disc` refitted at the chroma's own
    resolution, for 4:2:0 frames.

    A 4:2:0 frame stores one chroma sample per 2×2 pixel cell (cells start at
    even coordinates) and the reader repeats it over the cell, so the
    coverage is a staircase at the disc's edge. Fitted pixel by pixel, that
    staircase is misfit the smooth edge model cannot follow: on the H.264
    reference renders it made up most of the residual, and a still marker's σ
    was 1.2–1.7× its error. Here each cell's mean coverage is one sample at
    the cell's centre (pixel coordinate 2k + ½), where the model's blurred
    edge can follow it, and the σ lets cells up to :data:`CELL_REACH` apart
    share errors. ``alpha``'s top-left pixel is (``x0``, ``y0``).

    Starts from ``pixel_fit`` (within 0.02 px, as the tracker runs it) and
    keeps its shape, gain, residual and area, which the tracker's checks for
    a whole marker were set on; the pixel fit is returned as it is if the
    refit fails or lands implausibly far from it.
    """
    ox, oy = x0 % 2, y0 % 2
    cells = _cell_means(np.asarray(alpha, np.float64), ox, oy)
    cx0, cy0 = float((x0 + ox) // 2), float((y0 + oy) // 2)
    gx, gy = (pixel_fit.x - 0.5) / 2, (pixel_fit.y - 0.5) / 2
    r, s, gain, offset = pixel_fit.params[-4:]
    # The compiled kernels are called directly: this runs for every marker in
    # every 4:2:0 frame, and fit_disc's checks are the pixel fit's to make.
    p, inv, _, _, _, posdef = _fit_disc_compiled(
        cells, cx0, cy0, gx, gy, r / 2, np.array([gx, gy, r / 2, s / 2, gain, offset]), 8, 5e-4)
    if not posdef:
        return pixel_fit
    var = _sandwich_compiled(cells, cx0, cy0, gx, gy, r / 2, p, inv, CELL_REACH)
    x, y = 2 * p[0] + 0.5, 2 * p[1] + 0.5
    if not (np.isfinite(x) and np.isfinite(y) and var > 0 and np.hypot(
            x - pixel_fit.x, y - pixel_fit.y) <= max(0.5, 5.0 * pixel_fit.sigma)):
        return pixel_fit
    return replace(pixel_fit, x=float(x), y=float(y), sigma=2 * math.sqrt(var))


def local_coverage(patch_rgb: NDArray, x0: float, y0: float, centre: tuple[float, float],
                   radius: float, marker: NDArray | None = None, luminance: bool = False
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
    ``luminance`` unmixes brightness instead of chroma (a white or black marker).
    """
    known = marker is not None
    m = np.asarray(marker if known else (0.0, 0.0), np.float64)
    # The patch goes in as it is (a uint8 view of the frame): the kernel reads it
    # pixel by pixel, so a float copy per marker per frame would be wasted.
    alpha, seen = _coverage_compiled(np.asarray(patch_rgb),
                                     LUMA_BASIS if luminance else _BASIS64,
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


# Where each pixel stores its own colour (RGB, 4:4:4), the marker's edge is
# also seen in luminance, with most of the information about where it is
# (the Cramér–Rao bound for all channels is about half the chroma-only one).
# Luminance is blind to nothing, though: a grey link under the marker's edge
# changes it. So only edge sectors whose luminance is flat just outside and
# just inside the edge (and whose neighbours' is too: a link's side crosses
# the edge at an angle) are used, each with its own background and marker
# level, fitted jointly with the chroma coverage of the whole disc.

#: Angular sectors of the edge for the luminance part of :func:`fit_edges`.
EDGE_SECTORS = 24
_GH_NODES, _GH_WEIGHTS = np.polynomial.hermite.hermgauss(7)
#: Gauss–Hermite nodes (in units of the blur σ) and weights of a Gaussian average.
_GH_X = _GH_NODES * math.sqrt(2.0)
_GH_W = _GH_WEIGHTS / math.sqrt(math.pi)


@njit(cache=True, nogil=True)
def _area_step(t: float, a: float, b: float) -> tuple[float, float]:
    """Part of a unit pixel on the inner side of a straight edge whose signed distance
    from the pixel's centre is ``t`` (px) and whose normal is (±a, ±b); its t-derivative.

    The pixel's footprint across the edge is the convolution of two boxes of
    widths a and b: a trapezoid, whose integral is this piecewise quadratic.
    """
    w1, w2 = min(a, b), max(a, b)
    h = 0.5 * (a + b)
    x = -abs(t)
    if x <= -h:
        c, d = 0.0, 0.0
    elif x <= -h + w1:
        c, d = (x + h) ** 2 / (2.0 * w1 * w2), (x + h) / (w1 * w2)
    else:
        c, d = w1 / (2.0 * w2) + (x + h - w1) / w2, 1.0 / w2
    return (1.0 - c if t >= 0.0 else c), d


@njit(cache=True, nogil=True)
def _edge(t: float, a: float, b: float, s: float, gx: NDArray, gw: NDArray
          ) -> tuple[float, float, float]:
    """:func:`_area_step` blurred by a Gaussian of σ ``s`` px: value, d/dt, d/ds."""
    c = dt = ds = 0.0
    for i in range(gx.size):
        ci, di = _area_step(t + s * gx[i], a, b)
        c += gw[i] * ci
        dt += gw[i] * di
        ds += gw[i] * di * gx[i]
    return c, dt, ds


@njit(cache=True, nogil=True)
def _clean_sectors(lum: NDArray, X: NDArray, Y: NDArray, cx: float, cy: float, r: float,
                   sectors: int) -> NDArray:
    """Sectors whose luminance is flat just outside (r + 1.5…5 px) and inside (r − 4…2 px)
    the edge, and whose neighbours' is too: scatter at most twice the median sector's."""
    sd = np.zeros((2, sectors))
    for band in range(2):
        lo, hi = (r + 1.5, r + 5.0) if band == 0 else (r - 4.0, r - 2.0)
        n, s1, s2 = np.zeros(sectors), np.zeros(sectors), np.zeros(sectors)
        for i in range(lum.shape[0]):
            for j in range(lum.shape[1]):
                d = math.hypot(X[j] - cx, Y[i] - cy)
                if lo <= d <= hi:
                    k = int((math.atan2(Y[i] - cy, X[j] - cx) + math.pi)
                            / (2.0 * math.pi) * sectors) % sectors
                    n[k] += 1.0
                    s1[k] += lum[i, j]
                    s2[k] += lum[i, j] ** 2
        for k in range(sectors):
            sd[band, k] = (math.sqrt(max(s2[k] / n[k] - (s1[k] / n[k]) ** 2, 0.0))
                           if n[k] >= 3 else np.inf)
    dirty = np.zeros(sectors, np.bool_)
    for band in range(2):
        limit = max(2.0 * np.median(sd[band]), 1.5)
        for k in range(sectors):
            dirty[k] |= sd[band, k] > limit
    clean = np.empty(sectors, np.bool_)
    for k in range(sectors):
        clean[k] = not (dirty[k] or dirty[(k + 1) % sectors] or dirty[k - 1])
    return clean


@njit(cache=True, nogil=True)
def _fit_edges_compiled(rgb: NDArray, alpha: NDArray, x0: float, y0: float, p: NDArray,
                        radius: float, chroma_rms: float, sectors: int, gx: NDArray,
                        gw: NDArray, iterations: int) -> tuple[float, float, float, int]:
    """:func:`fit_edges`: (cx, cy, per-axis σ, sectors used); σ NaN when it failed."""
    h, w = alpha.shape
    X, Y = x0 + np.arange(w).astype(np.float64), y0 + np.arange(h).astype(np.float64)
    lum = np.empty((h, w))
    for i in range(h):
        for j in range(w):
            # The grey axis of the chroma basis: noise σ as one channel's.
            lum[i, j] = (float(rgb[i, j, 0]) + rgb[i, j, 1] + rgb[i, j, 2]) / math.sqrt(3.0)
    cx, cy, r = p[0], p[1], p[2]
    clean = _clean_sectors(lum, X, Y, cx, cy, r, sectors)
    slot = np.full(sectors, -1)
    m = 0
    for k in range(sectors):
        if clean[k]:
            slot[k] = m
            m += 1
    if m < 4:
        return cx, cy, np.nan, m
    # Pixels: chroma coverage over the disc (group −1), luminance of clean sectors' edges.
    n_max = 2 * h * w
    PX, PY, PV = np.empty(n_max), np.empty(n_max), np.empty(n_max)
    grp = np.empty(n_max, np.int64)
    n = nc = 0
    lev = np.zeros((2, m))
    cnt = np.zeros((2, m))
    for i in range(h):
        for j in range(w):
            d = math.hypot(X[j] - cx, Y[i] - cy)
            if np.isfinite(alpha[i, j]) and d <= radius + 3.0:
                PX[n], PY[n], PV[n], grp[n] = X[j], Y[i], alpha[i, j], -1
                n += 1
                nc += 1
            k = slot[int((math.atan2(Y[i] - cy, X[j] - cx) + math.pi)
                         / (2.0 * math.pi) * sectors) % sectors]
            if k >= 0 and r - 5.0 <= d <= r + 5.0:
                PX[n], PY[n], PV[n], grp[n] = X[j], Y[i], lum[i, j], k
                n += 1
                side = 0 if d > r else 1
                lev[side, k] += lum[i, j]
                cnt[side, k] += 1.0
    nl = n - nc
    P = 6 + 2 * m
    q = np.empty(P)
    q[0], q[1], q[2], q[3], q[4], q[5] = cx, cy, r, 0.3, p[4], p[5]
    for k in range(m):
        q[6 + k] = lev[0, k] / max(cnt[0, k], 1.0)
        q[6 + m + k] = lev[1, k] / max(cnt[1, k], 1.0)
    wc, wl = 1.0 / max(chroma_rms, 1e-4) ** 2, 1.0 / 2.5**2
    JtJ, Jtr = np.empty((P, P)), np.empty(P)
    idx = np.empty(6, np.int64)
    jr = np.empty(6)
    L = np.empty((P, P))
    for it in range(iterations):
        JtJ[:, :] = 0.0
        Jtr[:] = 0.0
        rss_c = rss_l = 0.0
        for u in range(n):
            dx, dy = PX[u] - q[0], PY[u] - q[1]
            d = math.sqrt(dx * dx + dy * dy) + 1e-9
            c, dt, ds = _edge(q[2] - d, abs(dx) / d, abs(dy) / d, q[3], gx, gw)
            k = grp[u]
            if k < 0:
                amp, base, wt = q[4], q[5], wc
                idx[4], idx[5] = 4, 5
                jr[4], jr[5] = c, 1.0
            else:
                base = q[6 + k]
                amp, wt = q[6 + m + k] - base, wl
                idx[4], idx[5] = 6 + k, 6 + m + k
                jr[4], jr[5] = 1.0 - c, c
            g = amp * dt
            idx[0], idx[1], idx[2], idx[3] = 0, 1, 2, 3
            jr[0], jr[1], jr[2], jr[3] = g * dx / d, g * dy / d, g, amp * ds
            res = PV[u] - (base + amp * c)
            if k < 0:
                rss_c += res * res
            else:
                rss_l += res * res
            for a_ in range(6):
                Jtr[idx[a_]] += wt * jr[a_] * res
                for b_ in range(6):
                    JtJ[idx[a_], idx[b_]] += wt * jr[a_] * jr[b_]
        if it in (2, 4):
            # Each group weighted by its own residual: chroma coverage and luminance
            # are in different units and carry different noise.
            wc = max(nc - 6, 1) / max(rss_c, 1e-12)
            wl = max(nl - 4 - 2 * m, 1) / max(rss_l, 1e-12)
        for a_ in range(P):
            JtJ[a_, a_] += 1e-9
        L, ok = _cholesky(JtJ)
        if not ok:
            return cx, cy, np.nan, m
        step = _cho_solve(L, Jtr)
        q = q + step
        q[3] = max(abs(q[3]), 0.05)
        if it > 4 and abs(step[0]) < 1e-4 and abs(step[1]) < 1e-4:
            break
    e = np.zeros(P)
    e[0] = 1.0
    v0 = _cho_solve(L, e)[0]
    e[0], e[1] = 0.0, 1.0
    v1 = _cho_solve(L, e)[1]
    var = 0.5 * (v0 + v1)
    if not (var >= 0.0 and np.isfinite(q[0]) and np.isfinite(q[1])):
        return cx, cy, np.nan, m
    return q[0], q[1], math.sqrt(var), m


def fit_edges(patch_rgb: NDArray, alpha: NDArray, x0: float, y0: float, chroma_fit: Centre,
              radius: float, sectors: int = EDGE_SECTORS, iterations: int = 16
              ) -> Centre | None:
    """Refine a chroma disc fit with the luminance of the edge's clean sectors.

    One weighted least-squares fit of the chroma coverage ``alpha`` over the
    disc (as :func:`fit_disc`) and of the luminance of the pixels within 5 px
    of the edge in sectors where the background and marker are flat, each
    such sector with its own background and marker level. Both share centre,
    radius and blur; the edge is a pixel's area on one side of a straight
    edge, blurred by a Gaussian (the erf edge of :func:`fit_disc` misses the
    area sampling by 1–4 thousandths of a pixel, which matters at this
    precision). Each group is weighted by its own residual variance, so σ
    comes out of the fit. For frames whose every pixel has its own colour;
    see :attr:`Frame.full_chroma`. Returns None (use the chroma fit) when
    fewer than 4 sectors are clean or the fit fails; shape fields (radius,
    gain, params, area) are the chroma fit's, to warm-start the next frame.
    """
    if chroma_fit.params is None or not chroma_fit.ok:
        return None
    x, y, sigma, _ = _fit_edges_compiled(
        np.asarray(patch_rgb), np.asarray(alpha, np.float64), float(x0), float(y0),
        np.asarray(chroma_fit.params, np.float64), float(radius),
        float(chroma_fit.rms_residual), int(sectors), _GH_X, _GH_W, int(iterations))
    # A joint fit far from the chroma one has been misled (something grey moved
    # under the edge after the sectors were chosen): trust the chroma fit.
    if not np.isfinite(sigma) or np.hypot(x - chroma_fit.x, y - chroma_fit.y) > max(
            0.5, 5.0 * chroma_fit.sigma):
        return None
    return Centre(float(x), float(y), float(sigma), chroma_fit.radius, True,
                  chroma_fit.rms_residual, chroma_fit.gain, chroma_fit.params, chroma_fit.area)
