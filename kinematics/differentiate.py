"""Smoothing derivatives of noisy samples on real (possibly uneven) timestamps.

A local polynomial of degree ``order`` is fitted by least squares to the
``window`` samples around each point (shifted inward at the ends of a
segment), using the actual sample times. This is Savitzky–Golay filtering
without the equal-spacing assumption. The estimate at each point is a linear
combination of the samples, so the 1-σ of independent per-sample errors
propagates exactly: σ² = Σ cᵢ² σᵢ².

Segments are runs of finite samples; no window crosses a gap.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class Derivatives:
    """Smoothed value and first two derivatives with their 1-σ (NaN in gaps)."""

    value: NDArray[np.float64]
    d1: NDArray[np.float64]
    d2: NDArray[np.float64]
    value_sigma: NDArray[np.float64]
    d1_sigma: NDArray[np.float64]
    d2_sigma: NDArray[np.float64]


def segments(valid: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the runs of ``True`` in ``valid``."""
    v = np.concatenate([[False], np.asarray(valid, bool), [False]])
    edges = np.flatnonzero(np.diff(v.astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def local_polynomial(
    t_s: ArrayLike,
    y: ArrayLike,
    sigma: ArrayLike | float = 0.0,
    window: int = 7,
    order: int = 2,
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
        Samples per fit (odd, > ``order``).
    order : int
        Polynomial degree (≥ 2 for a second derivative).

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
    if window % 2 == 0 or window <= order:
        raise ValueError(f"window must be odd and larger than order, got {window}, {order}")
    t = np.asarray(t_s, dtype=float)
    yv = np.asarray(y, dtype=float)
    sig = np.broadcast_to(np.asarray(sigma, dtype=float), yv.shape)
    out = {k: np.full(yv.shape, np.nan) for k in ("v", "d1", "d2", "sv", "s1", "s2")}
    half = window // 2
    for a, b in segments(np.isfinite(yv) & np.isfinite(t)):
        n = b - a
        if n < window:
            continue
        idx = np.arange(n)
        start = np.clip(idx - half, 0, n - window)  # windows shifted inward at the ends
        rows = start[:, None] + np.arange(window)[None, :] + a  # (n, window)
        centre = t[a:b]
        # Times relative to each point, scaled for conditioning.
        scale = max(float(np.median(np.diff(t[a:b]))), 1e-12)
        dt = (t[rows] - centre[:, None]) / scale
        V = dt[..., None] ** np.arange(order + 1)  # (n, window, order+1)
        C = np.linalg.pinv(V)  # (n, order+1, window): coefficients = C @ y
        ys, ss = yv[rows], sig[rows]
        for k, key, skey, f in ((0, "v", "sv", 1.0), (1, "d1", "s1", 1.0 / scale),
                                (2, "d2", "s2", 2.0 / scale**2)):
            if k > order:
                continue
            c = C[:, k, :] * f
            out[key][a:b] = np.sum(c * ys, axis=1)
            out[skey][a:b] = np.sqrt(np.sum((c * ss) ** 2, axis=1))
    return Derivatives(out["v"], out["d1"], out["d2"], out["sv"], out["s1"], out["s2"])
