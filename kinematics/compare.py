"""Measured kinematics beside a model: the error figures."""

from __future__ import annotations

import numpy as np
import pandas as pd

from cranktrack.kinematics.crank_slider import crank_state
from cranktrack.kinematics.spool import SpoolDrive
from cranktrack.kinematics.table import kinematics_table

#: Columns compared by default, with their units for display.
COMPARED = {"theta_deg": "deg", "omega_rad_s": "rad/s", "vB_mm_s": "mm/s"}


def spool_model(drive: SpoolDrive, t_s: np.ndarray) -> pd.DataFrame:
    """The analytic spool-driven crank-slider as a kinematics table at times ``t_s``."""
    slider = drive.slider(t_s)
    s = crank_state(drive.bed, slider)
    return kinematics_table(t_s, s.theta, s.omega, s.alpha, s.vB, slider.L3, slider.L3_rate)


def error_summary(measured: pd.DataFrame, model: pd.DataFrame,
                  columns: dict[str, str] = COMPARED,
                  mask: np.ndarray | None = None) -> pd.DataFrame:
    """RMS and largest error of each column over the rows both tables have values for.

    Both tables must be row-aligned (same frames). ``mask`` restricts the
    rows. Returns one row per quantity: ``quantity``, ``unit``, ``rms``,
    ``max_abs``, ``peak`` (largest |model| value), ``rms_pct_of_peak`` and
    ``frames`` (rows used).
    """
    rows = []
    for col, unit in columns.items():
        err = measured[col].to_numpy(float) - model[col].to_numpy(float)
        keep = np.isfinite(err)
        if mask is not None:
            keep &= mask
        e = err[keep]
        peak = float(np.nanmax(np.abs(model[col].to_numpy(float)))) if keep.any() else np.nan
        rms = float(np.sqrt(np.mean(e**2))) if e.size else np.nan
        rows.append({
            "quantity": col, "unit": unit, "rms": rms,
            "max_abs": float(np.max(np.abs(e))) if e.size else np.nan,
            "peak": peak,
            "rms_pct_of_peak": 100 * rms / peak if peak else np.nan,
            "frames": int(keep.sum()),
        })
    return pd.DataFrame(rows)
