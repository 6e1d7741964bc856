"""A printed disc seen at a slant, without a plane calibration: the ellipse it makes,
measured on its own pictures while it stands still.

A camera not square to the rig sees a printed disc as an ellipse. With a plane
calibration :mod:`.foreshortening` says which, everywhere in the frame. Without one,
a circle is fitted to the ellipse: its rim misfits all round, and the fit's residual,
so its σ, grows. On the project's own render 10° from square with a barrel lens
(640×360, k1 −0.2, the crank-slider's pivot A standing), A's σ came out 0.131 px
against an error of 0.051 px RMS (every coordinate inside ±1σ); fitted as the
calibration's ellipse, 0.037 px against 0.040.

Here each resting fix of a printed disc is fitted again with its ellipse free
(:func:`ellipse_of`: the blurred-disc model of :mod:`.disc` under a metric of
determinant 1, by :func:`scipy.optimize.least_squares`), and after
:data:`SHAPE_FRAMES` such fixes the median ellipse (:func:`settled_metric`) is the
marker's, if it is clearly not round: :meth:`.marker_state.MarkerState.stretch_at`
hands it to every later fit near where it was measured. A motion blur stretches a
disc too, along its motion, so only a marker at rest is measured.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import OptimizeResult, least_squares
from scipy.special import ndtr

from .centre import Centre

#: Resting fixes of a marker whose ellipse is measured before it is settled.
SHAPE_FRAMES = 12
#: ...tried on at most this many: a fit took 6 ms (median of 36 on bench/tilted_bed.py;
#: about 3 ms since its Jacobian is in closed form), and a disc whose fits keep failing
#: would cost that in every frame it rests.
SHAPE_TRIES = 3 * SHAPE_FRAMES
#: An ellipse whose axes are in a ratio above this is taken as round. What lies around a
#: disc makes a round one look a little stretched: on the second renderer's SMA bed
#: filmed square-on (bench/sma_bed_apart.py, 8 runs), the crank bar under A and B and
#: the wire at their rims gave 0.971-0.993 : 1, and C fitted as its 0.975 : 1 was
#: 0.045 px off instead of 0.022. A camera's slant makes 0.957 : 1 at A on the project's
#: own render pitched 5° with a 60° lens (off its axis), 0.85-0.91 : 1 on the second
#: renderer's bed pitched 20° with a barrel lens.
ROUND_ENOUGH = 0.96
#: ...and it must differ from round by this many of its standard errors (over the
#: fixes measured).
SHAPE_Z = 4.0
#: Discs smaller than this (radius, px) are not measured: H.264 keeps colour in cells of
#: 2×2 px, and a disc a few cells across looks stretched. On the project's own render
#: filmed square-on, discs of radius 3.7 px looked 0.84-0.95 : 1 (H.264; lossless, 0.97
#: and rounder), 5.5 px up to 0.962 : 1, 7.4 and 14.9 px 0.98 : 1 and rounder.
SHAPE_MIN_RADIUS_PX = 6.0
#: The learned ellipse is used within this many radii of where it was measured: a
#: lens bends a disc's shape over the frame (a barrel lens of k1 −0.2 stretched one to
#: 1.41 : 1 in the corners of a 640×360 frame, 1.12 : 1 at its middle).
SHAPE_REACH_RADII = 10.0
#: The metric's shape terms are bounded to this (an ellipse of axes 0.58 : 1 at most).
MOST_SHAPE = 0.5


def metric_of(u: float, v: float) -> tuple[float, float, float]:
    """The disc model's metric ``(g11, g12, g22)`` (:func:`.disc.stretch_of`) of the
    shape terms ``u``, ``v``: ``[[1 + u, v], [v, 1 − u]]`` scaled to determinant 1."""
    k = 1.0 / math.sqrt(max(1.0 - u * u - v * v, 1e-12))
    return ((1.0 + u) * k, v * k, (1.0 - u) * k)


def axis_ratio(u: float, v: float) -> float:
    """The ratio of the shorter to the longer axis of the ellipse of ``u``, ``v``."""
    e = math.hypot(u, v)
    return math.sqrt((1.0 - e) / (1.0 + e)) if e < 1.0 else 0.0


def long_axis_deg(u: float, v: float) -> float:
    """The direction of the ellipse's longer axis, degrees from the image's +x toward
    +y (0–180): the metric's direction of least growth."""
    # The metric's eigenvector of the smaller eigenvalue, 1 − √(u² + v²), lies at
    # half the angle of (−u, −v).
    return math.degrees(0.5 * math.atan2(-v, -u)) % 180.0


def ellipse_of(alpha: NDArray, x0: float, y0: float, fit: Centre
               ) -> tuple[float, float, float, float] | None:
    """The ellipse of a disc in its coverage patch ``alpha`` (top-left pixel at image
    ``x0``, ``y0``), started from its round fit ``fit``: the shape terms ``u``, ``v``
    of :func:`metric_of` and their standard errors; None where the fit fails.

    The model is :func:`.disc.fit_disc`'s, ``b + a·Φ((r − d)/s)``, with ``d`` the
    distance under the metric; the pixels within 3 px past the round fit's rim enter,
    with a soft-L1 loss (a wire across the disc, a speck), so a few pixels far off
    the model weigh less."""
    out = _fitted(alpha, x0, y0, fit, "soft_l1")
    if out is None:
        return None
    J = out.jac
    dof = max(len(out.fun) - len(out.x), 1)
    s2 = float(np.sum(out.fun ** 2)) / dof
    try:
        cov = np.linalg.inv(J.T @ J) * s2
    except np.linalg.LinAlgError:
        return None
    se_u, se_v = math.sqrt(max(cov[6, 6], 0.0)), math.sqrt(max(cov[7, 7], 0.0))
    u, v = float(out.x[6]), float(out.x[7])
    if not all(map(math.isfinite, (u, v, se_u, se_v))):
        return None
    return u, v, se_u, se_v


def ellipse_misfit(alpha: NDArray, x0: float, y0: float, fit: Centre) -> float | None:
    """What an ellipse leaves unexplained of a disc's coverage patch ``alpha`` (as
    :func:`ellipse_of` takes it, least squares without a robust loss): the RMS
    residual over the fitted gain (coverage per coverage); None where the fit fails.
    A disc seen at a slant leaves little, as a round disc does round; a patch of a
    larger thing of the disc's colour, lit unevenly, does not."""
    out = _fitted(alpha, x0, y0, fit, "linear")
    if out is None or not out.x[4] > 0:
        return None
    return float(np.sqrt(np.mean(out.fun ** 2)) / out.x[4])


def _fitted(alpha: NDArray, x0: float, y0: float, fit: Centre, loss: str
            ) -> OptimizeResult | None:
    """scipy's ``least_squares`` result of the ellipse model on ``alpha`` from the round
    fit ``fit`` (:func:`ellipse_of`), under ``loss``; None where it fails."""
    if fit.params is None or not fit.ok:
        return None
    cx, cy, r, s, a, b = fit.params
    h, w = alpha.shape
    yy, xx = np.mgrid[0:h, 0:w]
    X, Y = xx.ravel() + x0, yy.ravel() + y0
    A = np.asarray(alpha, float).ravel()
    keep = np.isfinite(A) & (np.hypot(X - cx, Y - cy) <= r + 3.0)
    if keep.sum() < 20:
        return None
    X, Y, A = X[keep], Y[keep], A[keep]

    def residual(p: NDArray) -> NDArray:
        return p[5] + p[4] * ndtr(_ellipse_terms(p, X, Y)[-1]) - A

    def jacobian(p: NDArray) -> NDArray:
        return ellipse_jacobian(p, X, Y)

    start = np.array([cx, cy, r, max(s, 0.1), a, b, 0.0, 0.0])
    lower = [-np.inf, -np.inf, 0.3 * r, 0.05, -np.inf, -np.inf, -MOST_SHAPE, -MOST_SHAPE]
    upper = [np.inf, np.inf, 3.0 * r, 3.0 * r, np.inf, np.inf, MOST_SHAPE, MOST_SHAPE]
    try:
        # The Jacobian in closed form: by differences it took 9 evaluations of the model
        # a step, and the fit 5–6 ms (on the project's H.264 render, 36 fits 168 against
        # 104 ms; the shape terms the same to 4e-9).
        out = least_squares(residual, start, jac=jacobian, bounds=(lower, upper),
                            loss=loss, f_scale=0.1, x_scale="jac")
    except (ValueError, np.linalg.LinAlgError):
        return None
    return out if out.success else None


def _ellipse_terms(p: NDArray, X: NDArray, Y: NDArray) -> tuple:
    """The pieces of :func:`ellipse_of`'s model at parameters ``p`` (cx, cy, r, s, a, b,
    u, v) on pixels (``X``, ``Y``) px: the metric's scale ``k`` and terms, the offsets
    from the centre, the squared metric distance ``q``, the distance ``d`` and the
    edge's argument ``z = (r − d)/s``."""
    g11, g12, g22 = metric_of(p[6], p[7])
    k = 0.5 * (g11 + g22)
    dx, dy = X - p[0], Y - p[1]
    q = g11 * dx * dx + 2.0 * g12 * dx * dy + g22 * dy * dy
    d = np.sqrt(np.maximum(q, 0.0))
    return k, g11, g12, g22, dx, dy, q, d, (p[2] - d) / p[3]


def ellipse_jacobian(p: NDArray, X: NDArray, Y: NDArray) -> NDArray:
    """∂(model)/∂p, (n, 8), of :func:`ellipse_of`'s model ``b + a·Φ((r − d)/s)`` at
    parameters ``p`` (cx, cy, r, s, a, b, u, v) on pixels (``X``, ``Y``) px, ``d`` the
    distance under :func:`metric_of`'s metric, whose scale ``k = (1 − u² − v²)^−½`` moves
    with ``u`` and ``v`` (∂k/∂u = u·k³). At a pixel on the centre itself ``d`` has no
    slope; it is taken as 0 there."""
    k, g11, g12, g22, dx, dy, q, d, z = _ellipse_terms(p, X, Y)
    slope = p[4] * np.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)  # ∂model/∂z
    # ∂model/∂q = ∂model/∂z · ∂z/∂d · ∂d/∂q
    along_q = np.divide(-slope, p[3] * 2.0 * d, out=np.zeros_like(d), where=d > 1e-9)
    J = np.empty((len(X), 8))
    J[:, 0] = along_q * -2.0 * (g11 * dx + g12 * dy)
    J[:, 1] = along_q * -2.0 * (g12 * dx + g22 * dy)
    J[:, 2] = slope / p[3]
    J[:, 3] = -slope * z / p[3]
    J[:, 4] = ndtr(z)
    J[:, 5] = 1.0
    # q = k·((dx² + dy²) + u(dx² − dy²) + 2v·dx·dy), so ∂q/∂u = k(dx² − dy²) + u·k²·q.
    J[:, 6] = along_q * (k * (dx * dx - dy * dy) + p[6] * k * k * q)
    J[:, 7] = along_q * (2.0 * k * dx * dy + p[7] * k * k * q)
    return J


def settled_metric(seen: list[tuple[float, float]]) -> tuple[float, float] | None:
    """The shape terms ``u``, ``v`` a marker is fitted with from now, from those
    measured on its resting fixes (``seen``, at least :data:`SHAPE_FRAMES`): their
    medians, where the ellipse they make is clearly not round (axes under
    :data:`ROUND_ENOUGH` of each other, and away from round by :data:`SHAPE_Z` standard
    errors, from the fixes' spread); else None (round)."""
    if len(seen) < SHAPE_FRAMES:
        return None
    uv = np.asarray(seen, float)
    u, v = np.median(uv, axis=0)
    # The standard error of a median, from the spread of the fixes about it.
    se = 1.2533 * 1.4826 * np.median(np.abs(uv - (u, v)), axis=0) / math.sqrt(len(uv))
    e = math.hypot(u, v)
    # How far from round (e = 0), in standard errors along the way out.
    se_e = math.hypot(se[0] * u, se[1] * v) / e if e > 0 else math.inf
    if axis_ratio(u, v) >= ROUND_ENOUGH or not e > SHAPE_Z * se_e:
        return None
    return float(u), float(v)
