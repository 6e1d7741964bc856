"""A marker's outline: the circle through the rim of a ball, a shaded sphere or a
disc with something attached to it.

The blurred-disc fit of :mod:`.refine` expects a flat disc of one coverage. Real
markers often are not: a ball or a rendered sphere is shaded, so its coverage
falls from the middle to the rim; a bead on a string or an atom on a bond has a
stalk of its own colour leaving it. There the disc fit fails or wanders, yet the
rim is still a circle over most of its length.

This finds the rim along rays from the centre, where the coverage falls most
steeply (sub-pixel, a mean weighted by the fall), and fits a circle to those rim
points by iteratively reweighted least squares with Tukey's biweight: rays that
run out along a stalk or stop short at something in front are weighed out. σ of
the centre is the fit's own covariance, with the rays' spacing chosen so that
neighbouring rim points do not share the same pixels (about 2 px apart).
"""

from __future__ import annotations

import math
from functools import lru_cache

import cv2
import numpy as np
from numba import njit
from numpy.typing import NDArray

from .centre import Centre
from .coverage import CHROMA_BASIS, LUMA_BASIS

#: Tukey biweight tuning constant (95 % efficiency for Gaussian residuals).
TUKEY_C = 4.685
#: Smallest scale of the rim residuals used for weighting, px (a rim from a
#: clean render can fit to ~0.01 px, which would weigh out sound rays).
MIN_SCALE_PX = 0.15
#: Rays are cast again from the fitted centre only when it is this far (px) from
#: where they were cast: nearer, each ray still crosses the rim within a few
#: degrees of square, and the fall it finds is in the same place.
RECAST_PX = 1.0
#: Fewest rim points kept for a fit to be trusted, and the fraction of rays.
MIN_POINTS = 8
MIN_FRACTION = 0.4


def rim_coverage(patch_rgb: NDArray, x0: float, y0: float, centre: tuple[float, float],
                 radius: float, marker: NDArray | None = None, luminance: bool = False,
                 unit_px: float = 1.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Coverage of a patch by the marker's colour against one background: the median
    colour on the ring ``radius`` + 3…5 px from ``centre`` (image px).

    The disc fit's coverage (:func:`.coverage.local_coverage`) takes a background
    per ray, which follows uneven light but takes a stalk of the marker's own
    colour lying under the ring for the background and loses that quarter of
    the rim. The rim needs only where the colour ends, so one background, a
    median that a stalk does not move, serves. ``marker`` is the learned marker
    colour (chroma; luminance for ``luminance``), else the median of the
    middle 0.6·``radius``. Every pixel of the patch gets a value. Returns
    ``(alpha, seen)``: ``seen`` is that median of the middle (as
    :func:`.coverage.local_coverage` gives it), for following slow colour drift.
    ``unit_px``: the frame px one of the patch's pixels spans, as for
    :func:`.coverage.local_coverage` (the ring stays 3…5 frame px out).
    """
    basis = LUMA_BASIS if luminance else CHROMA_BASIS.astype(np.float64)
    given = np.empty(0) if marker is None else np.asarray(marker, np.float64)
    return _rim_coverage(np.ascontiguousarray(patch_rgb, np.float64), basis,
                         centre[0] - x0, centre[1] - y0, float(radius), given,
                         float(unit_px))


@njit(cache=True, nogil=True)
def _rim_coverage(patch: NDArray, basis: NDArray, cx: float, cy: float, radius: float,
                  marker: NDArray, unit: float) -> tuple[NDArray, NDArray]:
    """:func:`rim_coverage` on a patch (centre in patch px, each ``unit`` frame px;
    ``marker`` empty when not known). Compiled: in NumPy its many small steps cost a
    third of a large ball's rim fit."""
    h, w = patch.shape[0], patch.shape[1]
    k = basis.shape[0]
    P = np.empty((h, w, k))
    ring_n = 0
    middle_n = 0
    inner2, outer2 = (radius + 3 / unit) ** 2, (radius + 5 / unit) ** 2
    mid2 = (0.6 * radius) ** 2
    for i in range(h):
        for j in range(w):
            for c in range(k):
                P[i, j, c] = (patch[i, j, 0] * basis[c, 0] + patch[i, j, 1] * basis[c, 1]
                              + patch[i, j, 2] * basis[c, 2])
            r2 = (j - cx) ** 2 + (i - cy) ** 2
            if inner2 <= r2 <= outer2:
                ring_n += 1
            if r2 <= mid2:
                middle_n += 1
    ring = np.empty((k, ring_n))
    middle = np.empty((k, middle_n))
    a = 0
    b = 0
    for i in range(h):
        for j in range(w):
            r2 = (j - cx) ** 2 + (i - cy) ** 2
            if inner2 <= r2 <= outer2:
                for c in range(k):
                    ring[c, a] = P[i, j, c]
                a += 1
            if r2 <= mid2:
                for c in range(k):
                    middle[c, b] = P[i, j, c]
                b += 1
    seen = np.empty(k)
    for c in range(k):
        seen[c] = np.median(middle[c]) if middle_n >= 3 else P[h // 2, w // 2, c]
    alpha = np.full((h, w), np.nan)
    if ring_n < 8 or middle_n < 3:
        return alpha, seen
    back = np.empty(k)
    for c in range(k):
        back[c] = np.median(ring[c])
    m = marker if marker.size == k else seen
    d = m - back
    dd = max(np.sum(d * d), 1e-6)
    for i in range(h):
        for j in range(w):
            v = 0.0
            for c in range(k):
                v += (P[i, j, c] - back[c]) * d[c]
            alpha[i, j] = v / dd
    return alpha, seen


def middle_peak(alpha: NDArray, x0: float, y0: float, centre: tuple[float, float],
                radius: float) -> float:
    """The coverage in a marker's middle: the 90th percentile of α within
    0.7·``radius`` of ``centre`` (image px); NaN with fewer than 3 pixels there."""
    return _quantile_within(alpha, centre[0] - x0, centre[1] - y0, 0.7 * radius, 0.9, 3)


@njit(cache=True, nogil=True)
def _quantile_within(alpha: NDArray, cx: float, cy: float, reach: float, q: float,
                     fewest: int) -> float:
    """The ``q`` quantile (linear, as np.quantile) of the finite α within ``reach`` px of
    (cx, cy) (patch px); NaN with fewer than ``fewest`` values. Compiled: the masks and
    the sort in NumPy cost a fifth of a large ball's rim fit."""
    h, w = alpha.shape
    values = np.empty(h * w)
    n = 0
    for i in range(h):
        for j in range(w):
            if (j - cx) ** 2 + (i - cy) ** 2 <= reach * reach and np.isfinite(alpha[i, j]):
                values[n] = alpha[i, j]
                n += 1
    if n < fewest:
        return np.nan
    return np.quantile(values[:n], q)


def rim_points(alpha: NDArray, x0: float, y0: float, centre: tuple[float, float],
               radius: float, rays: int, peak: float) -> NDArray[np.float64]:
    """Where each of ``rays`` rays from ``centre`` crosses the marker's rim.

    Each ray is sampled every 0.25 px out to where α stops being defined. The
    rim is the outermost place where α falls steeply: the drop over 2 px is at
    least 0.6 of the ray's largest and at least 0.15 of the coverage in the
    marker's middle (the 90th percentile of α within 0.7·``radius``). A shaded
    ball's dark side falls from little coverage to none, its highlight dips
    inside: a fixed level would put the rim inside on one and at the dip on
    the other, the steepest fall does not. The place is the drop-weighted mean
    over ±1 px around that fall. ``peak`` is that middle's coverage
    (:func:`middle_peak`). Returns (k, 2) image px; rays with no such fall are
    left out.
    """
    cx, cy = centre[0] - x0, centre[1] - y0
    reach, dx, dy = _ray_grid(rays, math.ceil(4 * (2.0 * radius + 4.0)))
    return _rim_points(np.asarray(alpha, np.float32), float(x0), float(y0), cx, cy, dx, dy,
                       reach, float(peak))


@njit(cache=True, nogil=True)
def _rim_points(alpha: NDArray, x0: float, y0: float, cx: float, cy: float, dx: NDArray,
                dy: NDArray, reach: NDArray, peak: float) -> NDArray:
    """:func:`rim_points` on a float32 coverage patch, the centre (``cx``, ``cy``) in
    patch px, the rays :func:`_ray_grid`'s."""
    if not peak > 0.1:
        return np.empty((0, 2))
    rays, samples = dx.shape
    a = np.empty(samples, np.float32)
    drop = np.empty(samples, np.float32)
    out = np.empty((rays, 2))
    n = 0
    for k in range(rays):
        # Ray by ray, its samples still in the cache, and only as far as they are
        # defined: past there the falls are NaN, which the rim search passes over.
        stop = _sample_ray(alpha, dx[k], dy[k], np.float32(cx), np.float32(cy), a)
        end = _ray_falls(a, stop, drop)
        r = _ray_rim(drop, end, reach, peak, RIM_HALF)
        if np.isfinite(r):
            # As float64 from the float32 offsets, the first sample's offset is the
            # ray's direction times its spacing.
            out[n, 0] = x0 + cx + r * (np.float64(dx[k, 1]) / reach[1])
            out[n, 1] = y0 + cy + r * (np.float64(dy[k, 1]) / reach[1])
            n += 1
    return out[:n]


#: Samples in 1 px along a ray (every 0.25 px), and so in half of the 2 px the rim's
#: fall is taken over.
RIM_HALF = 4


@njit(cache=True, nogil=True, inline="always")
def _fma32(p: float, q: float, r: float) -> float:
    """p·q + r for float32 values, rounded once to float32 (as a fused multiply-add:
    a product of two float32 is exact in float64)."""
    return np.float32(np.float64(p) * np.float64(q) + np.float64(r))


@njit(cache=True, nogil=True)
def _sample_ray(alpha: NDArray, dx: NDArray, dy: NDArray, cx: np.float32, cy: np.float32,
                a: NDArray) -> int:
    """One ray's samples of α into ``a``: from (``cx``, ``cy``) (patch px) at the offsets
    ``dx``, ``dy`` (a row of :func:`_ray_grid`'s), bilinear, NaN where a sample's four
    pixels are not all defined (outside the patch or the unmixed window). In float32,
    each row's step and the step between the rows rounded once each, as OpenCV 5's
    ``remap`` (INTER_LINEAR, a NaN border) samples: the same values to the bit, which a
    test checks. Through ``remap``'s arrays, and the differences between them, the
    sampling cost as much as the rim search itself. Returns how many samples were
    read: past that the ray has left the patch, and ``a`` is NaN."""
    h, w = alpha.shape
    n = len(dx)
    inside = False
    for i in range(n):
        x, y = dx[i] + cx, dy[i] + cy
        fx0, fy0 = np.floor(x), np.floor(y)
        j0, i0 = int(fx0), int(fy0)
        if j0 < 0 or i0 < 0 or j0 + 1 >= w or i0 + 1 >= h:
            if inside:
                # Out of the patch after being in it: a ray's samples run straight
                # out (monotone even when rounded), so all the rest are out too.
                a[i:] = np.nan
                return i
            a[i] = np.nan
            continue
        inside = True
        fx, fy = x - fx0, y - fy0
        p, q = alpha[i0, j0], alpha[i0, j0 + 1]
        u, v = alpha[i0 + 1, j0], alpha[i0 + 1, j0 + 1]
        top = _fma32(fx, q - p, p)
        bottom = _fma32(fx, v - u, u)
        a[i] = _fma32(fy, bottom - top, top)
    return n


@njit(cache=True, nogil=True)
def _ray_falls(a: NDArray, stop: int, drop: NDArray) -> int:
    """The fall of α over 2 px (:data:`RIM_HALF` samples either side) along a ray's
    samples ``a`` into ``drop``, NaN within 1 px of its start; returns the index past
    which it is NaN (the ray's end, or where its samples stop, ``stop``)."""
    n = len(a)
    end = max(min(n, stop) - RIM_HALF, RIM_HALF)
    drop[:RIM_HALF] = np.nan
    for i in range(RIM_HALF, end):
        drop[i] = a[i - RIM_HALF] - a[i + RIM_HALF]
    return end


@lru_cache(maxsize=64)
def _ray_grid(rays: int, samples: int) -> tuple[NDArray, NDArray, NDArray]:
    """Rays from the origin every 0.25 px: the distances (px, float64) and each
    sample's x and y offsets (float32, one row per ray). Cached: a marker keeps its
    radius from frame to frame, and making them cost a fifth of a rim fit."""
    reach = np.arange(samples) * 0.25
    angles = np.linspace(0.0, 2.0 * np.pi, rays, endpoint=False)
    dx = (np.cos(angles)[:, None] * reach[None, :]).astype(np.float32)
    dy = (np.sin(angles)[:, None] * reach[None, :]).astype(np.float32)
    for a in (reach, dx, dy):
        a.flags.writeable = False
    return reach, dx, dy


@njit(cache=True, nogil=True)
def _ray_rim(d: NDArray, n: int, reach: NDArray, peak: float, half: int) -> float:
    """The rim's distance from the centre along one ray, px, or NaN (see
    :func:`rim_points`): ``d`` is the fall of α over 2 px at each of ``reach``'s
    samples, defined (or NaN) in its first ``n`` and NaN beyond."""
    strongest = -np.inf
    for i in range(n):
        if np.isfinite(d[i]) and d[i] > strongest:
            strongest = d[i]
    if not np.isfinite(strongest) or strongest < 0.15 * peak:
        return np.nan
    j = -1
    for i in range(n - 1, -1, -1):
        if np.isfinite(d[i]) and d[i] >= 0.6 * strongest:
            j = i
            break
    # That is on the fall's outer flank: walk in to its top.
    while j > 0 and np.isfinite(d[j - 1]) and d[j - 1] > d[j]:
        j -= 1
    lo, hi = max(j - half, 0), min(j + half + 1, n)
    total = 0.0
    moment = 0.0
    for i in range(lo, hi):
        if np.isfinite(d[i]) and d[i] > 0.0:
            total += d[i]
            moment += d[i] * reach[i]
    return moment / total if total > 0.0 else np.nan


#: Triples of rim points tried for the least-median start; fixed, so that a frame
#: always gives the same centre (a resumed run equals an uninterrupted one).
_TRIPLES = np.random.default_rng(0).random((96, 3))


@njit(cache=True, nogil=True)
def _least_median_circle(points: NDArray) -> NDArray[np.float64]:
    """(cx, cy, R) of the circle through three of the points whose median
    distance to all points is smallest (least median of squares). Compiled, as
    :func:`_reweighted_circle`."""
    n = len(points)
    best, out = np.inf, np.empty(3)
    res = np.empty(n)
    for t in range(len(_TRIPLES)):
        i = min(int(_TRIPLES[t, 0] * n), n - 1)
        j = min(int(_TRIPLES[t, 1] * n), n - 1)
        k = min(int(_TRIPLES[t, 2] * n), n - 1)
        ax, ay = points[i, 0], points[i, 1]
        bx, by = points[j, 0], points[j, 1]
        cx, cy = points[k, 0], points[k, 1]
        # The circumcentre of the triple (collinear or repeated triples drop out).
        d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
        if not abs(d) > 1e-6:
            continue
        sa, sb, sc = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
        ux = (sa * (by - cy) + sb * (cy - ay) + sc * (ay - by)) / d
        uy = (sa * (cx - bx) + sb * (ax - cx) + sc * (bx - ax)) / d
        r = math.hypot(ax - ux, ay - uy)
        if not np.isfinite(r):
            continue
        # The median is under the best only where at least half the residuals are
        # (ceil(n/2) of them): else it cannot be, and is not sorted for (a third of a
        # pendulum clip's tracking time went to these medians). A triple with more than
        # the other half at or over the best is left as soon as that is so.
        most_over = n - (n + 1) // 2
        over = 0
        for m in range(n):
            res[m] = abs(math.hypot(points[m, 0] - ux, points[m, 1] - uy) - r)
            over += not res[m] < best
            if over > most_over:
                break
        if over > most_over:
            continue
        med = np.median(res)
        if med < best:
            best = med
            out[0], out[1], out[2] = ux, uy, r
    if not np.isfinite(best):
        mx, my = np.mean(points[:, 0]), np.mean(points[:, 1])
        out[0], out[1] = mx, my
        out[2] = np.mean(np.sqrt((points[:, 0] - mx) ** 2 + (points[:, 1] - my) ** 2))
    return out


def fit_circle(points: NDArray, iterations: int = 20, start: NDArray | None = None,
               hold_radius: bool = False
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Robust circle through rim points: ((cx, cy, R), 3×3 covariance, weights).

    The least-median circle through triples of points starts it (a quarter of
    the rays running up a stalk would pull any least-squares start off by a
    pixel, and the reweighting then crawls back), unless ``start`` (cx, cy, R)
    is given: a circle already fitted to nearly the same rim. Gauss–Newton
    steps on the geometric distance, each reweighted by Tukey's biweight of the
    residual over 1.4826·MAD (at least :data:`MIN_SCALE_PX`), follow. The
    covariance is s²·(JᵀWJ)⁻¹ with s² the weighted residual variance. With
    ``hold_radius`` the radius stays at ``start``'s and only the centre is fitted (its
    variance and covariance with the radius are then 0).
    """
    given = np.empty(0) if start is None else np.asarray(start, np.float64)
    return _fit_circle(np.ascontiguousarray(points, np.float64), given, iterations,
                       hold_radius and start is not None)


@njit(cache=True, nogil=True)
def _fit_circle(points: NDArray, start: NDArray, iterations: int, hold: bool
                ) -> tuple[NDArray, NDArray, NDArray]:
    """:func:`fit_circle`, with ``start`` empty for the least-median start. Compiled:
    in NumPy the covariance's small array steps cost as much as the fit."""
    x = np.ascontiguousarray(points[:, 0])
    y = np.ascontiguousarray(points[:, 1])
    if start.size == 0:
        start = _least_median_circle(points)
    p, wts = _reweighted_circle(x, y, start, iterations, hold)
    A = np.zeros((3, 3))
    j = np.empty(3)
    kept, ss = 0.0, 0.0
    for i in range(len(x)):
        ex, ey = x[i] - p[0], y[i] - p[1]
        rho = max(math.hypot(ex, ey), 1e-9)
        res = rho - p[2]
        j[0], j[1], j[2] = -ex / rho, -ey / rho, -1.0
        for a in range(3):
            for b in range(3):
                A[a, b] += j[a] * wts[i] * j[b]
        kept += wts[i]
        ss += wts[i] * res * res
    s2 = ss / max(kept - (2.0 if hold else 3.0), 1.0)
    if hold:
        _radius_held(A)
    try:
        cov = s2 * np.linalg.inv(A)
    except Exception:  # a singular system: numba catches no narrower class
        cov = np.full((3, 3), np.nan)
    if hold:
        cov[2, 2] = 0.0
    return p, cov, wts


@njit(cache=True, nogil=True)
def _radius_held(A: NDArray) -> None:
    """Make the normal matrix ``A`` (cx, cy, R) leave R where it is: its row and column
    cut from the centre's, and its own diagonal 1 (a step of 0 on a gradient of 0)."""
    A[2, 0] = A[0, 2] = A[2, 1] = A[1, 2] = 0.0
    A[2, 2] = 1.0


@njit(cache=True, nogil=True)
def _reweighted_circle(x: NDArray, y: NDArray, p0: NDArray, iterations: int, hold: bool
                       ) -> tuple[NDArray, NDArray]:
    """The Gauss–Newton / Tukey-biweight iterations of :func:`fit_circle` from
    ``p0`` (cx, cy, R), R held with ``hold``: the circle and the last weights. Compiled:
    two medians and a solve per iteration, a few hundred times a frame on a clip full
    of false blobs."""
    n = len(x)
    p = p0.copy()
    wts = np.ones(n)
    res = np.empty(n)
    J = np.empty((n, 3))
    for _ in range(iterations):
        for i in range(n):
            ex, ey = x[i] - p[0], y[i] - p[1]
            rho = max(math.hypot(ex, ey), 1e-9)
            res[i] = rho - p[2]
            J[i, 0], J[i, 1], J[i, 2] = -ex / rho, -ey / rho, -1.0
        scale = max(1.4826 * np.median(np.abs(res - np.median(res))), MIN_SCALE_PX)
        A = np.zeros((3, 3))
        g = np.zeros(3)
        for i in range(n):
            u = res[i] / (TUKEY_C * scale)
            wts[i] = (1 - u * u) ** 2 if abs(u) < 1 else 0.0
            for a in range(3):
                g[a] -= J[i, a] * wts[i] * res[i]
                for b in range(3):
                    A[a, b] += J[i, a] * wts[i] * J[i, b]
        if hold:
            _radius_held(A)
            g[2] = 0.0
        try:
            step = np.linalg.solve(A, g)
        except Exception:  # a singular system: numba catches no narrower class
            break
        if not np.all(np.isfinite(step)):
            break
        p += step
        if math.hypot(step[0], step[1]) < 1e-4:
            break
    return p, wts


#: A followed ball's centre is taken with its radius held at its learned one (the median
#: of its first fits, :meth:`.marker_state.MarkerState.remember`) while the free fit's
#: radius lies within this factor of it (:func:`fit_outline`). A rim that is
#: no full circle lets a free fit trade its radius for its centre: the blue lower half of
#: bartekpacia/pendulum's capsule, fitted free at 75–100 px in radius on its 1920×1080
#: copy, moved its centre 1.2–1.5 px up for each px the radius grew, and the four copies
#: of that recording differed by 2.4–3.6 px RMS in y (in 550×310 px); held, 1.4–2.3.
#: Beyond the band the marker's outline has changed (Tracker's diabolo, turning, fitted
#: under 0.7 of its learned radius in a quarter of its frames), and the free fit is
#: taken.
HOLD_BAND = 1.3
#: ...and while the held circle's centre lies within this many times the two radii's
#: difference (plus 3σ) of the free one's: a circle that keeps to an arc as its radius
#: changes by Δr moves its centre by about Δr. On the capsule's 800×480 copy the held
#: centre moved 1.3 Δr (median), 2.5 Δr in 9 frames of 10, 3.7 Δr in 99 of 100 (at 2,
#: 12 % of its frames were fitted free, and the swapping lost the capsule in 7 %). Held
#: at a radius 10 % short, a drawn half disc's circle left its rim for one 10–16 px
#: off, 5–8 Δr (tests/test_outline.py).
HOLD_SHIFT = 4.0


def fit_outline(alpha: NDArray, x0: float, y0: float, guess: tuple[float, float],
                radius: float, passes: int = 2, hold: float | None = None) -> Centre:
    """The circle through a marker's rim in a coverage patch (see the module).

    Rays are cast from ``guess`` (image px), then again from the fitted
    centre when that is :data:`RECAST_PX` or more away. ``radius`` is the
    expected marker radius, px. The result is not ``ok`` when fewer than
    :data:`MIN_POINTS` rim points (or :data:`MIN_FRACTION` of the rays) keep
    weight, when the centre moved more than ``radius`` or the fitted radius is
    outside 0.3–3× ``radius``.
    With ``hold`` (px: a followed ball's learned radius) the centre is that of the
    circle of that radius through the same rim points, where the free fit's radius lies
    within :data:`HOLD_BAND` of it, that circle keeps as many points and its centre
    lies within :data:`HOLD_SHIFT` of the free one's. Its σ is then at least the free
    centre's distance from it, axis by axis. The returned radius is the free fit's
    either way, so that a marker coming nearer is seen to grow.
    The returned gain is the median coverage within half the fitted radius
    (≈ 1 for a whole flat marker of the learned colour); ``rms_residual`` is
    NaN, since a rim residual (px) is not comparable to a disc fit's (α).
    """
    rays = int(np.clip(round(math.pi * radius), 16, 96))
    cast = guess
    failed = Centre(np.nan, np.nan, np.nan, radius, False)
    p = cov = None
    # The middle's coverage is read once, around the guess: the second pass's
    # centre is within a pixel or two of it, well inside 0.7 of the radius.
    peak = middle_peak(alpha, x0, y0, guess, radius)
    for _ in range(passes):
        pts = rim_points(alpha, x0, y0, cast, radius, rays, peak)
        if len(pts) < MIN_POINTS:
            return failed
        # A later pass starts from the circle before it, cast from nearly the same
        # centre: the least-median search over triples is for the first.
        p, cov, wts = fit_circle(pts, start=p)
        kept = int((wts > 0).sum())
        if kept < max(MIN_POINTS, MIN_FRACTION * rays) or not np.all(np.isfinite(p)):
            return failed
        if math.hypot(p[0] - cast[0], p[1] - cast[1]) < RECAST_PX:
            break
        cast = (float(p[0]), float(p[1]))
    free_r = p[2]
    if hold is not None and hold > 0 \
            and abs(math.log(max(free_r, 1e-9) / hold)) <= math.log(HOLD_BAND):
        held, held_cov, held_wts = fit_circle(pts, start=np.array([p[0], p[1], hold]),
                                              hold_radius=True)
        dx, dy = held[0] - p[0], held[1] - p[1]
        free_sigma = math.sqrt(max(0.5 * (cov[0, 0] + cov[1, 1]), 0.0))
        if int((held_wts > 0).sum()) >= max(MIN_POINTS, MIN_FRACTION * rays) \
                and np.all(np.isfinite(held)) and math.hypot(dx, dy) \
                <= HOLD_SHIFT * abs(free_r - hold) + 3.0 * free_sigma:
            # Its σ owns up to what holding the radius assumes: not below the free
            # circle's distance from it, axis by axis.
            p, cov = held, held_cov
            cov[0, 0] += dx * dx
            cov[1, 1] += dy * dy
    var = 0.5 * (cov[0, 0] + cov[1, 1])
    moved = math.hypot(p[0] - guess[0], p[1] - guess[1])
    if not (np.isfinite(var) and var > 0 and moved < radius
            and 0.3 * radius < free_r < 3 * radius):
        return failed
    gain = _quantile_within(alpha, p[0] - x0, p[1] - y0, 0.5 * p[2], 0.5, 1)
    return Centre(float(p[0]), float(p[1]), float(math.sqrt(var)), float(free_r), True,
                  float("nan"), gain, (float(p[0]), float(p[1]), float(free_r), 0.5, 1.0, 0.0),
                  rim=True)


#: Spread of the coverage over a marker's middle, (p90 − p10) / p90, above which it
#: is shaded (a ball lit from one side), not a flat disc of one colour. Measured:
#: 0.02–0.06 on the flat markers of an H.264 design render at 2.5 DN noise (up
#: to 0.11 on a small red one, see below),
#: 0.19–0.28 on the Jmol atoms of Tracker's jmoljana clip, 0.33–0.37 on the
#: Lambert spheres of tests/test_real_footage_like.py.
SHADED_SPREAD = 0.15
#: ...unless it falls off evenly all round (:func:`_even_falloff`): a plane with a bowl
#: fitted to the middle's coverage rises across it (one radius) by less than this
#: fraction of its p90 and leaves less than :data:`EVEN_RESIDUAL` of it. A disc out of
#: focus pulls no fit aside: yupi's rover pivot (r ≈ 12.7 px, edge 4.5 px), first held
#: by its rim at 9.3 px, spread 0.18, rose 0.04 and left 0.06; the Jmol atom rose 0.46,
#: Tracker's diabolo 0.53, the pendulum's glass bob 1.07, and OpenCV vtest.avi's white
#: plate, which leans less (0.13), left 1.9 (it is lettered). For the crank-slider's
#: printed discs, whose shading rejects a blob of their colour, only beside the band
#: of the wire's shadow out of focus (:func:`_even_beside_a_band`).
SHADED_TILT = 0.2
EVEN_RESIDUAL = 0.1
#: A wire tied at a printed disc's middle (B's) is also a line where only the core of
#: what the filling raised (by at least this fraction of the middle's coverage) lies
#: along a line through the disc's centre, within :data:`TIED_PX`. The 4:2:0 chroma
#: cells beside a nearly level wire are raised too, and with them its line was as
#: wide as long: on the second renderer's SMA bed at rest (bench/sma_bed_apart.py,
#: seed 1), spreads along and across 2.2 : 1, and B was rejected for 16 frames. Its
#: core's spreads are 3.4–21 : 1 and its line passes 0.0–0.6 px from B's centre; a
#: box's lettering on OpenCV's box.mp4 that passes at this depth lies 1.4–2.4 px off.
LINE_CORE = 0.2
TIED_PX = 1.0
#: Markers smaller than this (radius, px) are never judged shaded: their middle is
#: a dozen pixels, over which H.264's half-resolution chroma is blurred (a flat
#: red marker of radius 4.5 px reached a spread of 0.11 at its true centre).
SHADED_MIN_RADIUS_PX = 8.0


def shaded(alpha: NDArray, x0: float, y0: float, centre: tuple[float, float],
           radius: float, fill_lines_px: int = 0, band_half_px: float = 0.0) -> bool:
    """Does the coverage vary across the marker's middle (within half its radius) as
    on a shaded ball? Then its rim, not a flat disc, says where its centre is.

    ``fill_lines_px`` > 0 first fills dark lines up to that wide (px) in ``alpha`` (a
    grey closing with a disc that wide): a thread or wire across a printed disc, or
    tied at its middle (:data:`LINE_CORE`), which is no shading. What the filling
    raises must be one line (not lettering). Shading varies over the whole middle and
    is kept. A middle that falls off evenly all round (:func:`_even_falloff`) is an
    out-of-focus disc, not a ball."""
    if radius < SHADED_MIN_RADIUS_PX:
        return False
    h, w = alpha.shape
    yy, xx = np.mgrid[0:h, 0:w]
    middle = ((xx + x0 - centre[0]) ** 2 + (yy + y0 - centre[1]) ** 2 <= (0.5 * radius) ** 2) \
        & np.isfinite(alpha)
    if middle.sum() < 5:
        return False
    p10, p90 = np.percentile(alpha[middle], [10, 90])
    if not (p90 > 0 and (p90 - p10) / p90 > SHADED_SPREAD):
        return False
    if fill_lines_px == 0 and _even_falloff(alpha, x0, y0, centre, radius, middle, p90):
        return False
    if fill_lines_px > 0:
        # Outside the coverage window counts as dark: a closing takes maxima first, so
        # it cannot raise the middle above what the marker itself shows.
        k = 2 * (fill_lines_px // 2) + 1
        filled = cv2.morphologyEx(np.where(np.isfinite(alpha), alpha, 0.0).astype(np.float32),
                                  cv2.MORPH_CLOSE,
                                  cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
        # Only one line: printed text or a pattern (a red box's lettering on a webcam
        # clip) fills as well, and is no marker.
        inside = ((xx + x0 - centre[0]) ** 2 + (yy + y0 - centre[1]) ** 2
                  <= (radius - 3.0) ** 2) & np.isfinite(alpha)
        gain = filled - alpha
        raised = inside & (gain > 0.5 * SHADED_SPREAD * p90)
        core = inside & (gain > LINE_CORE * p90)
        if _one_line(xx[raised], yy[raised]) or _one_line(
                xx[core], yy[core], (centre[0] - x0, centre[1] - y0), TIED_PX):
            q10, q90 = np.percentile(filled[middle], [10, 90])
            return bool(q90 > 0 and (q90 - q10) / q90 > SHADED_SPREAD)
        if band_half_px and _even_beside_a_band(alpha, xx + x0 - centre[0],
                                                 yy + y0 - centre[1], radius, band_half_px):
            return False
    return True


#: Directions tried for the darkest band through a printed disc's centre (degrees apart).
BAND_STEP_DEG = 5.0
#: ...over the disc within this fraction of its radius: three edge widths inside the
#: rim of a disc 10 px in radius blurred over 1.7 px, where its own edge has fallen by
#: under 4 %.
BAND_INSIDE = 0.7


def _even_beside_a_band(alpha: NDArray, dx: NDArray, dy: NDArray, radius: float,
                        half_width: float) -> bool:
    """Is the disc's coverage within :data:`BAND_INSIDE` of its radius even, or falling
    off evenly all round (:func:`_bowl_even`), once the darkest band through its centre,
    ``half_width`` px either side, is left out? Out of focus the wire's shadow is such
    a band, too wide and soft to be filled as a line; a shaded ball's coverage still
    leans beside it (``dx``, ``dy``: each pixel's offset from the centre, px)."""
    inside = np.isfinite(alpha) & (np.hypot(dx, dy) <= BAND_INSIDE * radius)
    darkest, best = None, np.inf
    for deg in np.arange(0.0, 180.0, BAND_STEP_DEG):
        ux, uy = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        band = inside & (np.abs(dx * uy - dy * ux) <= half_width)
        if band.sum() >= 5 and (level := float(np.mean(alpha[band]))) < best:
            darkest, best = band, level
    if darkest is None:
        return False
    beside = inside & ~darkest
    if beside.sum() < 10:
        return False
    q10, q90 = np.percentile(alpha[beside], [10, 90])
    if not q90 > 0:
        return False
    # Or falling off evenly all round beside it, as a disc out of focus does: blurred
    # by 4 px (edge 3.7 px, radius 9.6), B's middle itself falls off so that the darkest
    # band was not the wire's and the coverage beside it spread by 0.19-0.21; B was
    # refused as shaded in its first 9 frames on the second renderer's SMA bed, and lost
    # in 16 (bench/README.md, stop 52).
    return (q90 - q10) / q90 <= SHADED_SPREAD or _bowl_even(alpha[beside], dx[beside],
                                                            dy[beside], radius, q90)


def _even_falloff(alpha: NDArray, x0: float, y0: float, centre: tuple[float, float],
                  radius: float, middle: NDArray, p90: float) -> bool:
    """Does the coverage over ``middle`` (a mask of ``alpha``) fall off evenly all round,
    as on a disc out of focus (:func:`_bowl_even`)?"""
    yy, xx = np.nonzero(middle)
    return _bowl_even(alpha[yy, xx], xx + x0 - centre[0], yy + y0 - centre[1], radius, p90)


def _bowl_even(a: NDArray, dx: NDArray, dy: NDArray, radius: float, p90: float) -> bool:
    """Do coverages ``a`` at offsets ``dx``, ``dy`` (px) from a disc's centre fall off evenly
    all round? A plane with a bowl (a + b·dx + c·dy + d·(dx² + dy²)) fitted to them rises
    across the disc's middle (one ``radius``) by less than :data:`SHADED_TILT` of
    ``p90``, and leaves less than :data:`EVEN_RESIDUAL` of it. A ball lit from one side
    leans; lettering or a highlight leaves a residual."""
    design = np.c_[np.ones(len(a)), dx, dy, dx * dx + dy * dy]
    coef, *_ = np.linalg.lstsq(design, a, rcond=None)
    lean = float(np.hypot(coef[1], coef[2]) * radius)
    return lean < SHADED_TILT * p90 and float(np.std(a - design @ coef)) < EVEN_RESIDUAL * p90


def _one_line(x: NDArray, y: NDArray, through: tuple[float, float] | None = None,
              within_px: float = 0.0) -> bool:
    """Do these pixels (at least three) lie along one line, at least 1.6 times as long as
    wide (their spreads along and across), and, if ``through`` is given (px, in their
    coordinates), does that line pass within ``within_px`` of it?"""
    if len(x) < 3:
        return False
    xy = np.vstack([x, y]).astype(float)
    spread, axes = np.linalg.eigh(np.cov(xy))
    if not spread[1] >= 2.5 * max(spread[0], 1e-9):
        return False
    if through is None:
        return True
    off = xy.mean(axis=1) - np.asarray(through, float)
    return bool(abs(off @ axes[:, 0]) <= within_px)
