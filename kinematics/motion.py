"""How each marker moves in the plane: its velocity and acceleration with σ.

The crank-slider's kinematics (:mod:`.measured`) are angles and rates of a
mechanism. A ball tossed before a metre stick, a pendulum's bob or a cart on a
track has none of those, only a point that moves; what a lab user wants of it is
its velocity and acceleration in mm/s and mm/s². This module gives them for every
marker of a run with a scale, the crank-slider's included.

Each axis of each marker is differentiated on its own (:func:`.measured.rates`): its
window is the one with the least leave-one-out error (:func:`.choose_window`), so a
falling ball's steady x takes a long window and its y the one its curve allows, and
its σ is the tracker's σ scaled to the leave-one-out residuals nearby
(:func:`.measured.noise_scale`), plus the window's bias. Frames whose picture
repeats the one before are left out as in the kinematics: their time is not when
their picture was taken.

>>> import numpy as np, pandas as pd
>>> t = np.arange(60) / 100.0
>>> y = 500.0 - 0.5 * 9810.0 * t**2
>>> tracks = pd.DataFrame({"frame": np.arange(60), "t_s": t, "ball_ok": True,
...                        "ball_x_px": 10.0 * t, "ball_y_px": y, "ball_x_mm": 10.0 * t,
...                        "ball_y_mm": y, "ball_sigma_mm": 0.01})
>>> table, info = marker_motion(tracks, ("ball",))
>>> round(float(np.nanmedian(table["ball_ay_mm_s2"])))
-9810
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import CranktrackError
from .differentiate import choose_window, local_polynomial
from .measured import noise_scale, rates, repeated_rows, window_samples

#: The columns per marker, in mm/s and mm/s², each followed by its ``_sigma``.
MOTION_VALUES = ("vx_mm_s", "vy_mm_s", "speed_mm_s", "ax_mm_s2", "ay_mm_s2")


@dataclass(frozen=True)
class MotionInfo:
    """How the motion was measured, per marker and axis (``"ball_x"``): the window
    (samples), the σ scale (median over the run) and the frames left out."""

    windows: dict[str, int]
    sigma_scales: dict[str, float]
    repeated_frames: int = 0

    def to_dict(self) -> dict:
        return {"window_samples": self.windows, "sigma_scale": self.sigma_scales,
                "repeated_frames": self.repeated_frames}


def marker_motion(tracks: pd.DataFrame, names: tuple[str, ...],
                  window_s: float | None = None, order: int = 2,
                  scale_sigma: float = 0.0) -> tuple[pd.DataFrame, MotionInfo]:
    """The motion table of markers ``names`` from a tracks table with plane coordinates.

    ``tracks`` has ``t_s`` and per marker ``_ok``, ``_x_mm``, ``_y_mm`` and
    ``_sigma_mm``. ``window_s`` fixes the differentiator's window (s; default: chosen
    per axis from the data), ``order`` is the local polynomials' degree and
    ``scale_sigma`` the calibration's relative 1-σ, added to every rate's σ.

    Returns ``frame``, ``t_s`` and per marker ``NAME_vx_mm_s``, ``NAME_vy_mm_s``,
    ``NAME_speed_mm_s``, ``NAME_ax_mm_s2``, ``NAME_ay_mm_s2``, each with ``_sigma``;
    NaN where the marker was not found in enough neighbouring frames. The plane's y is
    up, so a falling body's ``ay`` is negative.
    """
    for m in names:
        if f"{m}_x_mm" not in tracks:
            raise CranktrackError(f"the tracks have no plane coordinates for marker {m}; "
                                  "give a scale first")
    repeat = repeated_rows(tracks, names)
    kept = tracks[~repeat].reset_index(drop=True)
    t = kept["t_s"].to_numpy(float)
    columns: dict[str, NDArray] = {}
    windows: dict[str, int] = {}
    scales: dict[str, float] = {}
    for m in names:
        ok = kept[f"{m}_ok"].astype(bool).to_numpy()
        sigma = np.where(ok, kept[f"{m}_sigma_mm"].to_numpy(float), np.nan)
        fits = {}
        for axis in "xy":
            y = np.where(ok, kept[f"{m}_{axis}_mm"].to_numpy(float), np.nan)
            if window_s is None:
                w, _ = choose_window(t, y, sigma, order)
            else:
                w = window_samples(t, window_s, order)
            fit = local_polynomial(t, y, sigma, w, order, adaptive=True)
            scale = noise_scale(fit.loo, sigma, fit.value_sigma, fit.shifted)
            fits[axis] = rates(t, y, sigma, w, order, scale, fit, richardson=True)
            windows[f"{m}_{axis}"] = int(w)
            scales[f"{m}_{axis}"] = float(np.median(scale))
        dx, dy = fits["x"], fits["y"]
        speed = np.hypot(dx.d1, dy.d1)
        # The axes' σ along the velocity are added, not in quadrature: a window's bias
        # shrinks both components of a turning body's velocity alike (drawn circles: in
        # quadrature the speed's σ held the truth in 34 % of frames).
        with np.errstate(invalid="ignore", divide="ignore"):
            speed_sigma = (np.abs(dx.d1) * dx.d1_sigma + np.abs(dy.d1) * dy.d1_sigma) / speed
        # Standing still, the speed's σ is the whole velocity's.
        still = ~(speed > 0)
        speed_sigma[still] = np.hypot(dx.d1_sigma, dy.d1_sigma)[still]
        for col, value, sig in (("vx_mm_s", dx.d1, dx.d1_sigma), ("vy_mm_s", dy.d1, dy.d1_sigma),
                                ("speed_mm_s", speed, speed_sigma),
                                ("ax_mm_s2", dx.d2, dx.d2_sigma),
                                ("ay_mm_s2", dy.d2, dy.d2_sigma)):
            columns[f"{m}_{col}"] = value
            # The scale's error is shared by every frame's rates.
            columns[f"{m}_{col}_sigma"] = np.hypot(sig, np.abs(value) * scale_sigma)
    table = pd.DataFrame({"frame": kept["frame"].to_numpy(), "t_s": t, **columns})
    if repeat.any():
        table = (table.set_index("frame").reindex(tracks["frame"].to_numpy())
                 .rename_axis("frame").reset_index())
        table["t_s"] = tracks["t_s"].to_numpy(float)
    return table, MotionInfo(windows, scales, int(repeat.sum()))
