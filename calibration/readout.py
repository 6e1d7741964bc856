"""A rolling shutter's readout time, measured from two markers on a ruler shaken
sideways (:func:`readout_from_pair`: perspective cannot fake it) or from a marker in
free flight (:func:`readout_from_flight`: only if it flew square to the camera).

A camera that reads its rows one after another takes row ``y`` ρ·y seconds after
the top row (:mod:`..kinematics.rolling_shutter`). A ball tossed in front of it
falls under constant acceleration, so its fixes lie on quadratics in the time
each was taken, t + ρ·y, and on no quadratic in the frame's time t when ρ ≠ 0.
The ρ that leaves the least squares is the camera's; its 1-σ is the jackknife's
(each fix left out in turn). On Tracker's public ball toss (a 640×480 webcam)
this gives 6.7–6.9 ± 1.0 ms over the frame, and 6.6 ± 1.7 ms from the Tracker
user's own clicks (``bench/real_footage.py``).

The readout holds only for a flight in a plane square to the camera. A plane
turned towards it bends the image parabola in much the same way (perspective), so
the fit also says what a tilted flight plane, read all at once, leaves
(:func:`tilted_plane_residual`). On that toss the tilted plane leaves 0.13–0.14 px
against the readout's 0.29: the bend may be the plane's, not the shutter's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares, minimize_scalar

from ..errors import CranktrackError

#: Fewest fixes of the flight: three parameters per axis and ρ, and a few to spare.
MIN_FIXES = 8


@dataclass(frozen=True)
class ReadoutFit:
    """A free flight fitted with and without a rolling shutter."""

    readout_s: float  # top row to bottom row
    readout_sigma_s: float  # jackknife 1-σ
    height_px: int
    fixes: int
    residual_px: float  # RMS per axis, with the readout
    residual_global_px: float  # RMS per axis, all rows at the frame's time
    acceleration_px_s2: float  # |acceleration| with the readout
    acceleration_global_px_s2: float  # |acceleration| with all rows at the frame's time
    #: RMS per axis (px) of a flight in a plane tilted to the camera, all rows at once.
    residual_tilted_px: float
    #: Per fix and axis, px, with the readout (the fixes used, in order).
    residual: NDArray = field(repr=False, compare=False, default_factory=lambda: np.empty((0, 2)))

    @property
    def tilt_explains_it(self) -> bool:
        """Does a flight plane tilted to the camera (8 parameters, all rows at once) leave
        no more than the readout does (7), each residual taken per degree of freedom?
        Then this flight cannot tell the readout from the plane's tilt."""
        n = 2 * self.fixes
        with_readout = self.residual_px * np.sqrt(n / (n - 7))
        tilted = self.residual_tilted_px * np.sqrt(n / (n - 8))
        return bool(tilted <= with_readout)


def _jackknife_sigma(left_out: list[float]) -> float:
    """The jackknife's 1-σ of an estimate from its values with each fix left out in turn."""
    loo = np.asarray(left_out, float)
    return float(np.sqrt((len(loo) - 1) * np.mean((loo - loo.mean()) ** 2)))


def _fit(t: NDArray, xy: NDArray, rho: float) -> tuple[NDArray, NDArray]:
    """Quadratics in t + ρ·y: their coefficients and the residual (px)."""
    te = t + rho * xy[:, 1]
    X = np.vander(te - te.mean(), 3)
    coef = np.linalg.lstsq(X, xy, rcond=None)[0]
    return coef, xy - X @ coef


def _best_rho(t: NDArray, xy: NDArray, step_s: float, height_px: int) -> float:
    """The ρ (s per row) that leaves the least squares, with the whole readout of
    ``height_px`` rows shorter than ``step_s`` (a frame)."""
    bound = step_s / height_px
    return float(minimize_scalar(lambda rho: float(np.sum(_fit(t, xy, rho)[1] ** 2)),
                                 bounds=(-bound, bound), method="bounded",
                                 options={"xatol": 1e-3 * bound}).x)


def flight_fixes(t_s: NDArray, xy: NDArray, least: int, what: str,
                 *more: NDArray) -> tuple[NDArray, ...]:
    """A flight's fixes where every one of ``t_s`` (s), ``xy`` (n, 2) and ``more`` (n,)
    is finite, checked: at least ``least`` of them (``what`` needs them), with times that
    advance. Returns them in that order."""
    arrays = [np.asarray(t_s, float), np.asarray(xy, float), *(np.asarray(m, float)
                                                              for m in more)]
    ok = np.all(np.isfinite(arrays[1]), axis=1)
    for a in (arrays[0], *arrays[2:]):
        ok &= np.isfinite(a)
    arrays = [a[ok] for a in arrays]
    if len(arrays[0]) < least:
        raise CranktrackError(f"only {len(arrays[0])} fixes of the flight; {what} needs at "
                              f"least {least} frames of a marker flying freely")
    if not np.all(np.diff(arrays[0]) > 0):
        raise CranktrackError("the fixes' times do not advance from frame to frame")
    return tuple(arrays)


def readout_from_flight(t_s: NDArray, xy_px: NDArray, height_px: int) -> ReadoutFit:
    """The readout time of a camera ``height_px`` rows tall, from a marker's fixes
    ``xy_px`` (n, 2; image px, y down) at frame times ``t_s`` (s) while it flies
    freely (constant acceleration, as a tossed ball between throw and catch).

    Raises
    ------
    CranktrackError
        Fewer than :data:`MIN_FIXES` fixes, or times that do not advance.
    """
    t, xy = flight_fixes(t_s, xy_px, MIN_FIXES, "the readout")
    step = float(np.median(np.diff(t)))
    rho = _best_rho(t, xy, step, height_px)
    # Jackknife: ρ with each fix left out in turn.
    keep = ~np.eye(len(t), dtype=bool)
    sigma = _jackknife_sigma([_best_rho(t[k], xy[k], step, height_px) for k in keep])
    coef, resid = _fit(t, xy, rho)
    coef0, resid0 = _fit(t, xy, 0.0)
    tilted = tilted_plane_residual(t, xy)
    return ReadoutFit(rho * height_px, sigma * height_px, int(height_px), len(t),
                      float(np.sqrt(np.mean(resid**2))), float(np.sqrt(np.mean(resid0**2))),
                      float(np.hypot(*(2 * coef[0]))), float(np.hypot(*(2 * coef0[0]))),
                      float(np.sqrt(np.mean(tilted**2))), resid)


def tilted_plane_residual(t_s: NDArray, xy_px: NDArray) -> NDArray:
    """The residual (px, per fix and axis) of a free flight in a plane that need not
    face the camera, all rows read at once: the plane's coordinates are quadratics in
    t, and a pinhole maps them by a homography, so image x and y are quadratics over
    one shared quadratic, (P(t)/R(t), Q(t)/R(t)) with R(t̄) = 1: 8 parameters.

    A flight plane turned towards or away from the camera bends the image parabola
    as a rolling shutter does: on one flight the two are not told apart. A toss drawn
    square to the camera and read over 7 ms is fitted by either to its noise; one
    drawn in a plane turned by 10° and read at once gives a readout of −18 ms."""
    t = np.asarray(t_s, float)
    xy = np.asarray(xy_px, float)
    tc = t - t.mean()
    X = np.vander(tc, 3)
    coef = np.linalg.lstsq(X, xy, rcond=None)[0]

    def model(p: NDArray) -> NDArray:
        R = 1.0 + p[6] * tc + p[7] * tc**2
        return np.c_[X @ p[0:3], X @ p[3:6]] / R[:, None]

    fit = least_squares(lambda p: (model(p) - xy).ravel(), np.r_[coef[:, 0], coef[:, 1], 0, 0])
    return xy - model(fit.x)


@dataclass(frozen=True)
class PairReadoutFit:
    """A readout from two markers on one rigid bar moved sideways: the readout (s, top
    row to bottom row) and its jackknife 1-σ, the frame's height (px), the fixes used,
    and the RMS (px per axis) of the pair's separation about a constant, with the
    readout and with all rows at the frame's time."""

    readout_s: float
    readout_sigma_s: float
    height_px: int
    fixes: int
    residual_px: float
    residual_global_px: float


def _pair_fit(rows_apart: NDArray, velocity: NDArray, separation: NDArray
              ) -> tuple[float, NDArray]:
    """ρ (s per row) and the residual (px) of separation = d0 + ρ·Δrow·v, by least
    squares over both axes (d0 a constant per axis)."""
    n = len(separation)
    A = np.zeros((2 * n, 3))
    A[:n, 0] = 1.0
    A[n:, 1] = 1.0
    A[:n, 2] = rows_apart * velocity[:, 0]
    A[n:, 2] = rows_apart * velocity[:, 1]
    b = np.r_[separation[:, 0], separation[:, 1]]
    p = np.linalg.lstsq(A, b, rcond=None)[0]
    r = b - A @ p
    return float(p[2]), np.c_[r[:n], r[n:]]


def _five_point_rate(t: NDArray, xy: NDArray) -> tuple[NDArray, NDArray]:
    """The rate of ``xy`` (n, 2) per s at each frame from the five-point stencil, and
    where it holds (two frames either side, evenly spaced within 1 %). The three-point
    difference reads a 1.2 Hz shake filmed at 30 fps 1 % slow (sin x / x), which would
    put the readout 1 % high; the five-point one reads it within 0.01 %."""
    n = len(t)
    rate = np.full((n, 2), np.nan)
    even = np.zeros(n, bool)
    if n < 5:
        return rate, even
    h = np.diff(t)
    step = np.c_[h[:-3], h[1:-2], h[2:-1], h[3:]]
    mean = step.mean(axis=1)
    with np.errstate(invalid="ignore"):
        even[2:-2] = np.all(np.abs(step - mean[:, None]) <= 0.01 * mean[:, None], axis=1)
        rate[2:-2] = (xy[:-4] - 8 * xy[1:-3] + 8 * xy[3:-1] - xy[4:]) / (12 * mean[:, None])
    return rate, even & np.isfinite(t)


def readout_from_pair(t_s: NDArray, first_px: NDArray, second_px: NDArray,
                      height_px: int) -> PairReadoutFit:
    """The readout time of a camera ``height_px`` rows tall, from two markers on one
    rigid bar (n, 2 image px each, y down, at frame times ``t_s`` s) moved sideways at
    a constant distance and without turning, e.g. a ruler held upright and shaken.

    Each marker is seen when its row is read, so the separation the frame shows is
    the bar's own plus the motion in the time between their rows:
    d = d0 + ρ·(y₂ − y₁)·v, with v the pair's velocity (:func:`_five_point_rate` of its
    midpoint) and ρ the readout per row. Unlike a free flight's bend, this is not what
    perspective does: a bar at a constant distance keeps its image size whatever its
    speed. Frames with both markers found and two evenly spaced frames either side are
    used; the 1-σ is the jackknife's.

    Raises
    ------
    CranktrackError
        Fewer than :data:`MIN_FIXES` such frames, times that do not advance, markers on
        one row, or a bar that did not move.
    """
    t = np.asarray(t_s, float)
    a, b = np.asarray(first_px, float), np.asarray(second_px, float)
    velocity, even = _five_point_rate(t, 0.5 * (a + b))
    ok = (even & np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
          & np.all(np.isfinite(velocity), axis=1))
    if ok.sum() < MIN_FIXES:
        raise CranktrackError(f"only {int(ok.sum())} frames have both markers and two found "
                              f"frames either side; the readout needs at least {MIN_FIXES}")
    a, b, velocity, t = a[ok], b[ok], velocity[ok], t[ok]
    if not np.all(np.diff(t) > 0):
        raise CranktrackError("the fixes' times do not advance from frame to frame")
    rows_apart = b[:, 1] - a[:, 1]
    if np.median(np.abs(rows_apart)) < 0.1 * height_px:
        raise CranktrackError("the two markers lie within a tenth of the frame's height of "
                              "each other; hold the bar upright, so they lie rows apart")
    separation = b - a
    if np.percentile(np.hypot(*velocity.T), 90) * np.median(np.diff(t)) < 1.0:
        raise CranktrackError("the bar hardly moved (under a pixel a frame); move it "
                              "sideways, fast, while filming")
    rho, resid = _pair_fit(rows_apart, velocity, separation)
    n = len(t)
    keep = ~np.eye(n, dtype=bool)
    sigma = _jackknife_sigma([_pair_fit(rows_apart[k], velocity[k], separation[k])[0]
                              for k in keep])
    still = separation - separation.mean(axis=0)
    return PairReadoutFit(rho * height_px, sigma * height_px, int(height_px), n,
                          float(np.sqrt(np.mean(resid**2))), float(np.sqrt(np.mean(still**2))))
