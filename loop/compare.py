"""Measured kinematics beside a model: fit the model, then the error figures.

The spool model (thesis §2.5.2) is fitted to the measured θ(t) by
simulation (output error): least squares over the drive's start time and
stroke, and over whichever of L1, L2, L3₀ and the spool speed the user did
not fix, from several starting times. Parameter 1-σ come from the Jacobian
at the optimum, scaled by the residual variance.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ..errors import CranktrackError
from ..kinematics.table import kinematics_table
from ..models.crank_slider import crank_state
from ..models.spool import SpoolDrive
from .evidence import fit_percent

#: Columns compared by default, with their units for display.
COMPARED = {"theta_deg": "deg", "omega_rad_s": "rad/s", "vB_mm_s": "mm/s"}

#: Parameters of the spool model that a fit may free, with their units.
SPOOL_PARAMETERS = {"start_s": "s", "stroke_mm": "mm", "L1": "mm", "L2": "mm", "L3_0": "mm",
                    "speed_mm_s": "mm/s"}


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


@dataclass(frozen=True)
class SpoolFit:
    """A fitted spool model: the drive, fitted values ± 1σ, and what was held fixed."""

    drive: SpoolDrive
    fitted: dict[str, tuple[float, float]]
    fixed: dict[str, float]
    rms_theta_deg: float
    starts_tried: int
    messages: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "model": "spool",
            "fitted": {k: {"value": v, "sigma": s, "unit": SPOOL_PARAMETERS[k]}
                       for k, (v, s) in self.fitted.items()},
            "fixed": {k: {"value": v, "unit": SPOOL_PARAMETERS[k]} for k, v in self.fixed.items()},
            "rms_theta_deg": self.rms_theta_deg,
            "starts_tried": self.starts_tried,
            "messages": self.messages,
        }


def _initial_spool(measured: pd.DataFrame, fixed: dict[str, float]) -> dict[str, float]:
    """Starting values from the measurements themselves."""
    t = measured["t_s"].to_numpy(float)
    theta = np.radians(measured["theta_deg"].to_numpy(float))
    L3 = measured["L3_mm"].to_numpy(float)
    ok = np.isfinite(theta) & np.isfinite(L3)
    if ok.sum() < 5:
        raise CranktrackError("fewer than 5 frames have a measured crank angle; nothing to fit")
    guess = {
        "L1": float(np.nanmedian(measured["L1_mm"])) if "L1_mm" in measured else 160.8,
        "L2": float(np.nanmedian(measured["L2_mm"])) if "L2_mm" in measured else 72.4,
        "L3_0": float(np.median(L3[ok][:5])),
        "speed_mm_s": 14.0,
    }
    guess.update(fixed)
    # The drive starts where θ first leaves its starting value by a clear margin.
    th0 = np.median(theta[ok][:5])
    moved = np.flatnonzero(ok & (np.abs(theta - th0) > np.radians(0.5)))
    guess.setdefault("start_s", float(t[moved[0]]) - 0.1 if moved.size else float(t[ok][0]))
    guess.setdefault("stroke_mm", float(max(guess["L3_0"] - np.min(L3[ok]), 0.1)))
    return guess


def fit_spool(measured: pd.DataFrame, fixed: dict[str, float] | None = None) -> SpoolFit:
    """Fit the spool model to measured θ(t).

    Parameters
    ----------
    measured : DataFrame
        A kinematics table (``t_s``, ``theta_deg``, ``theta_deg_sigma``,
        ``L3_mm``; ``L1_mm``/``L2_mm`` help the starting values).
    fixed : dict, optional
        Parameters to hold, by the names of :data:`SPOOL_PARAMETERS`
        (e.g. ``{"L1": 160.8, "L2": 72.4, "speed_mm_s": 14.0}``).

    Raises
    ------
    CranktrackError
        Too few frames, or no start gives a mechanism that closes.
    """
    fixed = dict(fixed or {})
    unknown = set(fixed) - set(SPOOL_PARAMETERS)
    if unknown:
        raise CranktrackError(f"unknown spool parameter(s) {sorted(unknown)}; "
                              f"known: {', '.join(SPOOL_PARAMETERS)}")
    messages = []
    if "speed_mm_s" not in fixed and not {"L1", "L2", "L3_0"} & set(fixed):
        # θ(t) is unchanged when every length and the speed scale together, so one
        # of them must be held: the frame length, measured directly as |AC|.
        if "L1_mm" not in measured:
            raise CranktrackError("with a free spool speed, give --L1 (the fit needs one "
                                  "length to fix its scale)")
        fixed["L1"] = float(np.nanmedian(measured["L1_mm"]))
        messages.append(f"L1 held at the measured |AC| = {fixed['L1']:.3f} mm to fix the "
                        "scale, since the speed is free")
    guess = _initial_spool(measured, fixed)
    free = [k for k in SPOOL_PARAMETERS if k not in fixed]
    t = measured["t_s"].to_numpy(float)
    theta = np.radians(measured["theta_deg"].to_numpy(float))
    sig = np.radians(measured.get("theta_deg_sigma", pd.Series(np.nan, index=measured.index))
                     .to_numpy(float))
    ok = np.isfinite(theta) & np.isfinite(t)
    floor = np.nanmedian(sig[ok]) if np.isfinite(sig[ok]).any() else np.radians(0.01)
    w = 1.0 / np.maximum(np.where(np.isfinite(sig), sig, floor), max(floor, 1e-7))
    t, theta, w = t[ok], theta[ok], w[ok]

    def drive_of(p: np.ndarray) -> SpoolDrive:
        values = {**guess, **dict(zip(free, p, strict=True))}
        return SpoolDrive(L1=values["L1"], L2=values["L2"], L3_0=values["L3_0"],
                          speed_mm_s=values["speed_mm_s"], start_s=values["start_s"],
                          stroke_mm=values["stroke_mm"])

    def residual(p: np.ndarray) -> np.ndarray:
        try:
            d = drive_of(p)
            model = d.bed.theta(d.slider(t).L3)
        except (CranktrackError, ValueError):
            return np.full(t.size, 1e3)  # a geometry that cannot close: far from any fit
        return (theta - model) * w

    span = float(t[-1] - t[0]) if t.size > 1 else 1.0
    best, tried = None, 0
    for shift in (0.0, -0.1 * span, 0.1 * span, -0.2 * span, 0.2 * span):
        x0 = np.array([guess[k] + (shift if k == "start_s" else 0.0) for k in free])
        tried += 1
        sol = least_squares(residual, x0, x_scale="jac", method="trf")
        if best is None or sol.cost < best.cost:
            best = sol
    assert best is not None
    r = best.fun
    dof = max(r.size - len(free), 1)
    s2 = float(r @ r) / dof
    try:
        cov = np.linalg.inv(best.jac.T @ best.jac) * s2
        sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        sd = np.full(len(free), np.nan)
    if np.all(np.abs(r) >= 1e3 - 1):
        raise CranktrackError("no spool model with these fixed values can reproduce the "
                              "measured angles (the linkage would not close)")
    drive = drive_of(best.x)
    model = drive.bed.theta(drive.slider(t).L3)
    fitted = {k: (float(v), float(e)) for k, v, e in zip(free, best.x, sd, strict=True)}
    rms = float(np.degrees(np.sqrt(np.mean((theta - model) ** 2))))
    return SpoolFit(drive, fitted, fixed, rms, tried, messages)


@dataclass(frozen=True)
class Comparison:
    """Measured and model side by side, and the error figures."""

    table: pd.DataFrame
    summary: pd.DataFrame
    fit: SpoolFit


SIDE_BY_SIDE = ("theta_deg", "omega_rad_s", "vB_x_mm_s", "vB_y_mm_s", "vB_mm_s", "vB_dir_deg")


def compare_spool(measured: pd.DataFrame, fixed: dict[str, float] | None = None) -> Comparison:
    """Fit the spool model and put it beside the measurements."""
    fit = fit_spool(measured, fixed)
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
    return Comparison(table, error_summary(measured, model), fit)

