"""Filling short gaps in tracks, only when the user asks, and always flagged."""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import NDArray


def segments(valid: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the runs of ``True`` in ``valid``."""
    v = np.concatenate([[False], np.asarray(valid, bool), [False]])
    edges = np.flatnonzero(np.diff(v.astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def fill_gaps(tracks: pd.DataFrame, markers: tuple[str, ...], max_frames: int) -> pd.DataFrame:
    """A copy of ``tracks`` with gaps of at most ``max_frames`` frames interpolated.

    Positions are interpolated linearly in time between the last fix before
    and the first after the gap. Filled rows keep ``_ok = False`` (they were
    not measured) and get ``_status = "interpolated"``; their ``_sigma_px`` is
    the larger of the neighbours' σ plus half the distance between where the
    motion before the gap and the motion after it, each extrapolated to that
    frame, would put the marker: the interpolation is only as good as those
    two stories agree. Gaps at the start or end, or longer than
    ``max_frames``, stay NaN.
    """
    out = tracks.copy()
    t = out["t_s"].to_numpy(float)
    for m in markers:
        x = out[f"{m}_x_px"].to_numpy(float).copy()
        y = out[f"{m}_y_px"].to_numpy(float).copy()
        s = out[f"{m}_sigma_px"].to_numpy(float).copy()
        status = out[f"{m}_status"].to_numpy(object).copy() if f"{m}_status" in out else None
        found = np.isfinite(x) & np.isfinite(y)
        for a, b in segments(~found):
            if a == 0 or b == len(x) or b - a > max_frames:
                continue
            i0, i1 = a - 1, b  # last fix before, first after
            w = (t[a:b] - t[i0]) / (t[i1] - t[i0])
            x[a:b] = x[i0] + w * (x[i1] - x[i0])
            y[a:b] = y[i0] + w * (y[i1] - y[i0])
            spread = np.zeros(b - a)
            if i0 >= 1 and found[i0 - 1] and i1 + 1 < len(x) and found[i1 + 1]:
                v0 = np.array([x[i0] - x[i0 - 1], y[i0] - y[i0 - 1]]) / (t[i0] - t[i0 - 1])
                v1 = np.array([x[i1 + 1] - x[i1], y[i1 + 1] - y[i1]]) / (t[i1 + 1] - t[i1])
                fwd = np.array([x[i0], y[i0]])[:, None] + v0[:, None] * (t[a:b] - t[i0])
                bwd = np.array([x[i1], y[i1]])[:, None] + v1[:, None] * (t[a:b] - t[i1])
                spread = 0.5 * np.hypot(*(fwd - bwd))
            s[a:b] = max(s[i0], s[i1]) + spread
            if status is not None:
                status[a:b] = "interpolated"
        out[f"{m}_x_px"], out[f"{m}_y_px"], out[f"{m}_sigma_px"] = x, y, s
        if status is not None:
            out[f"{m}_status"] = status
    return out


def found_span(found: NDArray[np.bool_], t_s: NDArray[np.floating]) -> str | None:
    """Where a marker found in some frames was found, when most of the frames it was
    missed in come before its first fix or after its last (it came into view late, or
    left it, was covered or went out): a clause for the warning that it was found in
    few frames. None when it was found in every frame or none, or when its misses are
    scattered through the run. ``t_s``: each frame's time, s."""
    found = np.asarray(found, bool)
    n, k = len(found), int(found.sum())
    if k in (0, n):
        return None
    first, last = (int(i) for i in np.flatnonzero(found)[[0, -1]])
    before, after = first, n - 1 - last
    if before + after < 0.5 * (n - k):
        return None
    span = last - first + 1
    said = [f"in one frame, at {t_s[first]:.2f} s" if span == 1 else
            f"in {int(found[first:last + 1].sum())} of the {span} frames from "
            f"{t_s[first]:.2f} s to {t_s[last]:.2f} s"]
    if before:
        said.append(f"in none of the {before} before")
    if after:
        said.append(f"in none of the {after} after")
    return ", ".join(said[:-1]) + " and " + said[-1] + " (out of view, covered or unlit there)"
