"""The edge refit: a chroma disc fit sharpened by the luminance of the edge's clean sectors.

Where every pixel has its own colour (RGB or 4:4:4 video, PNG images),
:func:`fit_edges` refits the centre with the luminance of the edge's clean
sectors added (most of the information is there), sharing the centre with
the chroma coverage.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .centre import Centre
from .disc import cho_solve, cholesky, is_round, rim_distance, stretch_of

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
                   sectors: int, mt: NDArray) -> NDArray:
    """Sectors whose luminance is flat just outside (r + 1.5…5 px) and inside (r − 4…2 px)
    the edge (distances under the disc's metric ``mt``, :func:`.disc.stretch_of`), and
    whose neighbours' is too: scatter at most twice the median sector's."""
    sd = np.zeros((2, sectors))
    for band in range(2):
        lo, hi = (r + 1.5, r + 5.0) if band == 0 else (r - 4.0, r - 2.0)
        n, s1, s2 = np.zeros(sectors), np.zeros(sectors), np.zeros(sectors)
        for i in range(lum.shape[0]):
            for j in range(lum.shape[1]):
                d = rim_distance(mt, X[j] - cx, Y[i] - cy)
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
                        gw: NDArray, iterations: int, mt: NDArray
                        ) -> tuple[float, float, float, int]:
    """:func:`fit_edges`: (cx, cy, per-axis σ, sectors used); σ NaN when it failed.
    ``mt``: the disc's metric (:func:`.disc.stretch_of`)."""
    round_ = is_round(mt)
    h, w = alpha.shape
    X, Y = x0 + np.arange(w).astype(np.float64), y0 + np.arange(h).astype(np.float64)
    lum = np.empty((h, w))
    for i in range(h):
        for j in range(w):
            # The grey axis of the chroma basis: noise σ as one channel's.
            lum[i, j] = (float(rgb[i, j, 0]) + rgb[i, j, 1] + rgb[i, j, 2]) / math.sqrt(3.0)
    cx, cy, r = p[0], p[1], p[2]
    clean = _clean_sectors(lum, X, Y, cx, cy, r, sectors, mt)
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
            d = rim_distance(mt, X[j] - cx, Y[i] - cy)
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
            if round_:
                d = math.sqrt(dx * dx + dy * dy) + 1e-9
                slope, nx, ny = 1.0, dx / d, dy / d
            else:
                # An ellipse: d is the metric's distance; the edge's normal is along
                # ∇d = G·(dx, dy)/d, and a pixel's distance from the edge in px is
                # (r − d)/|∇d| near it.
                ux, uy = mt[0] * dx + mt[1] * dy, mt[1] * dx + mt[2] * dy
                d = math.sqrt(max(dx * ux + dy * uy, 0.0)) + 1e-9
                norm = math.sqrt(ux * ux + uy * uy) + 1e-12
                slope, nx, ny = norm / d, ux / norm, uy / norm
            c, dt, ds = _edge((q[2] - d) / slope, abs(nx), abs(ny), q[3], gx, gw)
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
            jr[0], jr[1], jr[2], jr[3] = g * nx, g * ny, g / slope, amp * ds
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
        L, ok = cholesky(JtJ)
        if not ok:
            return cx, cy, np.nan, m
        step = cho_solve(L, Jtr)
        q = q + step
        q[3] = max(abs(q[3]), 0.05)
        if it > 4 and abs(step[0]) < 1e-4 and abs(step[1]) < 1e-4:
            break
    e = np.zeros(P)
    e[0] = 1.0
    v0 = cho_solve(L, e)[0]
    e[0], e[1] = 0.0, 1.0
    v1 = cho_solve(L, e)[1]
    var = 0.5 * (v0 + v1)
    if not (var >= 0.0 and np.isfinite(q[0]) and np.isfinite(q[1])):
        return cx, cy, np.nan, m
    return q[0], q[1], math.sqrt(var), m


def fit_edges(patch_rgb: NDArray, alpha: NDArray, x0: float, y0: float, chroma_fit: Centre,
              radius: float, sectors: int = EDGE_SECTORS, iterations: int = 16,
              stretch: tuple[float, float, float] | None = None) -> Centre | None:
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
    ``stretch``: the disc is the ellipse of that metric (:func:`.disc.stretch_of`), its
    edge a straight one along its normal there.
    """
    if chroma_fit.params is None or not chroma_fit.ok:
        return None
    x, y, sigma, _ = _fit_edges_compiled(
        np.asarray(patch_rgb), np.asarray(alpha, np.float64), float(x0), float(y0),
        np.asarray(chroma_fit.params, np.float64), float(radius),
        float(chroma_fit.rms_residual), int(sectors), _GH_X, _GH_W, int(iterations),
        stretch_of(stretch))
    # A joint fit far from the chroma one has been misled (something grey moved
    # under the edge after the sectors were chosen): trust the chroma fit.
    if not np.isfinite(sigma) or np.hypot(x - chroma_fit.x, y - chroma_fit.y) > max(
            0.5, 5.0 * chroma_fit.sigma):
        return None
    return Centre(float(x), float(y), float(sigma), chroma_fit.radius, True,
                  chroma_fit.rms_residual, chroma_fit.gain, chroma_fit.params, chroma_fit.area)
