"""A rolling shutter: each marker's fix taken back to its frame's time.

Most phone and webcam sensors read their rows one after another. The frame's
timestamp is when the top row was read; row ``y`` (px from the top) is read
``ρ·y`` later, where ρ is the readout time of the frame divided by its height.
A marker low in the frame was therefore seen later than one high in it, and the
crank's points of one frame are not of one instant: the angle at A and the rigid
links come out bent where the crank moves fast.

The correction is checked against a renderer that draws each row at its own time
(``bench/rolling_shutter.py``). The readout comes from the closed loop on the
crank-slider, or from ``cranktrack calibrate readout`` on a ball tossed square to the
camera (:mod:`..calibration.readout`). On Tracker's public toss, a parabola with its
time taken per row fits with 6.7–6.9 ± 1.0 ms. A flight plane turned to the camera
fits it better, though, so that toss does not settle its camera's readout.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import CranktrackError


def at_frame_times(tracks: pd.DataFrame, readout_s: float, height_px: int,
                   markers: tuple[str, ...] = ("A", "B", "C")) -> pd.DataFrame:
    """The tracks with each marker's plane position (``_x_mm``, ``_y_mm``) moved to its
    frame's time ``t_s``, from the time its row was read, ``t_s + readout_s·y/height``.

    ``readout_s`` is the time (s) between reading the top row and the bottom row of a
    frame ``height_px`` rows tall; ``y`` is the marker's row, ``_y_px``. Each marker's
    fixes, at the times they were seen, are joined by a cubic spline and read at the
    frames' times. Its pixel columns keep what was seen. A frame whose marker was not
    found stays empty.

    Raises
    ------
    CranktrackError
        ``readout_s`` is negative, or not shorter than the time between frames (rows
        would then be read after the next frame began).
    """
    t = tracks["t_s"].to_numpy(float)
    step = float(np.median(np.diff(t))) if t.size > 1 else float("inf")
    if not 0.0 <= readout_s < step:
        raise CranktrackError(f"a rolling-shutter readout of {readout_s * 1e3:g} ms does not "
                              f"fit in a frame ({step * 1e3:.3g} ms): give the time from the "
                              "top row to the bottom row of one frame, in ms")
    out = tracks.copy()
    if readout_s == 0.0:
        return out
    # SciPy's interpolation (0.28 s to import) only when there is a readout to correct:
    # `track` imports this module before its first frame.
    from scipy.interpolate import CubicSpline

    rho = readout_s / height_px
    for m in markers:
        cols = [f"{m}_x_mm", f"{m}_y_mm"]
        if not {*cols, f"{m}_y_px"} <= set(tracks.columns):
            continue
        xy = tracks[cols].to_numpy(float)
        seen = t + rho * tracks[f"{m}_y_px"].to_numpy(float)
        ok = np.isfinite(seen) & np.all(np.isfinite(xy), axis=1)
        if ok.sum() < 4 or np.any(np.diff(seen[ok]) <= 0):
            continue  # too few fixes, or times that do not advance: left as seen
        spline = CubicSpline(seen[ok], xy[ok], axis=0)
        moved = np.full_like(xy, np.nan)
        moved[ok] = spline(t[ok])
        out[cols] = moved
    return out
