"""The blurred-disc fit: a marker's centre from its coverage image.

:func:`fit_disc` is least squares of a blurred-disc model
``α = b + a·Φ((r − d)/s)`` (centre, radius, edge width, gain, offset) by
Gauss–Newton, σ from the residual and the Jacobian; :func:`fit_disc_cells`
refits its centre at the chroma's own resolution on 4:2:0 frames.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .centre import Centre

# The per-marker work below runs on every frame for every marker, about a
# thousand pixels each time; as numpy it was ~1.5 ms per marker, mostly the
# overhead of many small array operations, which kept tracking slower than
# decoding. Compiled (numba), one pass over the pixels does each step, and
# ``nogil`` lets the decoder thread run beside it.

#: The narrowest edge, in pixels, that a disc fit's σ is taken at: averaging over a
#: pixel alone blurs a sharp edge by 1/√12 ≈ 0.29 px (:func:`_edge_floored`).
#: ``fit_disc`` itself lets the edge run down to 0.05 px.
EDGE_MIN = 0.29

_SQRT_HALF = math.sqrt(0.5)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)
#: Abramowitz & Stegun 7.1.26: erf(x) = 1 − (a1·t + … + a5·t⁵)·e^(−x²) with
#: t = 1/(1 + p·x), x ≥ 0, within 1.5e-7 (:func:`_step`).
_AS_P = 0.3275911 * _SQRT_HALF
_AS_A1, _AS_A2, _AS_A3, _AS_A4, _AS_A5 = (0.254829592, -0.284496736, 1.421413741,
                                          -1.453152027, 1.061405429)


@njit(cache=True, nogil=True)
def _step(z: float) -> tuple[float, float]:
    """Φ(z), the blurred edge's profile (the normal distribution's integral), within
    7.5e-8, and e^(−z²/2), its slope over 1/√(2π).

    ``math.erf`` was half of the disc fit's time per pixel (16 of 34 ns on this
    machine, no vectorised libm in numba): the formula takes the exponential the slope
    needs anyway, and 7.5e-8 is a million times under a coverage's noise."""
    e = math.exp(-0.5 * z * z)
    t = 1.0 / (1.0 + _AS_P * abs(z))
    tail = 0.5 * e * t * (_AS_A1 + t * (_AS_A2 + t * (_AS_A3 + t * (_AS_A4 + t * _AS_A5))))
    return (1.0 - tail if z >= 0.0 else tail), e


#: A disc seen square-on: its distance from the centre is the plain one
#: (:func:`stretch_of`).
ROUND = (1.0, 0.0, 1.0)
_ROUND_METRIC = np.array(ROUND, np.float64)


def stretch_of(stretch: tuple[float, float, float] | None) -> NDArray[np.float64]:
    """The disc model's metric ``(g11, g12, g22)`` as the compiled kernels take it.

    A printed disc seen by a camera not square to its plane is an ellipse in the image:
    its distance from the centre is ``d = √(g11·dx² + 2·g12·dx·dy + g22·dy²)`` (px),
    with ``g = JᵀJ / |det J|`` for ``J`` the image-to-plane Jacobian there
    (:mod:`.foreshortening`), whose determinant is 1, so the ellipse's area is still
    π·r². None is :data:`ROUND`, for which the model is the circle's, bit for bit."""
    # None is every fit without a calibration, several per marker per frame: the one
    # array (no kernel writes to it; left writable, so the kernels compile for one
    # array type), rather than a new one each time.
    return _ROUND_METRIC if stretch is None else np.array(stretch, np.float64)


@njit(cache=True, nogil=True)
def is_round(m: NDArray) -> bool:
    """Is the metric ``m`` the round one (:data:`ROUND`)?"""
    return m[1] == 0.0 and m[0] == 1.0 and m[2] == 1.0


@njit(cache=True, nogil=True)
def _distance(m: NDArray, dx: float, dy: float) -> float:
    """The disc model's distance (px) of an offset from the centre under the metric ``m``."""
    if is_round(m):
        return math.sqrt(dx * dx + dy * dy)
    return math.sqrt(max(m[0] * dx * dx + 2.0 * m[1] * dx * dy + m[2] * dy * dy, 0.0))


@njit(cache=True, nogil=True)
def rim_distance(m: NDArray, dx: float, dy: float) -> float:
    """As :func:`_distance`, by ``hypot`` when round: the test of a pixel against the
    rim was written so, and a round disc's answers stay as they were to the last bit."""
    if is_round(m):
        return math.hypot(dx, dy)
    return _distance(m, dx, dy)


@njit(cache=True, nogil=True)
def _disc_point(p: NDArray, x: float, y: float, jrow: NDArray, m: NDArray) -> float:
    """Model value at one pixel; its gradient over (cx, cy, r, s, a, b) into ``jrow``.
    ``m`` is the metric of :func:`stretch_of`."""
    dx, dy = x - p[0], y - p[1]
    d = _distance(m, dx, dy) + 1e-9
    z = (p[2] - d) / p[3]
    phi, e = _step(z)
    g = (p[4] / p[3]) * _INV_SQRT_2PI * e  # a · dΦ/dz / s
    # ∂d/∂cx = −(g11·dx + g12·dy)/d: for the round metric, −dx/d.
    jrow[0] = g * (m[0] * dx + m[1] * dy) / d
    jrow[1] = g * (m[1] * dx + m[2] * dy) / d
    jrow[2] = g
    jrow[3] = -g * z
    jrow[4] = phi
    jrow[5] = 1.0
    return p[5] + p[4] * phi


@njit(cache=True, nogil=True)
def _normal_equations(p: NDArray, X: NDArray, Y: NDArray, A: NDArray, n: int,
                      JtJ: NDArray, Jtr: NDArray, m: NDArray) -> float:
    """Fill JᵀJ and Jᵀr at ``p`` over the first ``n`` pixels; return the RSS.

    :func:`_disc_point`'s model and gradient written out here, with every sum a local
    scalar: through arrays, the 27 sums went to memory at every pixel, and this loop is
    most of a disc fit's time (yupi's rover clip: fits 1.5× faster, the same bits)."""
    cx, cy, r0, s, a, b = p[0], p[1], p[2], p[3], p[4], p[5]
    m0, m1, m2 = m[0], m[1], m[2]
    g0 = p[4] / p[3] * _INV_SQRT_2PI
    inv_s = 1.0 / s
    t0 = t1 = t2 = t3 = t4 = t5 = 0.0
    j00 = j10 = j11 = j20 = j21 = j22 = 0.0
    j30 = j31 = j32 = j33 = 0.0
    j40 = j41 = j42 = j43 = j44 = 0.0
    j50 = j51 = j52 = j53 = j54 = j55 = 0.0
    rss = 0.0
    for k in range(n):
        dx, dy = X[k] - cx, Y[k] - cy
        d = _distance(m, dx, dy) + 1e-9
        # Divisions cost as much as the exponential: one per pixel, not three.
        z = (r0 - d) * inv_s
        phi, e = _step(z)
        g = g0 * e
        g_d = g / d
        e0 = g_d * (m0 * dx + m1 * dy)
        e1 = g_d * (m1 * dx + m2 * dy)
        e2 = g
        e3 = -g * z
        e4 = phi
        e5 = 1.0
        r = A[k] - (b + a * phi)
        rss += r * r
        t0 += e0 * r
        j00 += e0 * e0
        t1 += e1 * r
        j10 += e1 * e0
        j11 += e1 * e1
        t2 += e2 * r
        j20 += e2 * e0
        j21 += e2 * e1
        j22 += e2 * e2
        t3 += e3 * r
        j30 += e3 * e0
        j31 += e3 * e1
        j32 += e3 * e2
        j33 += e3 * e3
        t4 += e4 * r
        j40 += e4 * e0
        j41 += e4 * e1
        j42 += e4 * e2
        j43 += e4 * e3
        j44 += e4 * e4
        t5 += e5 * r
        j50 += e5 * e0
        j51 += e5 * e1
        j52 += e5 * e2
        j53 += e5 * e3
        j54 += e5 * e4
        j55 += e5 * e5
    Jtr[0], Jtr[1], Jtr[2], Jtr[3], Jtr[4], Jtr[5] = t0, t1, t2, t3, t4, t5
    low = ((0, 0, j00), (1, 0, j10), (1, 1, j11), (2, 0, j20), (2, 1, j21), (2, 2, j22),
           (3, 0, j30), (3, 1, j31), (3, 2, j32), (3, 3, j33), (4, 0, j40), (4, 1, j41),
           (4, 2, j42), (4, 3, j43), (4, 4, j44), (5, 0, j50), (5, 1, j51), (5, 2, j52),
           (5, 3, j53), (5, 4, j54), (5, 5, j55))
    for i, j, v in low:
        JtJ[i, j] = v
        JtJ[j, i] = v
    return rss


@njit(cache=True, nogil=True)
def cholesky(M: NDArray) -> tuple[NDArray, bool]:
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
def cho_solve(L: NDArray, b: NDArray) -> NDArray:
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
def _reach2(radius: float, m: NDArray) -> float:
    """Square of how far (px) from the guess a sample enters the disc fit: 3 px past
    the rim, along the ellipse's longer axis under the metric ``m``."""
    half_trace = 0.5 * (m[0] + m[2])
    spread = math.sqrt(0.25 * (m[0] - m[2]) ** 2 + m[1] * m[1])
    shortest = half_trace - spread  # the metric's smaller eigenvalue: 1 when round
    longer = radius / math.sqrt(shortest) if shortest > 0.0 else radius
    return (longer + 3.0) ** 2


@njit(cache=True, nogil=True)
def _in_fit(a: float, dx: float, dy: float, reach2: float) -> bool:
    """Does a sample enter the disc fit: finite, within the window around the guess?"""
    return np.isfinite(a) and dx * dx + dy * dy <= reach2


@njit(cache=True, nogil=True)
def _fit_disc_compiled(alpha: NDArray, x0: float, y0: float, gx: float, gy: float,
                       radius: float, p: NDArray, iterations: int, tol_px: float,
                       hold_shape: bool, m: NDArray
                       ) -> tuple[NDArray, NDArray, float, int, float, bool]:
    """Gauss–Newton of :func:`fit_disc` from ``p``; returns (p, (JᵀJ)⁻¹, RSS,
    pixels used, Σα, whether JᵀJ was positive definite at the end). With
    ``hold_shape`` the radius and edge width stay at ``p``'s: their rows and columns
    of JᵀJ are those of a parameter that cannot move. ``m``: :func:`stretch_of`."""
    h, w = alpha.shape
    X, Y, A = np.empty(h * w), np.empty(h * w), np.empty(h * w)
    reach2 = _reach2(radius, m)
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
        rss = _normal_equations(p, X, Y, A, n, JtJ, Jtr, m)
        if hold_shape:
            for i in (2, 3):
                JtJ[i, :] = 0.0
                JtJ[:, i] = 0.0
                JtJ[i, i] = 1.0
                Jtr[i] = 0.0
        for i in range(6):
            JtJ[i, i] += 1e-9
        L, ok = cholesky(JtJ)
        if not ok:
            return p, inv, np.nan, n, total, False
        step = cho_solve(L, Jtr)
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
        inv[:, k] = cho_solve(L, e)
    return p, inv, rss, n, total, True


@njit(cache=True, nogil=True)
def _sandwich_compiled(alpha: NDArray, x0: float, y0: float, gx: float, gy: float,
                       radius: float, p: NDArray, inv: NDArray, reach: int, m: NDArray
                       ) -> float:
    """Per-axis variance of the centre with the residuals of samples up to
    ``reach`` apart taken as correlated (product Bartlett weights, which keep
    the estimate non-negative): Σ w·u_k·u_lᵀ over pairs of samples, where
    u_k = ((JᵀJ)⁻¹ J_kᵀ r_k) restricted to the centre. Same samples as the fit."""
    h, w = alpha.shape
    u = np.zeros((h, w, 2))
    used = np.zeros((h, w), np.bool_)
    reach2 = _reach2(radius, m)
    jrow = np.empty(6)
    n = 0
    for i in range(h):
        for j in range(w):
            a, xv, yv = alpha[i, j], x0 + j, y0 + i
            if _in_fit(a, xv - gx, yv - gy, reach2):
                r = a - _disc_point(p, xv, yv, jrow, m)
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


def _edge_floored(alpha: NDArray, x0: float, y0: float, gx: float, gy: float, radius: float,
                  p: NDArray, inv: NDArray, rss: float, m: NDArray) -> tuple[NDArray, float]:
    """(JᵀJ)⁻¹ and RSS of a fit ``p`` whose edge ran narrower than :data:`EDGE_MIN`,
    taken with the edge at that width instead (one pass of the normal equations
    there; their step is not taken), so its centre keeps a σ that means something.

    Narrower than a pixel's own averaging makes it, the model has a slope at almost
    no pixel and (JᵀJ)⁻¹ blows up (σ up to 10⁵ px for centres that were where they
    always were), or, on a hard-edged disc, comes out 3.6× below the scatter of its
    centres (1.9× taken here; a test). On OpenCV's vtest.avi a lettered board at
    rest, tracked over 795 frames, was then found in 99 % of them instead of 98 %,
    and 0.21 px RMS about where it stands instead of 0.44 (largest 1.7 px instead
    of 15). Fits with no disc in them (a gain near or below 0, a radius under a
    pixel) still come out with σ of 10² to 10⁵ px there, and are gaps. The
    chroma-cell refit is left as it is: the same floor there lost another object at
    rest to a neighbour 34 px off."""
    if p[3] >= EDGE_MIN:
        return inv, rss
    at = p.copy()
    at[3] = EDGE_MIN
    _, inv_at, rss_at, _, _, ok = _fit_disc_compiled(alpha, x0, y0, gx, gy, radius, at, 1,
                                                     np.inf, False, m)
    return (inv_at, rss_at) if ok else (inv, rss)


def fit_disc(alpha: NDArray, x0: float, y0: float, guess: tuple[float, float],
             radius: float, iterations: int = 8, tol_px: float = 1e-3,
             init: tuple[float, ...] | None = None, hold_shape: bool = False,
             stretch: tuple[float, float, float] | None = None) -> Centre:
    """Gauss–Newton fit of a blurred disc to a coverage patch.

    The model is ``b + a·Φ((r − d)/s)`` with ``d`` the distance to the centre
    and ``Φ`` the normal CDF: a disc whose edge is blurred by a Gaussian of
    width ``s`` (area sampling gives s ≈ 0.3 px; H.264's chroma subsampling
    more). Only pixels within ``radius + 3`` px of the guess enter the fit.
    σ of the centre is ``√(RSS/(n−6) · (JᵀJ)⁻¹)``. ``init`` carries the
    previous frame's (r, s, a, b) (or a full parameter tuple) so the fit
    starts near its answer; it stops when the centre moves less than
    ``tol_px``. With ``hold_shape`` the radius and edge width stay at ``init``'s
    and only the centre, gain and offset are fitted. ``stretch`` makes the disc the
    ellipse a camera not square to its plane sees (:func:`stretch_of`; ``d`` is then
    that metric's distance, and the window reaches 3 px past its longer axis).
    """
    shape = (radius, 0.5, 1.0, 0.0) if init is None else tuple(init)[-4:]
    p0 = np.array([guess[0], guess[1], *shape], dtype=np.float64)
    m = stretch_of(stretch)
    p, inv, rss, n, total, posdef = _fit_disc_compiled(
        np.asarray(alpha, np.float64), float(x0), float(y0), float(guess[0]),
        float(guess[1]), float(radius), p0, int(iterations), float(tol_px), hold_shape, m)
    if not posdef:
        return Centre(np.nan, np.nan, np.nan, radius, False)
    inv, rss = _edge_floored(np.asarray(alpha, np.float64), float(x0), float(y0),
                             float(guess[0]), float(guess[1]), float(radius), p, inv, rss, m)
    # As Python floats: this runs several times per marker per frame, and NumPy's
    # calls on scalars cost more than the arithmetic (the same libm functions).
    params = tuple(p.tolist())
    s2 = float(rss) / max(n - 6, 1)
    var = 0.5 * float(inv[0, 0] + inv[1, 1]) * s2
    moved = math.hypot(params[0] - guess[0], params[1] - guess[1])
    finite = math.isfinite(var) and var >= 0
    ok = (all(map(math.isfinite, params)) and moved < radius and 0 < params[2] < 3 * radius
          and finite)
    return Centre(params[0], params[1], math.sqrt(var) if finite else math.nan, params[2], ok,
                  math.sqrt(s2) if s2 >= 0 else math.nan, params[4], params, float(total))


#: A pixel of a fitted disc (inside it, or on its rim up to one blur width out) whose
#: coverage lies below the disc's model by more than 1 − this of the disc's gain has
#: something dark in front of it: a wire, a thread. The SMA wire (0.5 mm, 1.3 px)
#: across a printed disc on H.264 4:2:0 took its chroma cells down to 0.64–0.74 of
#: the gain; the disc's own inside scatters by 0.02–0.05.
OCCLUDED_GAIN = 0.8
#: ...and such pixels are a line across it when there are at least
#: :data:`OCCLUDED_MIN_PX` of them well inside, at most :data:`OCCLUDED_MAX_FRACTION`
#: of the disc's area in all, and they lie along a line (their spread across it under
#: :data:`LINE_HALF_WIDTH_PX`). A larger or rounder dark part is a cover (a hand, a
#: link), which the tracker's checks for a partly covered marker are for.
OCCLUDED_MIN_PX = 3
OCCLUDED_MAX_FRACTION = 0.25
LINE_HALF_WIDTH_PX = 2.5
#: The band left out of the fit reaches this far (px) beyond the line's own spread:
#: where the line crosses the rim, the edge's blur and a 4:2:0 frame's chroma cells
#: carry it into the neighbouring pixels.
LINE_MARGIN_PX = 1.5
#: A pixel counts for a line only with at least this many of its 8 neighbours dark too.
LINE_NEIGHBOURS = 2


@njit(cache=True, nogil=True)
def _line_pixels(alpha: NDArray, x0: float, y0: float, p: NDArray, drop: float,
                 neighbours: int, m: NDArray) -> tuple[NDArray, int, int]:
    """Pixels of the disc ``p`` (inside it, or on its blurred rim up to one blur width
    out) whose coverage lies below the model's by more than ``drop`` of its gain, and
    that have at least ``neighbours`` such pixels among their 8; how many, and how
    many of them lie well inside (within the radius less one blur width). Compiled:
    it runs on every fit of the crank-slider's discs."""
    h, w = alpha.shape
    dark = np.zeros((h, w), np.bool_)
    jrow = np.empty(6)
    # The model is never above its offset plus gain (Φ ≤ 1): a pixel at least that, less
    # the drop, is not dark, and its model (erf and exp) is not needed. Exact, as the
    # rounded operations keep that order; most of a disc's inside, which cost a fifth
    # of tracking markers of radius 60 px.
    top = p[5] + p[4] - drop * p[4] if p[4] >= 0.0 else np.inf
    for i in range(h):
        for j in range(w):
            a = alpha[i, j]
            if not np.isfinite(a) or a >= top:
                continue
            x, y = x0 + j, y0 + i
            if rim_distance(m, x - p[0], y - p[1]) > p[2] + p[3]:
                continue
            dark[i, j] = a < _disc_point(p, x, y, jrow, m) - drop * p[4]
    out = np.zeros((h, w), np.bool_)
    count, inner = 0, 0
    for i in range(h):
        for j in range(w):
            if not dark[i, j]:
                continue
            n = 0
            for di in range(-1, 2):
                for dj in range(-1, 2):
                    ii, jj = i + di, j + dj
                    if (di or dj) and 0 <= ii < h and 0 <= jj < w and dark[ii, jj]:
                        n += 1
            if n >= neighbours:
                out[i, j] = True
                count += 1
                if rim_distance(m, x0 + j - p[0], y0 + i - p[1]) < p[2] - p[3]:
                    inner += 1
    return out, count, inner


def line_across(alpha: NDArray, x0: float, y0: float, fit: Centre,
                stretch: tuple[float, float, float] | None = None) -> NDArray[np.bool_] | None:
    """The pixels of ``alpha`` (the patch's top-left pixel at image ``x0``, ``y0``) that
    a thin dark line across the disc ``fit`` covers, inside it and where it crosses
    the rim; None if there is no such line.

    A disc fit takes them for the disc's own: where the line crosses the rim, the
    rim seems to recede, and the centre moves away from it. On a second renderer's
    SMA bed (bench/sma_bed_apart.py) the wire tied at C's centre moved C by
    0.05 px (RGB) to 0.10 px (4:2:0) along the wire, with a σ of 0.04 px.
    ``stretch``: the disc is an ellipse under that metric (:func:`stretch_of`).
    """
    if fit.params is None or not fit.ok:
        return None
    p = np.asarray(fit.params, np.float64)
    cx, cy, r, s, a = p[:5]
    if not (a > 0 and r > 0 and s > 0):
        return None
    # A line is pixels side by side (a 4:2:0 frame's rim, a staircase the smooth model
    # cannot follow, leaves lone ones all round), and it crosses the disc, not only its
    # rim: a wire that leaves the marker's edge (tied under it) darkens only the rim's
    # pixels beside it, and the disc is whole.
    m = stretch_of(stretch)
    dark, count, inner = _line_pixels(np.asarray(alpha, np.float64), float(x0), float(y0),
                                      p, 1.0 - OCCLUDED_GAIN, LINE_NEIGHBOURS, m)
    if count < OCCLUDED_MIN_PX or count > OCCLUDED_MAX_FRACTION * math.pi * r * r \
            or inner < OCCLUDED_MIN_PX:
        return None
    yy, xx = np.mgrid[0:alpha.shape[0], 0:alpha.shape[1]]
    dx, dy = xx + x0 - cx, yy + y0 - cy
    px, py = dx[dark], dy[dark]
    mx, my = px.mean(), py.mean()
    cov = np.cov(np.vstack([px - mx, py - my]))
    spread, axes = np.linalg.eigh(cov)
    across, along = axes[:, 0], axes[:, 1]  # the smaller spread first
    half = 2.0 * math.sqrt(max(spread[0], 0.0))
    if half > LINE_HALF_WIDTH_PX or spread[1] < 2.0 * spread[0]:
        return None
    off = np.abs((dx - mx) * across[0] + (dy - my) * across[1])
    at = (dx - mx) * along[0] + (dy - my) * along[1]
    lo, hi = at[dark].min() - LINE_MARGIN_PX, at[dark].max() + LINE_MARGIN_PX
    # Where the line reaches the rim it goes on beyond it, over the background the
    # coverage was unmixed against: left out to the patch's edge there too.
    if rim_distance(m, mx + lo * along[0], my + lo * along[1]) >= r - s:
        lo = -np.inf
    if rim_distance(m, mx + hi * along[0], my + hi * along[1]) >= r - s:
        hi = np.inf
    return (off <= max(half, 1.0) + LINE_MARGIN_PX) & (at >= lo) & (at <= hi)


#: Cells (2 px) over which a 4:2:0 frame's chroma residuals are taken as
#: correlated in :func:`fit_disc_cells`' σ. The codec quantizes chroma in
#: blocks, so neighbouring cells share errors; on the H.264 design renders the
#: still markers' σ came out the same within 10 % for reaches of 1, 2 and 3.
CELL_REACH = 2

#: How much smaller than the pixel fit's σ the cell refit's may be. The pixel fit's σ
#: is inflated by the staircase misfit the cells remove, the more so the smaller the
#: marker: the refit's σ is 0.63–2.3× the pixel fit's on the 1280×720 H.264 design
#: render (15 px markers) and 0.28–1.2× on the 320×240 test render (3.7 px). A
#: refit that ran off claims far less: 1e-37 to 1e-144 px on a small blue sign in a
#: webcam clip, 7e-120 px on a drawn lumpy 3 px disc. (A bound of 2 was tried: it
#: threw away half the test render's good refits and left the pivot's σ 7× its
#: scatter, which the report's check of a marker at rest showed.)
CELL_SIGMA_DROP = 10.0


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


def correlated_sigma(alpha: NDArray, x0: int, y0: int, guess: tuple[float, float],
                     radius: float, fit: Centre, hold_shape: bool = False,
                     stretch: tuple[float, float, float] | None = None) -> Centre:
    """``fit`` (a :func:`fit_disc` of ``alpha`` around ``guess`` within ``radius`` + 3 px,
    the patch's top-left pixel at ``x0``, ``y0``) with its σ taken with the residuals of
    samples up to :data:`CELL_REACH` apart as correlated, as :func:`fit_disc_cells` takes
    it: for a frame seen block by block (:mod:`.binned`), whose blocks are a 4:2:0
    frame's chroma cells. Fitted as if each sample's residual were its own, a large disc
    standing still on H.264 came out with σ 0.004 px against an error of 0.02 px. As
    given where that σ cannot be had. ``stretch``: as :func:`fit_disc`'s."""
    m = stretch_of(stretch)
    a = np.asarray(alpha, np.float64)
    gx, gy = float(guess[0]), float(guess[1])
    p = np.asarray(fit.params, np.float64)
    _, inv, _, _, _, posdef = _fit_disc_compiled(a, float(x0), float(y0), gx, gy,
                                                 float(radius), p.copy(), 1, np.inf, hold_shape,
                                                 m)
    if not posdef:
        return fit
    var = _sandwich_compiled(a, float(x0), float(y0), gx, gy, float(radius), p, inv,
                             CELL_REACH, m)
    if not (np.isfinite(var) and var > 0):
        return fit
    return replace(fit, sigma=math.sqrt(var))


def fit_disc_cells(alpha: NDArray, x0: int, y0: int, pixel_fit: Centre,
                   stretch: tuple[float, float, float] | None = None) -> Centre:
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
    refit fails or lands implausibly far from it. ``stretch``: as :func:`fit_disc`'s
    (the cells scale both axes alike, so the metric is the same).
    """
    ox, oy = x0 % 2, y0 % 2
    cells = _cell_means(np.asarray(alpha, np.float64), ox, oy)
    cx0, cy0 = float((x0 + ox) // 2), float((y0 + oy) // 2)
    gx, gy = (pixel_fit.x - 0.5) / 2, (pixel_fit.y - 0.5) / 2
    r, s, gain, offset = pixel_fit.params[-4:]
    # The compiled kernels are called directly: this runs for every marker in
    # every 4:2:0 frame, and fit_disc's checks are the pixel fit's to make.
    m = stretch_of(stretch)
    p, inv, _, _, _, posdef = _fit_disc_compiled(
        cells, cx0, cy0, gx, gy, r / 2, np.array([gx, gy, r / 2, s / 2, gain, offset]), 8, 5e-4,
        False, m)
    if not posdef:
        return pixel_fit
    var = _sandwich_compiled(cells, cx0, cy0, gx, gy, r / 2, p, inv, CELL_REACH, m)
    x, y = 2 * p[0] + 0.5, 2 * p[1] + 0.5
    if not (np.isfinite(x) and np.isfinite(y) and var > 0 and np.hypot(
            x - pixel_fit.x, y - pixel_fit.y) <= max(0.5, 5.0 * pixel_fit.sigma)):
        return pixel_fit
    if 2 * math.sqrt(var) < pixel_fit.sigma / CELL_SIGMA_DROP:
        # The same pixels averaged into cells cannot locate the centre many times
        # better than the pixels did: a refit on a few lumpy cells that ran off (a
        # negative radius, a slope that vanishes at every sample) is dropped for the
        # pixel fit. (Dropping refits whose radius or gain looked wrong as well made
        # tracking OpenCV's box.mp4 15 % slower, its false blobs lost and sought
        # again; without that, no σ under 1e-3 px is left on any bench clip.)
        return pixel_fit
    return replace(pixel_fit, x=float(x), y=float(y), sigma=2 * math.sqrt(var))
