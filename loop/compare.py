"""Measured kinematics beside a model: fit the model, then the error figures.

The spool model (thesis §2.5.2) is fitted to the measured θ(t) by the closed
loop's own base fit (:func:`.search.close_loop` with no candidate effects):
one fitter, one set of names, whether a user compares or closes the loop.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..errors import CranktrackError
from ..kinematics.table import kinematics_table
from ..models.crank_slider import crank_state
from ..models.spool import SpoolDrive
from .candidates import SPOOL_BASE
from .evidence import fit_percent
from .search import close_loop
from .simulate import spool_drive

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
    """RMS, largest error and fit% of each column over the rows both tables have values for.

    Both tables must be row-aligned (same frames). ``mask`` restricts the
    rows. Returns one row per quantity: ``quantity``, ``unit``, ``rms``,
    ``max_abs``, ``peak`` (largest |model| value), ``rms_pct_of_peak``,
    ``fit_pct`` and ``frames`` (rows used).
    """
    rows = []
    for col, unit in columns.items():
        y, yh = measured[col].to_numpy(float), model[col].to_numpy(float)
        keep = np.isfinite(y - yh)
        if mask is not None:
            keep &= mask
        e = (y - yh)[keep]
        peak = float(np.nanmax(np.abs(yh[keep]))) if keep.any() else np.nan
        rms = float(np.sqrt(np.mean(e**2))) if e.size else np.nan
        rows.append({
            "quantity": col, "unit": unit, "rms": rms,
            "max_abs": float(np.max(np.abs(e))) if e.size else np.nan,
            "peak": peak,
            "rms_pct_of_peak": 100 * rms / peak if peak else np.nan,
            "fit_pct": fit_percent(y[keep], yh[keep]) if keep.any() else np.nan,
            "frames": int(keep.sum()),
        })
    return pd.DataFrame(rows)


def errors_against_drive(measured: pd.DataFrame, drive: SpoolDrive, margin_s: float
                         ) -> pd.DataFrame:
    """:func:`error_summary` against a known drive (a render's truth), twice: over all
    frames (``rows`` = "all frames") and away from the drive's start and stop by more
    than ``margin_s`` (s), where ω steps ("away from start/stop")."""
    model = spool_model(drive, measured["t_s"].to_numpy())
    t = measured["t_s"].to_numpy()
    away = (np.abs(t - drive.start_s) > margin_s) & (np.abs(t - drive.stop_s) > margin_s)
    parts = [error_summary(measured, model, mask=mask).assign(rows=label)
             for label, mask in (("all frames", None), ("away from start/stop", away))]
    return pd.concat(parts, ignore_index=True)


@dataclass(frozen=True)
class SpoolFit:
    """A fitted spool model: the drive, fitted values ± 1σ, and what was held fixed.

    Names are the loop's (:data:`.candidates.SPOOL_BASE`: ``L1_mm``,
    ``L3_0_mm``, ``speed_mm_s``, …), the same that ``fit --known`` takes."""

    drive: SpoolDrive
    fitted: dict[str, tuple[float, float]]
    fixed: dict[str, float]
    rms_theta_deg: float
    messages: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "model": "spool",
            "fitted": {k: {"value": v, "sigma": s, "unit": SPOOL_BASE[k].unit}
                       for k, (v, s) in self.fitted.items()},
            "fixed": {k: {"value": v, "unit": SPOOL_BASE[k].unit} for k, v in self.fixed.items()},
            "rms_theta_deg": self.rms_theta_deg,
            "messages": self.messages,
        }


def fit_spool(measured: pd.DataFrame, known: dict[str, float] | None = None) -> SpoolFit:
    """Fit the spool model to measured θ(t): the closed loop's base fit, with no effects.

    Parameters
    ----------
    measured : DataFrame
        A kinematics table (``t_s``, ``theta_deg``, ``theta_deg_sigma``,
        ``L3_mm``; ``L1_mm``/``L2_mm`` help the starting values).
    known : dict, optional
        Parameters to hold, by the names of :data:`.candidates.SPOOL_BASE`
        (e.g. ``{"L1_mm": 160.8, "L2_mm": 72.4, "speed_mm_s": 14.0}``). With
        the speed free, one length must fix the scale: ``L1_mm`` is then held
        at the measured |AC| unless a length is known.

    The 1-σ count correlated frames once (:class:`.evidence.NoiseModel`).

    Raises
    ------
    CranktrackError
        An unknown name, too few frames, or known values no spool model can meet.
    """
    known = dict(known or {})
    unknown = set(known) - set(SPOOL_BASE)
    if unknown:
        raise CranktrackError(f"unknown spool parameter(s) {sorted(unknown)}; "
                              f"known: {', '.join(SPOOL_BASE)}")
    result = close_loop(measured, known, "spool", candidates={})
    base = result.base
    v, sd = base.values, base.sigmas(result.noise)
    drive = spool_drive(v)
    fitted = {k: (v[k], sd[k]) for k in SPOOL_BASE if k in base.free}
    fixed = {k: v[k] for k in SPOOL_BASE if k not in base.free}
    return SpoolFit(drive, fitted, fixed, base.rmse_deg, list(result.messages))


@dataclass(frozen=True)
class Comparison:
    """Measured and model side by side, and the error figures."""

    table: pd.DataFrame
    summary: pd.DataFrame
    fit: SpoolFit
    #: The fitted model between the frames too (:func:`model_curve`), for figures.
    curve: pd.DataFrame | None = None


SIDE_BY_SIDE = ("theta_deg", "omega_rad_s", "vB_x_mm_s", "vB_y_mm_s", "vB_mm_s", "vB_dir_deg")


def compare_spool(measured: pd.DataFrame, known: dict[str, float] | None = None) -> Comparison:
    """Fit the spool model (:func:`fit_spool`) and put it beside the measurements."""
    fit = fit_spool(measured, known)
    model = spool_model(fit.drive, measured["t_s"].to_numpy(float))
    table = pd.DataFrame({"frame": measured["frame"], "t_s": measured["t_s"]})
    for c in SIDE_BY_SIDE:
        table[f"{c}_measured"] = measured[c].to_numpy()
        table[f"{c}_measured_sigma"] = measured[f"{c}_sigma"].to_numpy()
        table[f"{c}_model"] = model[c].to_numpy()
        err = measured[c].to_numpy() - model[c].to_numpy()
        if c == "vB_dir_deg":
            err = (err + 180.0) % 360.0 - 180.0
        table[f"{c}_error"] = err
    return Comparison(table, error_summary(measured, model), fit,
                      model_curve(fit.drive, measured["t_s"].to_numpy(float)))


def model_curve(drive: SpoolDrive, t_s: np.ndarray, per_frame: int = 20) -> pd.DataFrame:
    """The spool model between the frame times ``t_s`` (s) as well as at them:
    ``per_frame`` samples per frame interval, and the drive's start and stop instants
    with a point 1 ns either side, so a figure draws ω's steps as steps, not as ramps
    from one frame to the next."""
    t = t_s[np.isfinite(t_s)]
    if len(t) < 2:
        return spool_model(drive, t)
    grid = np.linspace(t.min(), t.max(), per_frame * (len(t) - 1) + 1)
    kinks = np.array([drive.start_s, drive.stop_s])
    grid = np.concatenate([grid, t, *(kinks + d for d in (-1e-9, 0.0, 1e-9))])
    grid = np.unique(grid[(grid >= t.min()) & (grid <= t.max())])
    return spool_model(drive, grid)

