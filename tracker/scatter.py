"""How much a track scatters from frame to frame: a floor under each centre's σ.

A centre's own σ comes from its fit to one frame's pixels. On real footage that
fit can be far too sure of itself: compression, blur and a marker that is not
the disc the fit assumes all move the centre by more than the pixel noise
explains. The track over neighbouring frames shows how much it really moves
about. A smooth motion has small high-order differences, so the k-th difference
of the positions is mostly noise, with variance C(2k, k)·σ² per axis for
independent per-frame noise σ; the scatter is read from the order that leaves
the least (difference-based variance estimation, as in Hall, Kay & Titterington,
Biometrika 77, 1990).

>>> import numpy as np
>>> rng = np.random.default_rng(1)
>>> t = np.arange(400) / 30.0
>>> xy = np.c_[200 + 80 * np.cos(t), 150 + 80 * np.sin(t)] + rng.normal(0, 0.5, (400, 2))
>>> s = scatter_sigma(xy)
>>> bool(0.4 < np.median(s) < 0.6)
True
"""

from __future__ import annotations

from math import comb, log

import numpy as np
import pandas as pd
from numpy.typing import NDArray

#: Frames over which the scatter is pooled, centred on each frame. Wide enough
#: that a median of squared differences settles (≈ ±15 % at 31), narrow enough
#: to follow a marker that blurs only while it moves fast.
WINDOW_FRAMES = 31

#: Difference orders tried. Second differences suit a slow marker; a marker on
#: a crank turning at 1 Hz filmed at 30 fps needs the fifth or sixth before its
#: motion drops below 0.03 px of render noise.
ORDERS: tuple[int, ...] = (2, 3, 4, 5, 6)


def scatter_sigma(xy: NDArray[np.floating], window: int = WINDOW_FRAMES,
                  orders: tuple[int, ...] = ORDERS) -> NDArray[np.float64]:
    """Per-frame 1-σ (px, per axis) of the frame-to-frame scatter of a track.

    ``xy`` is (n, 2) px, one row per frame, NaN where the marker was not found;
    a difference that spans a gap is not used. Per order k the half mean square
    of the two axes' k-th differences, (dx² + dy²)/2, is exponential with mean
    C(2k, k)·σ² for white noise; its rolling median over ``window`` frames is
    divided by ln 2 · C(2k, k). Each frame takes the smallest of the orders'
    estimates, since motion only adds to them. NaN where no order has five
    differences in the window.
    """
    xy = np.asarray(xy, float)
    n = len(xy)
    best = np.full(n, np.inf)
    for k in orders:
        if n <= k:
            continue
        d = np.diff(xy, n=k, axis=0)
        q = 0.5 * np.sum(d**2, axis=1)
        centred = np.full(n, np.nan)
        centred[k // 2: k // 2 + len(q)] = q
        med = pd.Series(centred).rolling(window, center=True, min_periods=5).median()
        est = np.sqrt(med.to_numpy() / (log(2) * comb(2 * k, k)))
        best = np.fmin(best, np.where(np.isfinite(est), est, np.inf))
    best[~np.isfinite(best)] = np.nan
    return best


def with_scatter_floor(sigma: NDArray[np.floating], xy: NDArray[np.floating]
                       ) -> NDArray[np.float64]:
    """``sigma`` (px) raised to the track's local scatter where that is larger.

    Frames without a scatter estimate keep their own σ; the floor never lowers one.
    """
    floor = scatter_sigma(xy)
    sigma = np.asarray(sigma, float)
    return np.where(np.isfinite(floor) & np.isfinite(sigma), np.fmax(sigma, floor), sigma)
