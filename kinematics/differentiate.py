"""Smoothing derivatives of noisy samples on real (possibly uneven) timestamps.

A local polynomial of degree ``order`` is fitted by least squares to a
window of ``window`` samples around each point, using the actual sample
times: Savitzky–Golay filtering without the equal-spacing assumption. The
estimate at each point is a linear combination of the samples, so the 1-σ of
independent per-sample errors propagates exactly: σ² = Σ cᵢ² σᵢ².

Two refinements make it fit for mechanisms that start and stop:

- *Non-oscillatory windows* (``adaptive=True``): where the centred window's
  fit residual is too large for the noise (it straddles a kink, such as the
  instant a drive starts), the point uses whichever shifted window containing
  it fits best, so a step in the derivative is not smeared across it (the
  idea of ENO stencil selection). When several windows fit acceptably but
  give different rates, half their spread is added to the rate's σ.
- *Automatic window length* (:func:`choose_window`): the length that
  minimises the leave-one-out prediction error of the samples.

Segments are runs of finite samples; no window crosses a gap.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..tracker.gaps import segments


@dataclass(frozen=True)
class Derivatives:
    """Smoothed value and first two derivatives with their 1-σ (NaN in gaps).

    The σ are the propagated measurement noise only. ``d1_select`` and
    ``d2_select`` are the extra uncertainty from window selection near kinks
    (half the spread of acceptable windows' rates; 0 elsewhere), to be added
    in quadrature. ``loo`` is each sample's leave-one-out residual (for
    choosing the window) and ``shifted`` marks points that used an
    off-centre window.
    """

    value: NDArray[np.float64]
    d1: NDArray[np.float64]
    d2: NDArray[np.float64]
    value_sigma: NDArray[np.float64]
    d1_sigma: NDArray[np.float64]
    d2_sigma: NDArray[np.float64]
    loo: NDArray[np.float64]
    shifted: NDArray[np.bool_]
    window: int
    d1_select: NDArray[np.float64]
    d2_select: NDArray[np.float64]


def _fits(t: NDArray, y: NDArray, a: int, n: int, start: NDArray, window: int, order: int,
          scale: float) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Coefficient maps, residual sums and self-weights for windows at ``start``."""
    idx = np.arange(n)
    rows = start[:, None] + np.arange(window)[None, :] + a  # (n, window)
    # Sample offsets in units of the median spacing, rounded to 1e-9 of it: far
    # below any container's time resolution, and it makes the windows of an evenly
    # sampled run share a handful of patterns, so each pseudo-inverse (an SVD, the
    # bulk of the kinematics step's time) is computed once per pattern.
    dt = np.round((t[rows] - t[a + idx][:, None]) / scale, 9)
    patterns, which = np.unique(dt, axis=0, return_inverse=True)
    which = which.reshape(-1)
    Vp = patterns[..., None] ** np.arange(order + 1)  # (patterns, window, order+1)
    V, C = Vp[which], np.linalg.pinv(Vp)[which]  # C: (n, order+1, window)
    coef = np.einsum("nkw,nw->nk", C, y[rows])
    fitted = np.einsum("nwk,nk->nw", V, coef)
    rss = ((y[rows] - fitted) ** 2).sum(axis=1)
    self_w = C[np.arange(n), 0, idx - start]  # weight of sample i on its own value
    return C, rss, self_w, rows


def _nonoscillatory(t: NDArray, yv: NDArray, a: int, centred: NDArray, rss: NDArray,
                    window: int, order: int, scale: float) -> tuple[NDArray, NDArray]:
    """Window selection near kinks, for the segment of ``n = len(centred)`` samples
    from ``a``: the start of each sample's best-fitting window (where the centred one
    misfits), and the spread (2, n) of the first two rates over the windows that fit
    about as well (see the module doc)."""
    n = len(centred)
    idx = np.arange(n)
    half = window // 2
    dof = window - order - 1
    spread = np.zeros((2, n))
    # χ² quantiles from scipy.special: scipy.stats would cost 0.45 s and 48 MB to import.
    from scipy.special import chdtri  # chdtri(dof, p) is the upper-tail quantile

    # Noise level from the typical centred residual (robust to the few kinks).
    noise_var = float(np.median(rss)) / dof / (chdtri(dof, 0.5) / dof)
    limit = noise_var * chdtri(dof, 0.001)
    best_rss, choice = rss.copy(), centred.copy()
    bad = rss > limit
    # Rates of every window containing the point: where more than one
    # fits about as well as the best (Δχ² ≤ 9) and they disagree (a kink
    # a fraction of a frame away), which is right is not knowable, and
    # their spread belongs in σ.
    all_rss, all_rates = [], []
    for shift in range(-half, half + 1):
        if not bad.any():
            break
        start = np.clip(idx - half + shift, 0, n - window)
        start = np.clip(start, idx - window + 1, idx)  # the window must contain i
        C2, r2, _, rows2 = _fits(t, yv, a, n, start, window, order, scale)
        better = bad & (r2 < best_rss)
        best_rss[better], choice[better] = r2[better], start[better]
        all_rss.append(r2)
        all_rates.append([np.einsum("nw,nw->n", C2[:, k, :], yv[rows2])
                          for k in range(1, order + 1)])
    if all_rss:
        R = np.array(all_rss)  # (shifts, n)
        rates = np.array(all_rates)  # (shifts, order, n)
        # Where even the best window misfits (a moving marker's codec error
        # can exceed the run's typical noise, which still frames set), windows
        # are told apart only to within the best one's own misfit.
        local = np.maximum(noise_var, best_rss / dof)
        fine = bad & ((R <= limit) | (R - best_rss <= 9.0 * local))
        for k in range(min(order, 2)):
            vals = np.where(fine, rates[:, k, :], np.nan)
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                width = np.nanmax(vals, axis=0) - np.nanmin(vals, axis=0)
            spread[k] = np.where(np.isfinite(width), 0.5 * width, 0.0)
    return choice, spread


def local_polynomial(
    t_s: ArrayLike,
    y: ArrayLike,
    sigma: ArrayLike | float = 0.0,
    window: int = 7,
    order: int = 2,
    adaptive: bool = False,
) -> Derivatives:
    """Value, first and second derivative of ``y(t)`` by local polynomial fits.

    Parameters
    ----------
    t_s : array_like
        Sample times, s, increasing.
    y : array_like
        Samples; NaN marks a gap.
    sigma : array_like or float
        1-σ of each sample (same unit as ``y``).
    window : int
        Samples per fit (odd, > ``order`` + 1).
    order : int
        Polynomial degree (≥ 2 for a second derivative).
    adaptive : bool
        Use non-oscillatory window selection near kinks (see module doc).

    Returns
    -------
    Derivatives
        Units of ``y``, ``y``/s and ``y``/s². Segments shorter than
        ``window`` get NaN.

    Examples
    --------
    >>> t = np.linspace(0, 1, 11)
    >>> d = local_polynomial(t, 3 * t**2, window=5, order=2)
    >>> float(np.round(d.d1[5], 9)), float(np.round(d.d2[5], 9))
    (3.0, 6.0)
    """
    if window % 2 == 0 or window <= order + 1:
        raise ValueError(f"window must be odd and larger than order + 1, got {window}, {order}")
    t = np.asarray(t_s, dtype=float)
    yv = np.asarray(y, dtype=float)
    sig = np.broadcast_to(np.asarray(sigma, dtype=float), yv.shape)
    keys = ("v", "d1", "d2", "sv", "s1", "s2", "loo", "x1", "x2")
    out = {k: np.full(yv.shape, np.nan) for k in keys}
    shifted = np.zeros(yv.shape, bool)
    half = window // 2
    for a, b in segments(np.isfinite(yv) & np.isfinite(t)):
        n = b - a
        if n < window:
            continue
        spread = np.zeros((2, n))
        scale = max(float(np.median(np.diff(t[a:b]))), 1e-12)
        idx = np.arange(n)
        centred = np.clip(idx - half, 0, n - window)
        C, rss, self_w, rows = _fits(t, yv, a, n, centred, window, order, scale)
        if adaptive and n > window:
            choice, spread = _nonoscillatory(t, yv, a, centred, rss, window, order, scale)
            moved = choice != centred
            if moved.any():
                C2, _, sw2, rows2 = _fits(t, yv, a, n, choice, window, order, scale)
                C[moved], self_w[moved], rows[moved] = C2[moved], sw2[moved], rows2[moved]
                shifted[a:b] = moved
        ys, ss = yv[rows], sig[rows]
        for k, key, skey, f in ((0, "v", "sv", 1.0), (1, "d1", "s1", 1.0 / scale),
                                (2, "d2", "s2", 2.0 / scale**2)):
            if k > order:
                continue
            c = C[:, k, :] * f
            out[key][a:b] = np.sum(c * ys, axis=1)
            out[skey][a:b] = np.sqrt(np.sum((c * ss) ** 2, axis=1))
            if k >= 1:
                out[f"x{k}"][a:b] = spread[k - 1] * f
        with np.errstate(divide="ignore", invalid="ignore"):
            out["loo"][a:b] = (yv[a:b] - out["v"][a:b]) / (1.0 - self_w)
    return Derivatives(out["v"], out["d1"], out["d2"], out["sv"], out["s1"], out["s2"],
                       out["loo"], shifted, window, out["x1"], out["x2"])


#: A window is a candidate only where it gives a leave-one-out residual at this fraction
#: of the samples the best-covering candidate does (:func:`choose_window`). The ends of a
#: run cost a long window a few samples; gaps across a quick motion cost it that motion.
WINDOW_COVERAGE = 0.9


def choose_window(
    t_s: ArrayLike,
    y: ArrayLike,
    sigma: ArrayLike | float = 0.0,
    order: int = 2,
    candidates: tuple[int, ...] = (5, 7, 9, 11, 15, 21, 31),
    adaptive: bool = True,
) -> tuple[int, dict[int, float]]:
    """The window length (samples) with the smallest leave-one-out error.

    Returns the chosen length and every candidate's mean squared
    leave-one-out residual (same unit as ``y``, squared). Candidates longer
    than the longest segment are skipped.

    The candidates are scored on the same samples: those every candidate kept has a
    leave-one-out residual at. A window too long for the gaps in a track has no
    residual where the motion is quick between them, and scored on its own samples
    it was scored on the rest alone, and won: on yupi's rover clip (5 s at rest, a
    turn of 35° with gaps in 1.5 s) 31 samples were chosen, and ω on the turn was
    empty. So a candidate is kept only where it gives a residual at
    :data:`WINDOW_COVERAGE` of the samples the best-covering one does.
    """
    residuals: dict[int, NDArray] = {}
    for w in candidates:
        if w <= order + 1:
            continue
        loo = local_polynomial(t_s, y, sigma, w, order, adaptive).loo
        if np.isfinite(loo).sum() >= max(10, w):
            residuals[w] = loo
    if not residuals:
        return min(c for c in candidates if c > order + 1), {}
    most = max(int(np.isfinite(r).sum()) for r in residuals.values())
    kept = {w: r for w, r in residuals.items() if np.isfinite(r).sum() >= WINDOW_COVERAGE * most}
    common = np.logical_and.reduce([np.isfinite(r) for r in kept.values()])
    scores = {w: float(np.mean((r[common] if common.any() else r[np.isfinite(r)]) ** 2))
              for w, r in kept.items()}
    return min(scores, key=scores.get), scores
