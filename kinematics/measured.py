"""Kinematics measured from tracks in the mechanism plane.

θ is the internal angle at A between A→C and A→B, computed per frame from
the three tracked points (so a pivot that moves does not bias it) and
unwrapped; ω, α, v_B and L3' come from :mod:`.differentiate` on the real
frame times. Every column carries a 1-σ propagated from the per-point
``_sigma_mm``, to first order and assuming independent frames.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from cranktrack.errors import CranktrackError
from cranktrack.kinematics.differentiate import local_polynomial
from cranktrack.kinematics.table import kinematics_table

#: Default length of the differentiator's window, s.
DEFAULT_WINDOW_S = 0.2


def _xy(tracks: pd.DataFrame, m: str) -> np.ndarray:
    return tracks[[f"{m}_x_mm", f"{m}_y_mm"]].to_numpy(float)


def window_samples(t_s: np.ndarray, window_s: float, order: int) -> int:
    """An odd window length in samples covering about ``window_s`` seconds."""
    dt = np.diff(np.asarray(t_s, float))
    dt = dt[dt > 0]
    step = float(np.median(dt)) if dt.size else 1.0
    n = round(window_s / step)
    n = max(n, order + 3)
    return n if n % 2 else n + 1


def crank_angle(tracks: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """θ (rad, unwrapped, positive on the assembly the run starts in) and its 1-σ.

    Frames where any of A, B, C is missing are NaN.
    """
    A, B, C = _xy(tracks, "A"), _xy(tracks, "B"), _xy(tracks, "C")
    ab, ac = B - A, C - A
    cross = ac[:, 0] * ab[:, 1] - ac[:, 1] * ab[:, 0]
    dot = (ac * ab).sum(axis=1)
    theta = np.arctan2(cross, dot)
    ok = np.isfinite(theta)
    if not ok.any():
        raise CranktrackError("markers A, B and C are never all found in the same frame, "
                              "so the crank angle cannot be measured")
    theta[ok] = np.unwrap(theta[ok])
    if np.median(theta[ok]) < 0:
        theta = -theta  # the mirror assembly: report the internal angle as positive
    # Gradients of θ with respect to B and C are perpendicular to AB and AC,
    # of size 1/|AB| and 1/|AC|; A's gradient is minus their sum.
    perp = np.array([[0.0, -1.0], [1.0, 0.0]])
    gB = ab @ perp.T / (ab**2).sum(axis=1, keepdims=True)
    gC = -(ac @ perp.T) / (ac**2).sum(axis=1, keepdims=True)
    gA = -(gB + gC)
    s = {m: tracks[f"{m}_sigma_mm"].to_numpy(float) for m in "ABC"}
    var = sum((g**2).sum(axis=1) * s[m] ** 2 for g, m in ((gA, "A"), (gB, "B"), (gC, "C")))
    return theta, np.sqrt(var)


def measure_kinematics(
    tracks: pd.DataFrame, window_s: float = DEFAULT_WINDOW_S, order: int = 2
) -> pd.DataFrame:
    """The kinematics table from a tracks table with plane coordinates.

    Parameters
    ----------
    tracks : DataFrame
        Tracks with ``t_s`` and ``A|B|C`` ``_x_mm``, ``_y_mm``, ``_sigma_mm``.
    window_s : float
        Length of the differentiator's window, s.
    order : int
        Degree of the local polynomials.

    Returns
    -------
    DataFrame
        The kinematics table of DESIGN.md, one row per frame.
    """
    for m in "ABC":
        if f"{m}_x_mm" not in tracks:
            raise CranktrackError(f"the tracks have no plane coordinates for marker {m}; "
                                  "calibrate first")
    t = tracks["t_s"].to_numpy(float)
    w = window_samples(t, window_s, order)
    theta, theta_sigma = crank_angle(tracks)
    d_theta = local_polynomial(t, theta, theta_sigma, w, order)
    B, C = _xy(tracks, "B"), _xy(tracks, "C")
    sB, sC = tracks["B_sigma_mm"].to_numpy(float), tracks["C_sigma_mm"].to_numpy(float)
    dBx = local_polynomial(t, B[:, 0], sB, w, order)
    dBy = local_polynomial(t, B[:, 1], sB, w, order)
    L3 = np.hypot(*(B - C).T)
    L3_sigma = np.hypot(sB, sC)
    dL3 = local_polynomial(t, L3, L3_sigma, w, order)
    vx, vy = dBx.d1, dBy.d1
    speed = np.hypot(vx, vy)
    with np.errstate(invalid="ignore", divide="ignore"):
        # Components of the velocity error along and across the direction of travel.
        along = np.sqrt((vx * dBx.d1_sigma) ** 2 + (vy * dBy.d1_sigma) ** 2) / speed
        across = np.sqrt((vy * dBx.d1_sigma) ** 2 + (vx * dBy.d1_sigma) ** 2) / speed
    still = ~(speed > 0)
    along[still] = np.hypot(dBx.d1_sigma, dBy.d1_sigma)[still]
    sigma = {
        "theta_deg": np.degrees(theta_sigma),
        "omega_rad_s": d_theta.d1_sigma,
        "alpha_rad_s2": d_theta.d2_sigma,
        "vB_x_mm_s": dBx.d1_sigma,
        "vB_y_mm_s": dBy.d1_sigma,
        "vB_mm_s": along,
        "vB_dir_deg": np.degrees(across),
        "L3_mm": L3_sigma,
        "L3_rate_mm_s": dL3.d1_sigma,
    }
    return kinematics_table(t, theta, d_theta.d1, d_theta.d2, np.stack([vx, vy], axis=1), L3,
                            dL3.d1, sigma=sigma, frame=tracks["frame"].to_numpy())
