"""PNG plots of measured vs model kinematics, in the style of thesis Figs. 2.34–2.36."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never a window
import matplotlib.pyplot as plt
import pandas as pd

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


def plot_comparison(table: pd.DataFrame, folder: str | os.PathLike) -> list[Path]:
    """Write the comparison figures from a :func:`compare_spool` table; returns the paths.

    Measured values are dots with a ±1σ band, the model a line.
    """
    out = []
    t = table["t_s"]
    for name, title, panels in FIGURES:
        fig, axes = plt.subplots(len(panels), 1, figsize=(6.4, 2.6 * len(panels) + 0.6),
                                 sharex=True, squeeze=False)
        for ax, (col, label) in zip(axes[:, 0], panels, strict=True):
            m, s = table[f"{col}_measured"], table[f"{col}_measured_sigma"]
            ax.fill_between(t, m - s, m + s, color="tab:blue", alpha=0.25, lw=0,
                            label="measured ±1σ")
            ax.plot(t, m, ".", color="tab:blue", ms=3, label="measured")
            ax.plot(t, table[f"{col}_model"], "-", color="tab:red", lw=1.2, label="model")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        axes[0, 0].legend(loc="best", fontsize=8)
        axes[-1, 0].set_xlabel("t (s)")
        fig.suptitle(title)
        fig.tight_layout()
        path = Path(folder) / name
        fig.savefig(path, dpi=110)
        plt.close(fig)
        out.append(path)
    return out
