"""The per-frame loop: frames in, a tracks table out."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from cranktrack.errors import CranktrackError
from cranktrack.tracker.markers import DEFAULT_MARKERS, MarkerSpec, detect_all
from cranktrack.tracker.video import FrameSource, timing_report


@dataclass
class TrackResult:
    """The tracks table and what the run learned about the footage."""

    tracks: pd.DataFrame
    timing: dict
    found_fraction: dict[str, float]
    problems: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready summary for ``run.json``."""
        return {"timing": self.timing, "found_fraction": self.found_fraction,
                "problems": self.problems}


def track(
    source: FrameSource,
    specs: tuple[MarkerSpec, ...] = DEFAULT_MARKERS,
    on_frame: Callable[[int], None] | None = None,
) -> TrackResult:
    """Find every marker in every frame of ``source``.

    Returns one row per decoded frame with ``frame``, ``t_s`` and, per marker,
    ``_x_px``, ``_y_px``, ``_sigma_px``, ``_ok``. A marker not found is NaN
    with ``_ok = False``; nothing is interpolated.

    A marker found in no frame is still a column (all NaN); ``found_fraction``
    says so and the caller decides what to tell the user.

    Raises
    ------
    CranktrackError
        No frame could be decoded.
    """
    rows: list[list[float]] = []
    times: list[float] = []
    for frame in source.frames():
        found = detect_all(frame.rgb, specs)
        row: list[float] = [frame.index, frame.t_s]
        for spec in specs:
            d = found[spec.name]
            row += [d.x, d.y, d.sigma, d.ok]
        rows.append(row)
        times.append(frame.t_s)
        if on_frame:
            on_frame(frame.index)
    if not rows:
        raise CranktrackError(f"no frame of {source.path} could be decoded")
    cols = ["frame", "t_s"] + [
        spec.name + s for spec in specs for s in ("_x_px", "_y_px", "_sigma_px", "_ok")]
    tracks = pd.DataFrame(rows, columns=cols)
    tracks["frame"] = tracks["frame"].astype(int)
    for spec in specs:
        tracks[spec.name + "_ok"] = tracks[spec.name + "_ok"].astype(bool)
    found_fraction = {s.name: float(tracks[s.name + "_ok"].mean()) for s in specs}
    return TrackResult(tracks, timing_report(np.asarray(times), source.nominal_fps),
                       found_fraction, list(source.problems))
