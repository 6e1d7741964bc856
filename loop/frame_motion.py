"""Is the mechanism's frame still? A shaking pivot, from the tracks of A and C.

θ is built per frame from the three markers, so a frame that moves as a whole
(the bench shaking, a pivot loose in its mount) leaves θ untouched and no
θ-model candidate can see it; but the pivot A and the slider end C then move
*across* the A–C line together, which a rigid, still frame never does. This
module fits that motion, ``y(t) = y₀ + amp·sin(2π·hz·t + φ)`` common to A and
C (y across the line, after calibration), against a still frame, and judges
it with the same rules as :mod:`.discrepancy`: ΔBIC over independent frames
> :data:`~.discrepancy.BIC_THRESHOLD`, an amplitude whose 95 % interval
excludes zero, an imprint above :data:`~.discrepancy.IMPRINT_SIGMAS` of the
tracker's noise, and at least two cycles in the clip below the Nyquist rate.
What a shake does to the velocity of B (it adds the frame's own velocity) is
then known too.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.signal import lombscargle

from .evidence import (
    BIC_THRESHOLD,
    IMPRINT_SIGMAS,
    effective_samples,
)

#: Cycles a shake must complete within the clip to be told from a slow drift.
MIN_CYCLES = 2.0


@dataclass(frozen=True)
class FrameShake:
    """The frame-motion check: the fitted shake (mm, Hz, rad) with 1-σ, how the
    evidence stands, and the RMS of A's and C's across-line motion before and
    after (mm). ``accepted`` follows the loop's rules; ``reason`` says why not."""

    amp_mm: float
    amp_sigma_mm: float
    hz: float
    hz_sigma: float
    phase_rad: float
    delta_bic: float
    imprint_sigmas: float
    rmse_before_mm: float
    rmse_after_mm: float
    tracker_sigma_mm: float
    frames: int
    accepted: bool
    reason: str
    #: The same shake's component along the A–C line at the fitted frequency, mm,
    #: and the largest displacement of the whole frame over a cycle (the vector),
    #: mm: a shake at an angle shows across the line only in part.
    amp_along_mm: float = float("nan")
    amp_vector_mm: float = float("nan")

    def to_dict(self) -> dict:
        return asdict(self)


def _sine(p: NDArray, t: NDArray) -> NDArray:
    amp, hz, phase, offset = p
    return offset + amp * np.sin(2.0 * np.pi * hz * t + phase)


def frame_shake(tracks: pd.DataFrame) -> FrameShake | None:
    """Fit a common across-line shake of A and C; None without A/C plane tracks.

    Parameters
    ----------
    tracks : DataFrame
        A run's tracks with ``t_s`` and ``A_y_mm``, ``C_y_mm``, ``A_sigma_mm``,
        ``C_sigma_mm`` (the plane frame puts A at the origin and C on +x, so y
        is across the A–C line).
    """
    cols = ("t_s", "A_y_mm", "C_y_mm", "A_sigma_mm", "C_sigma_mm")
    if any(c not in tracks for c in cols):
        return None
    t = tracks["t_s"].to_numpy(float)
    a, c = tracks["A_y_mm"].to_numpy(float), tracks["C_y_mm"].to_numpy(float)
    ok = np.isfinite(t) & np.isfinite(a) & np.isfinite(c)
    if ok.sum() < 12:
        return None
    t, a, c = t[ok], a[ok], c[ok]
    # A whole-frame shift moves both alike: their mean carries it, with half the noise.
    y = 0.5 * ((a - np.median(a)) + (c - np.median(c)))
    sigma = 0.5 * float(np.nanmedian(np.hypot(tracks["A_sigma_mm"], tracks["C_sigma_mm"])))
    span = float(t[-1] - t[0])
    nyquist = 0.5 / float(np.median(np.diff(t)))
    lowest = MIN_CYCLES / span
    rss0 = float(np.sum((y - y.mean()) ** 2))
    n = y.size
    if not lowest < 0.95 * nyquist:
        return FrameShake(np.nan, np.nan, np.nan, np.nan, np.nan, 0.0, 0.0,
                          float(np.sqrt(rss0 / n)), float(np.sqrt(rss0 / n)), sigma, n, False,
                          "the clip is too short to hold two cycles of any shake below the "
                          "Nyquist rate")
    freqs = np.linspace(lowest, 0.95 * nyquist, 400)
    power = lombscargle(t, y - y.mean(), 2.0 * np.pi * freqs)
    hz0 = float(freqs[int(np.argmax(power))])
    # Amplitude and phase at that frequency by linear least squares, then all four.
    X = np.column_stack([np.sin(2 * np.pi * hz0 * t), np.cos(2 * np.pi * hz0 * t),
                         np.ones(n)])
    s, co, off = np.linalg.lstsq(X, y, rcond=None)[0]
    p0 = np.array([np.hypot(s, co), hz0, np.arctan2(co, s), off])
    fit = least_squares(lambda p: _sine(p, t) - y, p0, x_scale="jac")
    p = fit.x
    if p[0] < 0:
        p = p * [-1, 1, 1, 1] + [0, 0, np.pi, 0]
    res = y - _sine(p, t)
    rss1 = float(res @ res)
    n_eff = effective_samples(res)
    delta_bic = float(n_eff * np.log(rss0 / max(rss1, 1e-300)) - 3.0 * np.log(n_eff))
    # Parameter σ from the Jacobian, the variance per independent frame.
    J = fit.jac
    scale = rss1 / max(n - 4, 1) * n / n_eff
    try:
        cov = np.linalg.inv(J.T @ J) * scale
        amp_sigma, hz_sigma = float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1]))
    except np.linalg.LinAlgError:
        amp_sigma = hz_sigma = float("inf")
    imprint = float(p[0] / sigma) if sigma > 0 else float("inf")
    along, vector = _along_and_vector(tracks, ok, t, p)
    reasons = []
    if delta_bic <= BIC_THRESHOLD:
        reasons.append(f"ΔBIC {delta_bic:.1f} ≤ {BIC_THRESHOLD:g}")
    if not p[0] > 1.96 * amp_sigma:
        reasons.append("the amplitude's 95 % interval includes zero")
    if imprint <= IMPRINT_SIGMAS:
        reasons.append(f"amplitude {imprint:.1f}σ of the tracker's noise (needs "
                       f"{IMPRINT_SIGMAS:g})")
    if not lowest <= p[1] <= 0.95 * nyquist:
        reasons.append("the frequency left the measurable band")
    return FrameShake(float(p[0]), amp_sigma, float(p[1]), hz_sigma,
                      float(np.mod(p[2], 2 * np.pi)), delta_bic, imprint,
                      float(np.sqrt(rss0 / n)), float(np.sqrt(rss1 / n)), sigma, n,
                      not reasons, "; ".join(reasons), along, vector)


def _along_and_vector(tracks: pd.DataFrame, ok: NDArray, t: NDArray, p: NDArray
                      ) -> tuple[float, float]:
    """The shake's along-line amplitude at the fitted frequency (linear least squares
    on the mean of A's and C's x, mm) and the peak of the whole displacement vector."""
    if "A_x_mm" not in tracks or "C_x_mm" not in tracks:
        return float("nan"), float("nan")
    ax, cx = tracks["A_x_mm"].to_numpy(float)[ok], tracks["C_x_mm"].to_numpy(float)[ok]
    x = 0.5 * ((ax - np.nanmedian(ax)) + (cx - np.nanmedian(cx)))
    good = np.isfinite(x)
    if good.sum() < 12:
        return float("nan"), float("nan")
    w = 2.0 * np.pi * p[1]
    X = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    sx, cxo, _ = np.linalg.lstsq(X[good], x[good], rcond=None)[0]
    phase = np.linspace(0.0, 2.0 * np.pi, 721)
    dx = sx * np.sin(phase) + cxo * np.cos(phase)
    dy = p[0] * np.sin(phase + p[2])
    return float(np.hypot(sx, cxo)), float(np.max(np.hypot(dx, dy)))
