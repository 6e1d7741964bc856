"""How much a track scatters: a floor under each centre's σ (from frame to frame),
and the σ check a marker at rest gives (about where it stands, :func:`at_rest`).

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

from dataclasses import dataclass
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


def found_xy(tracks: pd.DataFrame, name: str) -> NDArray[np.float64]:
    """Marker ``name``'s positions from a tracks table, (n, 2) px, NaN where it was not
    found: what this module's functions take."""
    xy = tracks[[f"{name}_x_px", f"{name}_y_px"]].to_numpy(float, copy=True)
    xy[~tracks[f"{name}_ok"].astype(bool).to_numpy()] = np.nan
    return xy


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


#: A frame whose step from the one before is under this fraction of both its
#: neighbouring steps, those at least :data:`STAIR_STEP_PX` long and pointing the same
#: way, shows the picture before it again (:func:`repeated_frames`).
STAIR_RATIO = 0.2
STAIR_STEP_PX = 0.5


def repeated_frames(xy: NDArray[np.floating]) -> NDArray[np.bool_]:
    """Frames (n,) of a track (n, 2) px that repeat the picture before them: the
    marker all but stops for one frame between two frames in which it moves on the
    same way. Footage converted from a lower frame rate does this (Tracker's
    jmoljana, a 20 fps animation at 30 fps: every third frame, re-encoded, moves
    0.1 px where the others move 2–3). A smooth motion cannot: where it slows to a
    stop it turns, and the steps either side point apart.

    >>> import numpy as np
    >>> shown = np.arange(90) * 2 // 3  # a 20 fps clip's pictures at 30 fps: 0 0 1 2 2 3 …
    >>> xy = np.c_[100 + 3.0 * shown, 50 + 0.05 * shown**2]
    >>> int(repeated_frames(xy).sum()), np.flatnonzero(repeated_frames(xy))[:3].tolist()
    (29, [4, 7, 10])
    """
    xy = np.asarray(xy, float)
    step = np.diff(xy, axis=0)
    length = np.hypot(step[:, 0], step[:, 1])
    before, here, after = length[:-2], length[1:-1], length[2:]
    ahead = np.einsum("ij,ij->i", step[:-2], step[2:]) > 0.5 * before * after
    shorter = np.fmin(before, after)
    with np.errstate(invalid="ignore"):
        stair = (shorter >= STAIR_STEP_PX) & (here <= STAIR_RATIO * shorter) & ahead
    out = np.zeros(len(xy), bool)
    out[2:len(stair) + 2] = stair
    return out


#: A coordinate lies on a whole pixel when it is within this of one (px): a fifth of
#: coordinates spread evenly do.
WHOLE_PX = 0.1
#: A track is drawn at whole pixels when on each axis at least this share of its moving
#: fixes' coordinates lie on one (:func:`whole_pixel_share`). On yupi's render of balls
#: in a box 0.93 and 0.88 do; on the real clips of the benches and the project's own
#: renders 0.09–0.29 of both axes' together (over 18 or more moving fixes). Both axes:
#: a render's disc sliding 4 px a frame along x and 1.3 along y lies on whole pixels in
#: x alone, and its motion is smooth (bench/large_markers.py).
WHOLE_SHARE = 0.6
#: ...counted over at least this many moving fixes (by chance an axis's share is
#: 0.2 ± 0.07), each :data:`MOVING_PX` or more from the fix in the frame before. A
#: marker at rest repeats one place, on a whole pixel or not.
WHOLE_MOVES = 30
MOVING_PX = 1.0


def whole_pixel_share(xy: NDArray[np.floating]) -> float | None:
    """The share of a track's moving fixes (those :data:`MOVING_PX` or more from the fix
    in the frame before) whose coordinate lies within :data:`WHOLE_PX` of a whole pixel,
    on the axis where fewer do; None for fewer than :data:`WHOLE_MOVES` of them. ``xy``
    is (n, 2) px, NaN where not found.

    A renderer that draws an object at whole-pixel places moves it in steps rounded
    to the pixel, and a centre fit that is right to a tenth of a pixel finds it there:

    >>> import numpy as np
    >>> t = np.arange(120.0)
    >>> path = np.c_[40 + 2.3 * t, 30 + 1.7 * t + 0.01 * t**2]
    >>> rng = np.random.default_rng(3)
    >>> drawn = np.round(path) + rng.normal(0, 0.04, path.shape)
    >>> round(whole_pixel_share(drawn), 2), round(whole_pixel_share(path), 2)
    (0.98, 0.19)
    >>> round(whole_pixel_share(np.c_[300 + 4.0 * t, 400 + 1.3 * t]), 2)  # whole in x alone
    0.09
    """
    xy = np.asarray(xy, float)
    step = np.hypot(*np.diff(xy, axis=0).T)
    moving = xy[1:][step >= MOVING_PX]  # NaN steps compare False
    if len(moving) < WHOLE_MOVES:
        return None
    return float(np.min(np.mean(np.abs(moving - np.round(moving)) <= WHOLE_PX, axis=0)))


def drawn_at_whole_pixels(xy: NDArray[np.floating]) -> bool:
    """Whether a track (n, 2) px lies on whole pixels as it moves
    (:func:`whole_pixel_share` at least :data:`WHOLE_SHARE`): footage drawn by a
    renderer that rounds each place to the pixel, whose steps from frame to frame
    are the drawing's and not the fit's error."""
    share = whole_pixel_share(xy)
    return share is not None and share >= WHOLE_SHARE


def with_scatter_floor(sigma: NDArray[np.floating], xy: NDArray[np.floating]
                       ) -> NDArray[np.float64]:
    """``sigma`` (px) raised to the track's local scatter where that is larger.

    The scatter is read over the frames that do not repeat the picture before
    them (:func:`repeated_frames`), and a repeat takes the floor of the frame it
    repeats: with the repeats in, the track moves in stairs, which differences
    read as noise (on jmoljana a floor of 0.47 px, where a point and the one a
    period later agree to 0.12 px). Frames without a scatter estimate keep
    their own σ; the floor never lowers one. A track drawn at whole pixels
    (:func:`drawn_at_whole_pixels`) keeps its own σ throughout: it really moves in
    steps rounded to the pixel, which differences would read as the fit's noise
    (yupi's balls in a box: a floor of 0.42 px where the fixes lie 0.09 px RMS
    from the whole pixels the ball was drawn at).

    >>> import numpy as np
    >>> rng = np.random.default_rng(2)
    >>> shown = np.arange(300) * 2 // 3 / 20.0  # a 20 fps clip at 30 fps, s
    >>> xy = np.c_[200 + 80 * np.cos(shown), 150 + 80 * np.sin(shown)]
    >>> xy += rng.normal(0, 0.1, (300, 2))
    >>> floor = with_scatter_floor(np.zeros(300), xy)
    >>> bool(0.07 < np.median(floor) < 0.13), bool(np.median(scatter_sigma(xy)) > 0.3)
    (True, True)
    """
    xy = np.asarray(xy, float)
    sigma = np.asarray(sigma, float)
    if drawn_at_whole_pixels(xy):
        return sigma.copy()
    repeat = repeated_frames(xy)
    if repeat.any():
        distinct = ~repeat
        floor = np.full(len(xy), np.nan)
        floor[distinct] = scatter_sigma(xy[distinct])
        floor = floor[np.maximum.accumulate(np.where(distinct, np.arange(len(xy)), 0))]
    else:
        floor = scatter_sigma(xy)
    return np.where(np.isfinite(floor) & np.isfinite(sigma), np.fmax(sigma, floor), sigma)


#: A marker whose found positions all lie, but for a twentieth of them, within this
#: of their median on each axis (px), and within :data:`AT_REST_TAIL` times their
#: own scatter, stood still over the run: the crank-slider's pivot A, a cone on the
#: ground. A moving marker spans tens of pixels; one that moved by less than a pixel
#: (the slider of a small render) has a scatter far below its span.
AT_REST_SPAN_PX = 1.0
#: For scatter alone (normal), 95 % of positions lie within 1.96 of its σ.
AT_REST_TAIL = 4.0
#: ...but a span below this (px) is rest whatever the scatter: H.264 leaves a still
#: marker's pixels unchanged for frames at a time, so its positions repeat to the
#: digit and their median absolute deviation can be 0.001 px (a test render's pivot,
#: whose 95 % span was 0.014 px). Motion this small is below what the tracker resolves.
AT_REST_SPAN_FLOOR_PX = 0.05


@dataclass(frozen=True)
class RestCheck:
    """A marker that stood still, and its σ against that: its scatter about where it
    stood (px per axis, from the median absolute deviation), its median σ (px) and
    the fraction of coordinates within ±1σ of that place: 0.68 for a σ of the random
    error alone, more where σ also covers a steady offset, which no scatter shows."""

    frames: int
    scatter_px: float
    sigma_px: float
    coverage: float


def at_rest(xy: NDArray[np.floating], sigma: NDArray[np.floating]) -> RestCheck | None:
    """The σ check a marker at rest gives on any footage: positions (n, 2) px and their
    per-axis 1-σ (n,) px, NaN where not found. None unless at least 10 positions were
    found and 95 % of them lie within :data:`AT_REST_SPAN_PX` of their median on each
    axis, and within :data:`AT_REST_TAIL` times their scatter (or within
    :data:`AT_REST_SPAN_FLOOR_PX`).

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> xy = np.array([120.0, 80.0]) + rng.normal(0.0, 0.05, (500, 2))
    >>> honest = at_rest(xy, np.full(500, 0.05))
    >>> bool(0.6 < honest.coverage < 0.76), round(honest.scatter_px, 2)
    (True, 0.05)
    >>> round(at_rest(xy, np.full(500, 0.0125)).coverage, 1)  # σ 4× too small
    0.2
    """
    xy = np.asarray(xy, float)
    sigma = np.asarray(sigma, float)
    found = np.isfinite(xy).all(axis=1) & np.isfinite(sigma)
    if found.sum() < 10:
        return None
    d = xy[found] - np.median(xy[found], axis=0)
    span = np.quantile(np.abs(d), 0.95, axis=0)
    tail = np.fmax(AT_REST_TAIL * 1.4826 * np.median(np.abs(d), axis=0),
                   AT_REST_SPAN_FLOOR_PX)
    if (span > AT_REST_SPAN_PX).any() or (span > tail).any():
        return None
    s = sigma[found]
    return RestCheck(frames=int(found.sum()),
                     scatter_px=float(1.4826 * np.median(np.abs(d))),
                     sigma_px=float(np.median(s)),
                     coverage=float(np.mean(np.abs(d) <= s[:, None])))
