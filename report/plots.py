"""PNG plots of measured vs model kinematics, in the style of thesis Figs. 2.34–2.36."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

#: (file name, title, panels: (column, y label)) — thesis figure numbers in the titles.
FIGURES = (
    ("fig_2_34_vB_xy.png", "Velocity of B (cf. thesis Fig. 2.34)",
     (("vB_x_mm_s", "v_B,x (mm/s)"), ("vB_y_mm_s", "v_B,y (mm/s)"))),
    ("fig_2_35_vB_mag_dir.png", "Speed and direction of B (cf. thesis Fig. 2.35)",
     (("vB_mm_s", "|v_B| (mm/s)"), ("vB_dir_deg", "direction of v_B (deg)"))),
    ("fig_2_36_omega.png", "Angular velocity of link 2 (cf. thesis Fig. 2.36)",
     (("omega_rad_s", "ω (rad/s)"),)),
    ("fig_theta.png", "Crank angle θ", (("theta_deg", "θ (deg)"),)),
)


#: Direction of v_B is drawn only where |v_B| exceeds this many σ of itself and this
#: fraction of its peak: below, B hardly moves, and a still marker's slow codec drift
#: (which its σ need not cover) would be drawn as a direction of travel.
DIRECTION_MIN_SIGMAS = 3.0
DIRECTION_MIN_OF_PEAK = 0.02


def _direction_shown(table: pd.DataFrame, curve: pd.DataFrame | None
                     ) -> tuple[np.ndarray, np.ndarray | None]:
    """Masks of the measured rows and the model's curve where v_B's direction means
    something: measured |v_B| above :data:`DIRECTION_MIN_SIGMAS` σ and
    :data:`DIRECTION_MIN_OF_PEAK` of its peak, the model's |v_B| above 0.1 % of its
    peak."""
    v, sv = table["vB_mm_s_measured"], table["vB_mm_s_measured_sigma"]
    peak = np.nanmax(v.to_numpy(float), initial=0.0)
    rows = ((v > DIRECTION_MIN_SIGMAS * sv) & (v > DIRECTION_MIN_OF_PEAK * peak)).to_numpy()
    if curve is None:
        return rows, None
    speed = curve["vB_mm_s"].to_numpy(float)
    return rows, speed > 1e-3 * np.nanmax(np.abs(speed), initial=0.0)


def plot_comparison(table: pd.DataFrame, folder: str | os.PathLike,
                    curve: pd.DataFrame | None = None) -> list[Path]:
    """Write the comparison figures from a :func:`compare_spool` table; returns the paths.

    Measured values are dots with a ±1σ band, the fitted model a line — through
    ``curve`` (the model between frames, :func:`~cranktrack.loop.compare.model_curve`)
    when given, so the drive's steps are steps — and under each panel the residual,
    measured − model, with the same ±1σ band about zero. The direction of v_B is left
    out where B hardly moves (:data:`DIRECTION_MIN_SIGMAS`).
    """
    out = []
    t = table["t_s"]
    shown, curve_shown = _direction_shown(table, curve)
    for name, title, panels in FIGURES:
        fig = Figure(figsize=(6.4, 3.4 * len(panels) + 0.6))
        axes = fig.subplots(2 * len(panels), 1, sharex=True, squeeze=False,
                            gridspec_kw={"height_ratios": [3, 1] * len(panels)})[:, 0]
        for ax, res, (col, label) in zip(axes[::2], axes[1::2], panels, strict=True):
            m, s = table[f"{col}_measured"], table[f"{col}_measured_sigma"]
            err = table[f"{col}_error"]
            if col == "vB_dir_deg":
                m, s, err = m.where(shown), s.where(shown), err.where(shown)
            ax.fill_between(t, m - s, m + s, color="tab:blue", alpha=0.25, lw=0,
                            label="measured ±1σ")
            ax.plot(t, m, ".", color="tab:blue", ms=3, label="measured")
            if curve is not None:
                y = curve[col].where(curve_shown) if col == "vB_dir_deg" else curve[col]
                ax.plot(curve["t_s"], y, "-", color="tab:red", lw=1.2, label="model (fitted)")
            else:
                ax.plot(t, table[f"{col}_model"], "-", color="tab:red", lw=1.2,
                        label="model (fitted)")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
            res.fill_between(t, -s, s, color="tab:blue", alpha=0.25, lw=0)
            res.axhline(0.0, color="tab:red", lw=0.8)
            res.plot(t, err, ".", color="tab:purple", ms=3)
            res.set_ylabel("residual", fontsize=8)
            res.grid(alpha=0.3)
        axes[0].legend(loc="best", fontsize=8)
        axes[-1].set_xlabel("t (s)")
        fig.suptitle(title)
        fig.tight_layout()
        path = Path(folder) / name
        fig.savefig(path, dpi=110)
        out.append(path)
    return out


def plot_map(x: np.ndarray, y: np.ndarray, z: np.ndarray, path: str | os.PathLike,
             title: str, label: str, optimum: tuple[float, float, float] | None = None,
             axes: tuple[str, str] = ("frame length L1 / L2", "starting angle θ0 (deg)"),
             note: str = "white: the mechanism cannot close (Fig. 2.5)") -> Path:
    """A filled contour map, by default over (L1/L2, θ0) like thesis Figs. 2.6 and 2.41."""
    fig = Figure(figsize=(6.4, 4.8))
    ax = fig.subplots()
    levels = np.linspace(np.nanmin(z), np.nanmax(z), 15)
    cs = ax.contourf(x, y, z, levels=levels, cmap="viridis")
    fig.colorbar(cs, ax=ax, label=label)
    if optimum is not None:
        ax.plot(optimum[1], optimum[2], "r*", ms=12, label=f"max {optimum[0]:.1f}")
        ax.legend(loc="lower right", fontsize=8)
    ax.set_xlabel(axes[0])
    ax.set_ylabel(axes[1])
    ax.set_title(title)
    ax.text(0.02, 0.02, note, transform=ax.transAxes, fontsize=7)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    return out


def plot_actuator_curves(curves: dict[str, tuple[np.ndarray, np.ndarray]],
                         path: str | os.PathLike, title: str) -> Path:
    """Force against stroke for named actuator curves, like thesis Fig. 2.14."""
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.subplots()
    for name, (stroke, force) in curves.items():
        ax.plot(stroke, force, label=name)
    ax.set_xlabel("stroke (% of wire length)")
    ax.set_ylabel("force (N)")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    return out


def plot_phase_portrait(dyn, path: str | os.PathLike, starts: list[tuple[float, float]],
                        t_end: float = 30.0, title: str = "") -> Path:
    """Phase portrait of eq. 3.28: vector field, trajectories from ``starts`` (θ, ω), equilibria."""
    th = np.linspace(0.05, 2 * np.pi - 0.05, 31)
    om = np.linspace(-1.5, 1.5, 25)
    T, W = np.meshgrid(th, om)
    fig = Figure(figsize=(6.4, 4.8))
    ax = fig.subplots()
    ax.quiver(T, W, W, dyn.accel(T, W), color="tab:red", alpha=0.5, angles="xy")
    t = np.linspace(0, t_end, 3000)
    for th0, om0 in starts:
        y, v = dyn.simulate(t, th0, om0)
        ax.plot(y, v, "-", lw=1.0)
        ax.plot(th0, om0, "ko", ms=3)
    for e in dyn.equilibria():
        ax.plot(e, 0, "kx", ms=8)
    ax.set_xlim(0, 2 * np.pi)
    ax.set_ylim(-1.5, 1.5)
    ax.set_xlabel("θ (rad)")
    ax.set_ylabel("ω (rad/s)")
    ax.set_title(title or f"SR = {dyn.stiffness_ratio:.2f}")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    return out
