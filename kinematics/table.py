"""Assemble the kinematics table (DESIGN.md) from arrays in code units."""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from ..tables import KINEMATICS_VALUES


def kinematics_table(
    t_s: ArrayLike,
    theta: ArrayLike,
    omega: ArrayLike,
    alpha: ArrayLike,
    vB_mm_s: ArrayLike,
    L3_mm: ArrayLike,
    L3_rate_mm_s: ArrayLike,
    sigma: dict[str, ArrayLike] | None = None,
    frame: ArrayLike | None = None,
) -> pd.DataFrame:
    """The kinematics table with a ``_sigma`` column for every value.

    Parameters
    ----------
    t_s : array_like
        Frame times, s.
    theta, omega, alpha : array_like
        Internal angle at A (rad) and its first two time derivatives
        (rad/s, rad/s²).
    vB_mm_s : array_like, shape (n, 2)
        Velocity of B in the plane, mm/s.
    L3_mm, L3_rate_mm_s : array_like
        Wire length |BC| (mm) and its rate (mm/s).
    sigma : dict, optional
        1-σ of some columns, keyed by the *table* column name (e.g.
        ``"theta_deg"``, in that column's unit); others are 0.
    frame : array_like, optional
        Frame numbers; default 0..n-1.

    Returns
    -------
    DataFrame
        ``frame``, ``t_s``, then each of ``tables.KINEMATICS_VALUES`` with its
        ``_sigma``. ``vB_dir_deg`` is NaN where B is exactly still.
    """
    t = np.asarray(t_s, dtype=float)
    v = np.asarray(vB_mm_s, dtype=float).reshape(-1, 2)
    speed = np.hypot(v[:, 0], v[:, 1])
    with np.errstate(invalid="ignore"):
        direction = np.where(speed > 0, np.degrees(np.arctan2(v[:, 1], v[:, 0])), np.nan)
    values = {
        "theta_deg": np.degrees(np.asarray(theta, float)),
        "omega_rad_s": np.asarray(omega, float),
        "alpha_rad_s2": np.asarray(alpha, float),
        "vB_x_mm_s": v[:, 0],
        "vB_y_mm_s": v[:, 1],
        "vB_mm_s": speed,
        "vB_dir_deg": direction,
        "L3_mm": np.asarray(L3_mm, float),
        "L3_rate_mm_s": np.asarray(L3_rate_mm_s, float),
    }
    sigma = sigma or {}
    cols: dict[str, np.ndarray] = {
        "frame": np.arange(t.size) if frame is None else np.asarray(frame),
        "t_s": t,
    }
    for name in KINEMATICS_VALUES:
        cols[name] = values[name]
        cols[name + "_sigma"] = np.broadcast_to(
            np.asarray(sigma.get(name, 0.0), float), t.shape).copy()
    return pd.DataFrame(cols)
