"""The per-frame loop: frames in, a tracks table out.

Each marker is *acquired* by a full-frame colour search (the first frame,
and again whenever it is lost), then *followed* in a small window around a
constant-velocity prediction, so most frames touch only a few thousand
pixels per marker. Its colour window is learned from the first acquisition.
Every found blob is refined to a sub-pixel centre with a 1-σ
(:mod:`.refine`). A marker not found is NaN with ``_ok = False`` and a
``_status`` that says why; nothing is interpolated.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from cranktrack.tracker.markers import (
    DEFAULT_MARKERS,
    Blob,
    MarkerSpec,
    choose_blob,
    find_blobs,
    learn_spec,
)
from cranktrack.tracker.refine import Centre, fit_disc, local_coverage, weighted_centroid
from cranktrack.tracker.video import FrameSource, timing_report

#: Why a marker has no position in a frame (the ``_status`` column).
STATUSES = {
    "ok": "found",
    "not_found": "no blob of the marker's colour where it was looked for",
    "rejected": "blobs of the colour, but none of the marker's size and shape",
    "out_of_view": "the predicted position is outside the image",
    "refine_failed": "a blob was found but no sub-pixel centre could be fitted",
}


@dataclass
class _MarkerState:
    spec: MarkerSpec
    learned: bool = False
    radius: float | None = None
    area: float | None = None
    history: list[tuple[float, float, float]] = field(default_factory=list)  # (t, x, y)

    def predict(self, t: float) -> tuple[float, float] | None:
        """Constant-velocity prediction from the last two fixes (px)."""
        if not self.history:
            return None
        t1, x1, y1 = self.history[-1]
        if len(self.history) < 2:
            return x1, y1
        t0, x0, y0 = self.history[-2]
        if t1 <= t0:
            return x1, y1
        k = (t - t1) / (t1 - t0)
        return x1 + k * (x1 - x0), y1 + k * (y1 - y0)

    def speed_px(self) -> float:
        """Displacement between the last two fixes, px."""
        if len(self.history) < 2:
            return 0.0
        (_, x0, y0), (_, x1, y1) = self.history[-2:]
        return float(np.hypot(x1 - x0, y1 - y0))


def _patch(rgb: NDArray[np.uint8], cx: float, cy: float, half: float
           ) -> tuple[NDArray[np.uint8], int, int]:
    h, w = rgb.shape[:2]
    x0, y0 = max(int(cx - half), 0), max(int(cy - half), 0)
    x1, y1 = min(int(cx + half) + 1, w), min(int(cy + half) + 1, h)
    return rgb[y0:y1, x0:x1], x0, y0


def refine(rgb: NDArray[np.uint8], guess: tuple[float, float], radius: float) -> Centre:
    """Sub-pixel centre of a marker near ``guess`` (see :mod:`.refine`).

    Chroma unmixing against a ring background around the guess, a weighted
    centroid, then the ring re-centred there and a blurred-disc fit.
    """
    patch, x0, y0 = _patch(rgb, guess[0], guess[1], radius + 9)
    alpha, _ = local_coverage(patch, x0, y0, guess, radius)
    c = weighted_centroid(alpha, x0, y0, guess, radius, noise_alpha=0.05)
    if not c.ok:
        return c
    alpha, _ = local_coverage(patch, x0, y0, (c.x, c.y), radius)
    fit = fit_disc(alpha, x0, y0, (c.x, c.y), radius)
    return fit if fit.ok else Centre(c.x, c.y, c.sigma, c.radius, True)


def _plausible(c: Centre, guess: tuple[float, float], radius: float) -> bool:
    """A fit from a prediction that really is the marker: whole, right size, nearby."""
    return (c.ok and 0.6 < c.gain < 1.4 and abs(c.radius - radius) < 0.25 * radius
            and np.hypot(c.x - guess[0], c.y - guess[1]) < radius)


def _locate(rgb: NDArray[np.uint8], state: _MarkerState, t: float, hsv_cache: dict
            ) -> tuple[Centre | None, str]:
    h, w = rgb.shape[:2]
    pred = state.predict(t)
    blob, status = None, "not_found"
    if pred is not None and state.radius is not None:
        r = state.radius
        if not (-r <= pred[0] <= w + r and -r <= pred[1] <= h + r):
            status = "out_of_view"
        else:
            # Following: refine straight from the prediction; the colour search
            # is only needed when that fails (fast motion, occlusion, a jump).
            if r + 2 <= pred[0] <= w - r - 3 and r + 2 <= pred[1] <= h - r - 3:
                centre = refine(rgb, pred, r)
                if _plausible(centre, pred, r):
                    return centre, "ok"
            half = 3.0 * r + 2.0 * state.speed_px() + 4.0
            patch, x0, y0 = _patch(rgb, pred[0], pred[1], half)
            hsv = cv2.cvtColor(np.ascontiguousarray(patch), cv2.COLOR_RGB2HSV)
            blob, status = choose_blob(find_blobs(hsv, state.spec, x0, y0), state.area, pred)
    if blob is None:
        # Lost (or never seen): search the whole frame.
        if "full" not in hsv_cache:
            hsv_cache["full"] = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
        blob, full_status = choose_blob(find_blobs(hsv_cache["full"], state.spec), state.area,
                                        pred)
        if blob is None:
            return None, status if status == "out_of_view" else full_status
    radius = state.radius or blob.radius
    if not state.learned:
        patch, x0, y0 = _patch(rgb, blob.x, blob.y, radius + 3)
        state.spec = learn_spec(state.spec, patch, (blob.x, blob.y), radius, x0, y0)
        state.learned = True
    centre = refine(rgb, (blob.x, blob.y), radius)
    if not centre.ok:
        return None, "refine_failed"
    if state.radius is None:
        state.radius, state.area = centre.radius, np.pi * centre.radius**2
    return centre, "ok"


@dataclass
class TrackResult:
    """The tracks table and what the run learned about the footage."""

    tracks: pd.DataFrame
    timing: dict
    found_fraction: dict[str, float]
    problems: list[str] = field(default_factory=list)
    learned: dict[str, dict] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready summary for ``run.json``."""
        return {"timing": self.timing, "found_fraction": self.found_fraction,
                "problems": self.problems, "learned_markers": self.learned}


def track(
    source: FrameSource,
    specs: tuple[MarkerSpec, ...] = DEFAULT_MARKERS,
    on_frame: Callable[[int], None] | None = None,
) -> TrackResult:
    """Find every marker in every frame of ``source``.

    Returns one row per decoded frame with ``frame``, ``t_s`` and, per marker,
    ``_x_px``, ``_y_px``, ``_sigma_px`` (per-axis 1-σ, px), ``_ok`` and
    ``_status`` (a key of :data:`STATUSES`). A marker found in no frame is
    still a column (all NaN); ``found_fraction`` says so and the caller
    decides what to tell the user.

    Raises
    ------
    CranktrackError
        No frame could be decoded.
    """
    from cranktrack.errors import CranktrackError

    states = [_MarkerState(spec) for spec in specs]
    rows: list[list] = []
    for frame in source.frames(prefetch=8):
        row: list = [frame.index, frame.t_s]
        hsv_cache: dict = {}
        for st in states:
            centre, status = _locate(frame.rgb, st, frame.t_s, hsv_cache)
            if centre is None:
                row += [np.nan, np.nan, np.nan, False, status]
            else:
                st.history = [*st.history[-1:], (frame.t_s, centre.x, centre.y)]
                row += [centre.x, centre.y, centre.sigma, True, status]
            if centre is None:
                st.history = []  # a lost marker is searched for afresh
        rows.append(row)
        if on_frame:
            on_frame(frame.index)
    if not rows:
        raise CranktrackError(f"no frame of {source.path} could be decoded")
    cols = ["frame", "t_s"] + [
        s.name + suffix for s in specs
        for suffix in ("_x_px", "_y_px", "_sigma_px", "_ok", "_status")]
    tracks = pd.DataFrame(rows, columns=cols)
    tracks["frame"] = tracks["frame"].astype(int)
    for s in specs:
        tracks[s.name + "_ok"] = tracks[s.name + "_ok"].astype(bool)
    found = {s.name: float(tracks[s.name + "_ok"].mean()) for s in specs}
    learned = {st.spec.name: {"hue_deg": round(st.spec.hue_deg, 2),
                              "hue_tol_deg": round(st.spec.hue_tol_deg, 2),
                              "radius_px": None if st.radius is None else round(st.radius, 3)}
               for st in states}
    return TrackResult(tracks, timing_report(tracks["t_s"].to_numpy(), source.nominal_fps),
                       found, list(source.problems), learned)
