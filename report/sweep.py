"""Design maps as files: each sweep of the models written as a CSV table and a figure.

The physics is in :mod:`..models.maps` and :mod:`..models.sma_material`; this
module lays their grids out as tables and draws them, so ``cranktrack sweep``
only chooses and prints.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import CranktrackError
from ..files import ensure_dir, write_csv_atomic
from ..models.maps import (
    CONTRACTION,
    actuator_map,
    default_grid,
    force_actuator,
    rocking_angle_map,
)
from ..models.sma_material import T_HOT_C, actuator_curve, max_work_map
from .plots import plot_actuator_curves, plot_map

#: What each linkage metric is called and measured in, and its column in the table.
LINKAGE_METRICS = {"rocking-angle": ("Rocking angle", "deg", "rocking_deg"),
                   "torque": ("Peak torque", "N·m", "torque_Nm"),
                   "work": ("Work", "J", "work_J")}


@dataclass(frozen=True)
class Optimum:
    """The best cell of one map: its value (``unit``) and where it is (``at``, by axis)."""

    what: str
    value: float
    unit: str
    at: dict[str, float]


@dataclass(frozen=True)
class Sweep:
    """The files a sweep wrote and the optima it found."""

    files: list[Path]
    optima: list[Optimum]
    stroke: float | None = None  # the actuator's contraction (fraction), for linkage maps


def linkage_sweep(out: str | os.PathLike, metric: str, actuator: str, n: int) -> Sweep:
    """Rocking angle, peak torque or work over L1/L2 × θ0 (thesis §2.4, Table 2.6).

    ``metric`` is a key of :data:`LINKAGE_METRICS`; ``actuator`` ``rigid`` (a
    fixed 4 % contraction, rocking angle only), ``linear``, ``sma`` or
    ``muscle``; ``n`` cells per axis. Writes ``{metric}_{actuator}.csv`` and
    ``.png`` in ``out``; the crank is L2 = 1 m.
    """
    if n < 2:
        raise CranktrackError(f"--n must be at least 2, not {n}")
    if actuator == "rigid" and metric != "rocking-angle":
        raise CranktrackError(f"the rigid actuator has no force curve, so no {metric} map; "
                              "use --actuator linear, sma or muscle")
    what, unit, column = LINKAGE_METRICS[metric]
    out = ensure_dir(out)
    ratio, theta0 = default_grid(n)
    R, T = np.meshgrid(ratio, theta0)
    table = pd.DataFrame({"L1_over_L2": R.ravel(), "theta0_deg": T.ravel()})
    if actuator == "rigid":
        m = rocking_angle_map(ratio, theta0, CONTRACTION["rigid"])
        table["rocking_deg"] = m.rocking_deg.ravel()
        best, stroke = m.optimum(), CONTRACTION["rigid"]
        z = m.rocking_deg
    else:
        stroke, force = force_actuator(actuator)
        m = actuator_map(ratio, theta0, stroke, force)
        for col in ("rocking_deg", "torque_Nm", "work_J"):
            table[col] = getattr(m, col).ravel()
        z = getattr(m, column)
        best = m.optimum(column)
    table["incompatibility"] = m.reason.ravel()
    name = f"{metric.replace('-', '_')}_{actuator}"
    csv = write_csv_atomic(out / f"{name}.csv", table)
    png = plot_map(ratio, theta0, z, out / f"{name}.png",
                   f"{what}, {actuator} actuator ({100 * stroke:.2f} % stroke)",
                   f"{what.lower()} ({unit})", best)
    optimum = Optimum(what, best[0], unit, {"L1/L2": best[1], "θ0 (deg)": best[2]})
    return Sweep([csv, png], [optimum], stroke)


def actuator_curve_sweep(out: str | os.PathLike) -> tuple[Sweep, dict[str, float]]:
    """The SMA wire's actuator curve (§2.3, eqs. 2.6–2.9) and its linearisation.

    Writes ``actuator_curve.csv`` and ``.png``; returns them with the curve's
    blocked force (N), free stroke (%) and work per metre of wire (J/m),
    exact and linearised."""
    out = ensure_dir(out)
    c = actuator_curve()
    lin = c.linearised()
    table = pd.DataFrame({"stroke_pct": c.stroke_pct, "force_N": c.force_N,
                          "linear_force_N": lin.force_N, "spring_MPa_per_pct": c.spring})
    csv = write_csv_atomic(out / "actuator_curve.csv", table)
    png = plot_actuator_curves({"SMA wire (eqs. 2.6–2.9)": (c.stroke_pct, c.force_N),
                                "linearised": (lin.stroke_pct, lin.force_N)},
                               out / "actuator_curve.png",
                               f"Actuator curve, 250 µm wire heated to {T_HOT_C:.0f} °C")
    figures = {"blocked_N": c.blocked_N, "free_pct": c.free_pct,
               "work_J_per_m": c.work_J_per_m(), "linear_work_J_per_m": lin.work_J_per_m()}
    return Sweep([csv, png], []), figures


def max_work_sweep(out: str | os.PathLike, envelope: str, n: int) -> Sweep:
    """Work of one heating from T_i to T_f over 25–70 °C on an ``n``-cell grid (§2.3).

    Writes ``max_work_{envelope}.csv`` and two figures: work (MJ/m³) and work
    per degree (MJ/(m³·K))."""
    if n < 2:
        raise CranktrackError(f"--n must be at least 2, not {n}")
    out = ensure_dir(out)
    T = np.linspace(25.0, 70.0, n)
    method = "analytic" if envelope == "linear" else "trapezoid"
    m = max_work_map(T, T, envelope, method)
    Ti, Tf = np.meshgrid(m.Ti_C, m.Tf_C, indexing="ij")
    table = pd.DataFrame({"Ti_C": Ti.ravel(), "Tf_C": Tf.ravel(),
                          "work_MJ_m3": m.work_MJ_m3.ravel(),
                          "work_per_K_MJ_m3K": m.per_kelvin.ravel()})
    name = f"max_work_{envelope}"
    files = [write_csv_atomic(out / f"{name}.csv", table)]
    axes = ("final temperature T_f (°C)", "start temperature T_i (°C)")
    optima = []
    for z, best, what, unit, suffix in (
            (m.work_MJ_m3, m.optimum(), "Work", "MJ/m³", ""),
            (m.per_kelvin, m.optimum_per_kelvin(), "Work per degree", "MJ/(m³·K)", "_per_K")):
        # plot_map wants (value, x, y): x is T_f (columns), y is T_i (rows).
        files.append(plot_map(m.Tf_C, m.Ti_C, z, out / f"{name}{suffix}.png",
                              f"{what}, {envelope} envelope", f"{what.lower()} ({unit})",
                              (best[0], best[2], best[1]), axes, "white: T_f ≤ T_i"))
        optima.append(Optimum(what, best[0], unit, {"T_i (°C)": best[1], "T_f (°C)": best[2]}))
    return Sweep(files, optima)
