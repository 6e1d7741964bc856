"""A rolling shutter's readout time, measured from a marker in free flight.

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


def readout_from_flight(t_s: NDArray, xy_px: NDArray, height_px: int) -> ReadoutFit:
    """The readout time of a camera ``height_px`` rows tall, from a marker's fixes
    ``xy_px`` (n, 2; image px, y down) at frame times ``t_s`` (s) while it flies
    freely (constant acceleration, as a tossed ball between throw and catch).

    Raises
    ------
    CranktrackError
        Fewer than :data:`MIN_FIXES` fixes, or times that do not advance.
    """
    t = np.asarray(t_s, float)
    xy = np.asarray(xy_px, float)
    ok = np.isfinite(t) & np.all(np.isfinite(xy), axis=1)
    t, xy = t[ok], xy[ok]
    if len(t) < MIN_FIXES:
        raise CranktrackError(f"only {len(t)} fixes of the flight; the readout needs at least "
                              f"{MIN_FIXES} frames of a marker flying freely")
    steps = np.diff(t)
    if not np.all(steps > 0):
        raise CranktrackError("the fixes' times do not advance from frame to frame")
    step = float(np.median(steps))
    rho = _best_rho(t, xy, step, height_px)
    # Jackknife: ρ with each fix left out in turn.
    keep = ~np.eye(len(t), dtype=bool)
    loo = np.array([_best_rho(t[k], xy[k], step, height_px) for k in keep])
    sigma = float(np.sqrt((len(t) - 1) * np.mean((loo - loo.mean()) ** 2)))
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
