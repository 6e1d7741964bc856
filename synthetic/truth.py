"""The ground-truth table written beside every render.

It has the columns of the tracks table (pixel and plane coordinates, with
σ = 0 and ``_ok`` true wherever the marker centre is inside the image) and of
the kinematics table (σ = 0), all exact.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..kinematics.table import kinematics_table
from .camera import Camera
from .scenarios import Motion


def truth_table(motion: Motion, camera: Camera) -> pd.DataFrame:
    """Exact tracks and kinematics for each frame of a render."""
    n = len(motion.t_s)
    cols: dict[str, np.ndarray] = {}
    for name, xy in motion.points_mm.items():
        uv = camera.project(xy)
        inside = ((uv[:, 0] >= -0.5) & (uv[:, 0] <= camera.width - 0.5)
                  & (uv[:, 1] >= -0.5) & (uv[:, 1] <= camera.height - 0.5))
        cols[f"{name}_x_px"] = uv[:, 0]
        cols[f"{name}_y_px"] = uv[:, 1]
        cols[f"{name}_sigma_px"] = np.zeros(n)
        cols[f"{name}_ok"] = inside
    for name, xy in motion.points_mm.items():
        cols[f"{name}_x_mm"] = xy[:, 0]
        cols[f"{name}_y_mm"] = xy[:, 1]
        cols[f"{name}_sigma_mm"] = np.zeros(n)
    kin = kinematics_table(motion.t_s, motion.theta, motion.omega, motion.alpha,
                           motion.vB_mm_s, motion.L3_mm, motion.L3_rate_mm_s)
    tracks = pd.DataFrame(cols)
    return pd.concat([kin[["frame", "t_s"]], tracks, kin.drop(columns=["frame", "t_s"])],
                     axis=1)
