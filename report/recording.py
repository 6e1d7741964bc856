"""A run as a Rerun recording: the video with the tracking drawn on it, and the plots.

Layout of the entities (timeline ``time``: the video's presentation time, s):

- ``video``: the video file as one ``AssetVideo`` (referenced once, not
  copied frame by frame) and a ``VideoFrameReference`` per frame on the
  container's own timestamps;
- ``video/markers/<name>``: each detected marker, radius = 3σ (at least 2 px);
- ``video/links/{AB,AC,BC}``: the crank, the frame and the wire;
- ``video/model/{A,B,C}``: where the fitted model puts the markers, in
  another colour (the closed loop's final model when ``cranktrack fit`` has
  run, else the ``compare`` fit);
- ``plots/<quantity>/{measured,model}`` and ``plots/residual/theta``:
  θ, ω, |v_B| measured and modelled, and the residual θ − θ_model;
- after ``cranktrack fit``: ``plots/theta/fitted`` (the model with the
  accepted effects) and ``plots/residual/{before,after}`` (θ residual of the
  base model and of the model with the effects).

A blueprint lays it out with the video on the left and the plots on the right.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
import rerun as rr
import rerun.blueprint as rrb

from ..errors import ViewerUnavailableError

MARKER_COLOURS = {"A": (40, 170, 70), "B": (220, 40, 45), "C": (40, 80, 220)}
MODEL_COLOUR = (255, 200, 0)
PLOTS = (("theta", "theta_deg", "θ (deg)"), ("omega", "omega_rad_s", "ω (rad/s)"),
         ("vB", "vB_mm_s", "|v_B| (mm/s)"))


def blueprint() -> rrb.Blueprint:
    """Video on the left, θ / ω / |v_B| / residual stacked on the right."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(origin="/video", name="video"),
            rrb.Vertical(*[rrb.TimeSeriesView(origin=f"/plots/{key}", name=label)
                           for key, _, label in PLOTS],
                         rrb.TimeSeriesView(origin="/plots/residual", name="residual θ (deg)")),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


def _column_points(rec: rr.RecordingStream, path: str, t: np.ndarray, xy: np.ndarray,
                   radii: np.ndarray, colour: tuple[int, int, int], label: str) -> None:
    ok = np.isfinite(xy).all(axis=1) & np.isfinite(t)
    if not ok.any():
        return
    n = int(ok.sum())
    rec.send_columns(
        path, indexes=[rr.TimeColumn("time", duration=t[ok])],
        columns=rr.Points2D.columns(positions=xy[ok], radii=radii[ok],
                                    colors=np.tile(colour, (n, 1)),
                                    labels=[label] * n).partition([1] * n))


def write_recording(
    path: str | os.PathLike,
    video: str | os.PathLike | None,
    tracks: pd.DataFrame,
    kinematics: pd.DataFrame | None = None,
    comparison: pd.DataFrame | None = None,
    model_px: dict[str, np.ndarray] | None = None,
    spawn: bool = False,
    fit: pd.DataFrame | None = None,
) -> Path:
    """Write (and with ``spawn``, also show) the recording of a run.

    Parameters
    ----------
    path : path-like
        The ``.rrd`` file to write.
    video : path-like, optional
        The run's video (an ``.mp4``); image folders are not embedded.
    tracks, kinematics : DataFrame
        The run's tables.
    comparison : DataFrame, optional
        ``compare.csv``'s table (measured and model side by side).
    model_px : dict of ndarray (n, 2), optional
        The model's markers (``"A"``, ``"B"``, ``"C"``) in image pixels,
        row-aligned with ``tracks``.
    spawn : bool
        Also open a live viewer. Where none can start, the file is still written in
        full and then :class:`~cranktrack.errors.ViewerUnavailableError` is raised.
    fit : DataFrame, optional
        ``fit/fit.csv`` of ``cranktrack fit`` (residuals before and after).
    """
    out = Path(path)
    rec = rr.RecordingStream("cranktrack", recording_id=out.stem)
    viewer = spawn
    if spawn:
        try:
            rec.spawn(default_blueprint=blueprint())
        except (RuntimeError, OSError):  # headless, or no viewer on PATH: the file still goes
            viewer = False
    rec.save(out, default_blueprint=blueprint())
    t = tracks["t_s"].to_numpy(float)
    if video is not None and Path(video).suffix.lower() in (".mp4", ".mov", ".m4v"):
        asset = rr.AssetVideo(path=str(video))
        rec.log("video", asset, static=True)
        # The container's own timestamps, on the same timeline as everything else.
        ts = asset.read_frame_timestamps_nanos()
        rec.send_columns("video", indexes=[rr.TimeColumn("time", duration=1e-9 * ts)],
                         columns=rr.VideoFrameReference.columns_nanos(ts))
    names = [c[: -len("_ok")] for c in tracks.columns if c.endswith("_ok")]
    for m in names:
        xy = tracks[[f"{m}_x_px", f"{m}_y_px"]].to_numpy(float)
        radii = np.maximum(3.0 * np.nan_to_num(tracks[f"{m}_sigma_px"].to_numpy(float)), 2.0)
        _column_points(rec, f"video/markers/{m}", t, xy, radii,
                       MARKER_COLOURS.get(m, (255, 255, 255)), m)
    for a, b in (("A", "B"), ("A", "C"), ("B", "C")):
        if a not in names or b not in names:
            continue
        pa = tracks[[f"{a}_x_px", f"{a}_y_px"]].to_numpy(float)
        pb = tracks[[f"{b}_x_px", f"{b}_y_px"]].to_numpy(float)
        ok = np.isfinite(pa).all(axis=1) & np.isfinite(pb).all(axis=1)
        if ok.any():
            strips = np.stack([pa[ok], pb[ok]], axis=1)  # (n, 2 points, 2)
            rec.send_columns(
                f"video/links/{a}{b}", indexes=[rr.TimeColumn("time", duration=t[ok])],
                columns=rr.LineStrips2D.columns(strips=list(strips)).partition(
                    [1] * int(ok.sum())))
    for name, xy in (model_px or {}).items():
        _column_points(rec, f"video/model/{name}", t, np.asarray(xy, float),
                       np.full(len(t), 4.0), MODEL_COLOUR, f"{name} model")
    if kinematics is not None:
        tk = kinematics["t_s"].to_numpy(float)
        for key, col, _ in PLOTS:
            _scalars(rec, f"plots/{key}/measured", tk, kinematics[col].to_numpy(float))
    if comparison is not None:
        tc = comparison["t_s"].to_numpy(float)
        for key, col, _ in PLOTS:
            _scalars(rec, f"plots/{key}/model", tc, comparison[f"{col}_model"].to_numpy(float))
        _scalars(rec, "plots/residual/theta", tc, comparison["theta_deg_error"].to_numpy(float))
    if fit is not None:
        tf = fit["t_s"].to_numpy(float)
        _scalars(rec, "plots/theta/fitted", tf, fit["theta_deg_final"].to_numpy(float))
        for when in ("before", "after"):
            _scalars(rec, f"plots/residual/{when}", tf,
                     fit[f"residual_{when}_deg"].to_numpy(float))
    rec.flush()
    rec.disconnect()
    if spawn and not viewer:
        raise ViewerUnavailableError(str(out))
    return out


def _scalars(rec: rr.RecordingStream, path: str, t: np.ndarray, y: np.ndarray) -> None:
    ok = np.isfinite(t) & np.isfinite(y)
    if ok.any():
        rec.send_columns(path, indexes=[rr.TimeColumn("time", duration=t[ok])],
                         columns=rr.Scalars.columns(scalars=y[ok]))


def read_entities(path: str | os.PathLike) -> dict[str, dict]:
    """What a recording holds: per entity, its row count and timelines (for checks)."""
    store = rr.chunk.RrdReader(str(path)).stream().collect()
    out: dict[str, dict] = {}
    for chunk in store.stream():
        e = out.setdefault(chunk.entity_path, {"rows": 0, "timelines": set(), "static": False})
        if chunk.is_static:
            e["static"] = True
        else:
            e["rows"] += chunk.num_rows
            e["timelines"] |= set(chunk.timeline_names)
    return out


def read_times(path: str | os.PathLike, entity: str) -> np.ndarray:
    """The ``time`` values (s) at which ``entity`` was logged."""
    store = rr.chunk.RrdReader(str(path)).stream().collect()
    times = []
    for chunk in store.stream():
        if chunk.entity_path == entity and not chunk.is_static:
            batch = chunk.to_record_batch()
            col = batch.column(batch.schema.get_field_index("time"))
            times.append(np.asarray(col.cast("int64").to_numpy(zero_copy_only=False)) * 1e-9)
    return np.sort(np.concatenate(times)) if times else np.array([])
