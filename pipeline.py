"""A whole run: video → tracks → plane coordinates → kinematics, in one folder.

Each step's output is written as soon as it exists, so a failure later in
the run keeps what was done before it.
"""

from __future__ import annotations

import json
import os
import pickle
import platform
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from .calibration.file import load_calibration, save_calibration
from .calibration.known_length import calibrate_known_length, check_length
from .calibration.plane import (
    PlaneCalibration,
    add_plane_coordinates,
    align_to_markers,
)
from .calibration.ruler import Ruler, ruler_calibration
from .environment import library_versions
from .errors import CranktrackError, RunInterrupted
from .files import (
    ensure_dir,
    write_csv_atomic,
    write_json_atomic,
    write_parquet_atomic,
    write_text_atomic,
)
from .kinematics.measured import (
    LINK_JUMP_SIGMA,
    LINK_WANDER,
    link_wanders,
    measure_kinematics,
)
from .kinematics.motion import marker_motion
from .kinematics.rolling_shutter import at_frame_times
from .run_folder import (
    CALIBRATION,
    COMPARE_FIT,
    COMPARE_REPORT,
    COMPARE_TABLE,
    FIT_DIR,
    FIT_REPORT_JSON,
    FIT_TABLE,
    KINEMATICS,
    KINEMATICS_FIGURE,
    KINEMATICS_PARQUET,
    MOTION,
    MOTION_PARQUET,
    RECORDING,
    RUN_INFO,
    TRACKER_STATE,
    TRACKS,
    TRACKS_FIGURE,
    TRACKS_PARQUET,
    RunFolder,
    claimed,
    clear_for,
    record_step,
    run_folder,
)
from .tracker.foreshortening import Foreshortening, foreshortening_of
from .tracker.gaps import fill_gaps, found_span
from .tracker.marker_state import MarkerState
from .tracker.markers import DEFAULT_MARKERS, MarkerSpec
from .tracker.scatter import found_xy
from .tracker.track import Roi, Span, TrackerState, TrackingInterrupted, track, tracks_table
from .tracker.video import FrameSource, open_frames

if TYPE_CHECKING:
    from .calibration.readout import PairReadoutFit, ReadoutFit
    from .loop.camera_view import CameraView
    from .loop.compare import Comparison
    from .loop.flight import FlightLoop
    from .loop.result import LoopResult
    from .loop.rotation import RotationLoop
    from .loop.swing import SwingLoop

RUN_SCHEMA = 1


def _load_state(path: Path, video: str | os.PathLike, roi: Roi | None = None) -> TrackerState:
    if not path.exists():
        raise CranktrackError(f"there is no interrupted run to resume in {path.parent} (no "
                              f"{path.name}); run without --resume")
    try:
        saved = pickle.loads(path.read_bytes())
        state = saved["state"]
    except (OSError, pickle.UnpicklingError, KeyError, EOFError, AttributeError) as e:
        raise CranktrackError(f"{path} cannot be read ({e}); run again without --resume") from None
    # A state saved by an older cranktrack lacks what the tracker has learned to keep
    # since (a marker's motion, shape, usual gain): resuming it would fail mid-run.
    wanted = {f.name for f in fields(MarkerState)}
    markers = getattr(state, "markers", None)
    if markers is None or any(not wanted <= set(vars(st)) for st in markers) \
            or not {f.name for f in fields(TrackerState)} <= set(vars(state)):
        raise CranktrackError(f"{path} was saved by an older cranktrack; run again without "
                              "--resume")
    if saved.get("video") != str(Path(video).resolve()):
        raise CranktrackError(f"the run in {path.parent} was tracking {saved.get('video')}, "
                              f"not {video}; resume it with that video")
    if saved.get("roi") != roi:
        was = saved.get("roi")
        raise CranktrackError(f"the run in {path.parent} was tracking "
                              + (f"--roi {was.x},{was.y},{was.w},{was.h}" if was else
                                 "the whole frame")
                              + "; resume it with the same region")
    return state


@dataclass
class RunResult:
    """What a run wrote and learned."""

    folder: Path
    tracks: pd.DataFrame
    kinematics: pd.DataFrame | None
    calibration: PlaneCalibration | None
    files: dict[str, Path] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    #: Every marker's velocity and acceleration (:func:`.kinematics.motion.marker_motion`),
    #: once the run has a scale.
    motion: pd.DataFrame | None = None


#: The smallest frame side a marker and the ring around it can fit in, px.
MIN_FRAME_PX = 16


def _check_before_tracking(source: FrameSource, specs: tuple[MarkerSpec, ...],
                           known_length: tuple[str, str, float] | None,
                           calibration: PlaneCalibration | None,
                           window_s: float | None, readout_s: float = 0.0) -> None:
    """What can be refused before a single frame is tracked, so a long video is not
    tracked only to fail at its end."""
    width, height, video = source.width, source.height, source.path
    if min(width, height) < MIN_FRAME_PX:
        raise CranktrackError(f"{video} is {width}x{height} px: too small to hold a marker "
                              f"(at least {MIN_FRAME_PX} px each way)")
    for s in specs:
        if s.near_px is not None and not (0 <= s.near_px[0] < width
                                          and 0 <= s.near_px[1] < height):
            raise CranktrackError(
                f"--marker {s.name}: @{s.near_px[0]:g},{s.near_px[1]:g} lies outside the "
                f"{width}x{height} frame (x from 0 to {width - 1}, y from 0 to {height - 1})")
    names = [s.name for s in specs]
    if known_length is not None:
        missing = [m for m in known_length[:2] if m not in names]
        if missing:
            raise CranktrackError(
                f"--known-length names {' and '.join(missing)}, not among the tracked "
                f"markers {', '.join(names)} (add one with --marker NAME=COLOUR)")
    if calibration is not None and calibration.image_size != (width, height):
        size = calibration.image_size
        raise CranktrackError(
            f"the calibration was made for {size[0]}x{size[1]} images, but {video} is "
            f"{width}x{height}; calibrate for this camera setting")
    if window_s is not None and source.duration_s and window_s > source.duration_s / 2:
        # ω and v_B need a window's worth of frames each side of a row: none would have one.
        raise CranktrackError(f"--window-s {window_s:g} is more than half the video's "
                              f"{source.duration_s:.3g} s; choose a window of a few frames")
    _refuse_long_readout(readout_s, 1.0 / source.nominal_fps if source.nominal_fps
                         else np.inf, str(video))


def track_run(
    video: str | os.PathLike,
    out_dir: str | os.PathLike,
    known_length: tuple[str, str, float] | None = None,
    specs: tuple[MarkerSpec, ...] = DEFAULT_MARKERS,
    fps: float | None = None,
    window_s: float | None = None,
    fill_gaps_frames: int = 0,
    calibration: PlaneCalibration | None = None,
    resume: bool = False,
    on_start: Callable[[int | None], None] | None = None,
    on_frame: Callable[[int], None] | None = None,
    span: Span | None = None,
    roi: Roi | None = None,
    on_stage: Callable[[str], None] | None = None,
    overwrite: bool = False,
    table_format: str = "csv",
    readout_s: float = 0.0,
    ruler: Ruler | None = None,
) -> RunResult:
    """Track ``video`` into ``out_dir`` (only the frames within ``span``, and only the
    part of each frame within ``roi``, if given).

    Writes ``tracks.csv`` (pixels, plus plane mm when ``known_length`` is
    given), ``calibration.json`` and ``kinematics.csv`` (only with a scale),
    and ``run.json`` with the provenance and quality figures.
    ``calibration`` (a plane calibration file's content) maps pixels to mm;
    then ``known_length``, if given, is only checked against it. Without it,
    ``known_length`` sets a single scale. ``window_s`` fixes the
    differentiator's window (s); by default it is chosen from the data.
    ``fill_gaps_frames`` > 0 interpolates gaps up to that many frames long,
    flagged ``_status = "interpolated"`` (off by default: gaps stay gaps).
    ``resume`` continues an interrupted run in ``out_dir`` (Ctrl-C leaves
    ``tracks.csv`` up to the last finished frame and the tracker's state in
    ``.tracker_state.pkl``; the resumed result equals an uninterrupted run).
    ``on_start(shown_frames)`` and ``on_frame(index)`` report progress, and
    ``on_stage(name)`` each step after the frames (``"kinematics"``, ``"report"``).
    ``overwrite`` replaces the run of another video that ``out_dir`` holds (without it,
    such a folder is refused). ``table_format="parquet"`` also writes the tracks and
    kinematics as Parquet (``tracks.parquet``, ``kinematics.parquet``) beside the CSVs.
    ``readout_s`` > 0 is a rolling shutter's readout time (s, top row to bottom row):
    the kinematics then take each marker's fix back from its row's time to its frame's
    (:func:`.kinematics.rolling_shutter.at_frame_times`); tracks.csv keeps what was seen.
    ``ruler`` sets the scale from two points of the frame a known distance apart (in
    place of ``calibration``); with a scale, ``motion.csv`` has every marker's velocity
    and acceleration, and ``kinematics.csv`` is written for the crank-slider's A and B.
    """
    if table_format not in ("csv", "parquet"):
        raise CranktrackError(f"unknown table format {table_format!r}; use csv or parquet")
    source = open_frames(video, fps=fps)
    calibration = _with_ruler(calibration, ruler, (source.width, source.height),
                              source.pixel_aspect)
    _check_before_tracking(source, specs, known_length, calibration, window_s, readout_s)
    # Refused here too, before a folder is made: a calibration no camera could give.
    foreshortening = _foreshortening(calibration, (source.width, source.height))
    folder = ensure_dir(out_dir)
    with claimed(folder):
        if not resume:
            clear_for(folder, video, overwrite)
        try:
            result = _track_into(folder, source, video, known_length, specs, window_s,
                                 fill_gaps_frames, calibration, resume, on_start, on_frame,
                                 span, roi, on_stage or (lambda stage: None), readout_s,
                                 foreshortening)
            if table_format == "parquet":
                result.files["tracks_parquet"] = write_parquet_atomic(
                    folder / TRACKS_PARQUET, result.tracks)
                if result.kinematics is not None:
                    result.files["kinematics_parquet"] = write_parquet_atomic(
                        folder / KINEMATICS_PARQUET, result.kinematics)
                if result.motion is not None:
                    result.files["motion_parquet"] = write_parquet_atomic(
                        folder / MOTION_PARQUET, result.motion)
        except KeyboardInterrupt as e:
            # The tracker's state stays until the whole run is written, so a run stopped
            # in any step after its first frame resumes; before it, there is nothing to.
            raise RunInterrupted(str(folder), (folder / TRACKER_STATE).exists()) from e
        except CranktrackError:
            (folder / TRACKER_STATE).unlink(missing_ok=True)  # it ended: nothing to resume
            raise
        (folder / TRACKER_STATE).unlink(missing_ok=True)
        return result


def _with_ruler(calibration: PlaneCalibration | None, ruler: Ruler | None,
                size: tuple[int, int], pixel_aspect: float) -> PlaneCalibration | None:
    """The calibration a run uses: ``calibration``, or the one ``ruler`` gives a frame of
    ``size`` (width, height px). Both at once are refused: each sets the scale."""
    if ruler is None:
        return calibration
    if calibration is not None:
        raise CranktrackError("give --ruler or --calibration, not both: each sets the scale")
    return ruler_calibration(ruler, size, pixel_aspect)


def _refuse_long_readout(readout_s: float, frame_s: float, what: str) -> None:
    """Refuse a readout (s) that is negative or not shorter than a frame of ``what``
    (``frame_s`` s apart; inf where the rate is not known)."""
    if readout_s == 0.0 or 0.0 < readout_s < frame_s:
        return
    raise CranktrackError(
        f"--rolling-shutter-ms {readout_s * 1e3:g} does not fit in one frame of {what} "
        f"({frame_s * 1e3:.3g} ms): give the time from its top row to its bottom row, from "
        "0 up to less than a frame")


def readout_from_run(run: str | os.PathLike, marker: str, start_s: float | None = None,
                     end_s: float | None = None, second: str | None = None
                     ) -> ReadoutFit | PairReadoutFit:
    """A rolling shutter's readout from the run folder ``run``, between ``start_s`` and
    ``end_s`` (s; the whole run by default), with the frame's height from ``run.json``:
    what ``cranktrack calibrate readout`` prints. From ``marker``'s free flight
    (:func:`.calibration.readout.readout_from_flight`), or, given a ``second`` marker on
    the same rigid bar moved sideways, from the pair
    (:func:`.calibration.readout.readout_from_pair`).

    Raises
    ------
    CranktrackError
        The run has no such marker, does not say the frame's height, or too few fixes.
    """
    # SciPy's optimizers (0.25 s to import) are loaded only here: `track` starts without.
    from .calibration.readout import readout_from_flight, readout_from_pair

    folder = RunFolder(run)
    tracks = folder.read_tracks()
    names = [marker] if second is None else [marker, second]
    for name in names:
        if f"{name}_ok" not in tracks.columns:
            markers = sorted(c[:-3] for c in tracks.columns if c.endswith("_ok"))
            raise CranktrackError(f"{folder / TRACKS} has no marker {name}; it has "
                                  + ", ".join(markers))
    height = ((folder.read_json(RUN_INFO) or {}).get("source") or {}).get("height")
    if not height:
        raise CranktrackError(f"{folder / RUN_INFO} does not say the frame's height; track "
                              "the video again with this version")
    t = tracks["t_s"].to_numpy(float)
    within = (t >= (-np.inf if start_s is None else start_s)) & (
        t <= (np.inf if end_s is None else end_s))
    if second is not None:
        # Every frame in the span, found or not: the pair's velocity needs its neighbours.
        xy = [found_xy(tracks, name)[within] for name in names]
        return readout_from_pair(t[within], xy[0], xy[1], int(height))
    use = within & tracks[f"{marker}_ok"].to_numpy(bool)
    xy = tracks.loc[use, [f"{marker}_x_px", f"{marker}_y_px"]].to_numpy(float)
    return readout_from_flight(t[use], xy, int(height))


def _found_warnings(found_fraction: dict[str, float], problems: list[str],
                    tracks: pd.DataFrame) -> list[str]:
    """What to tell the user of markers found in few or no frames (``problems`` may
    already say why one was never found: not within reach of its place), and, where
    its misses lie before or after the frames it was found in, which frames those are
    (:func:`.tracker.gaps.found_span`)."""
    out = []
    for name, frac in found_fraction.items():
        if frac == 0 and any(p.startswith(f"marker {name} was never within reach")
                             for p in problems):
            continue
        if frac == 0:
            out.append(f"marker {name} was not found in any frame; check its colour")
        elif frac < 0.95:
            where = (found_span(tracks[f"{name}_ok"].to_numpy(bool),
                                tracks["t_s"].to_numpy(float))
                     if f"{name}_ok" in tracks else None)
            out.append(f"marker {name} was found in only {100 * frac:.0f}% of frames"
                       + (f": {where}" if where else ""))
    return out


def _link_warnings(links: dict[str, dict]) -> list[str]:
    """What to tell the user of rigid links that jump or wander (``MeasureInfo.links``)."""
    out = []
    for k, v in links.items():
        if v["frames_flagged"]:
            out.append(f"{v['frames_flagged']} frame(s) where the rigid length {k[:2]} jumps "
                       f"by more than {LINK_JUMP_SIGMA:g}σ from its median (rigid_ok is false "
                       "there)")
    for k, link in links.items():
        if not link_wanders(link):
            continue
        how = (f"{link['std_over_sigma']:.1f}× what the markers' σ allow"
               if link["std_over_sigma"] > LINK_WANDER else
               "slowly, as the mechanism moves, not from frame to frame")
        out.append(f"the rigid length {k[:2]} varies by {link['std']:.3f} mm (1σ) over "
                   f"the run, {how}; the camera may be tilted or the lens distorting "
                   "(calibrate them: cranktrack calibrate)")
    return out


def _foreshortening(calibration: PlaneCalibration | None, size: tuple[int, int]
                    ) -> Foreshortening | None:
    """How the calibration's plane foreshortens a printed disc over a frame of ``size``
    px (:mod:`.tracker.foreshortening`); None without a calibration."""
    if calibration is None:
        return None
    try:
        return foreshortening_of(calibration.to_plane, size)
    except ValueError as e:
        raise CranktrackError(f"{e}: it cannot be this camera's view of a plane; "
                              "calibrate the plane again") from None


def _track_into(folder: Path, source: FrameSource, video: str | os.PathLike,
                known_length: tuple[str, str, float] | None, specs: tuple[MarkerSpec, ...],
                window_s: float | None, fill_gaps_frames: int,
                calibration: PlaneCalibration | None, resume: bool,
                on_start: Callable[[int | None], None] | None,
                on_frame: Callable[[int], None] | None, span: Span | None = None,
                roi: Roi | None = None,
                on_stage: Callable[[str], None] = lambda stage: None,
                readout_s: float = 0.0, foreshortening: Foreshortening | None = None
                ) -> RunResult:
    """:func:`track_run`'s work, in a folder it holds; ``foreshortening``: how the calibration's
    plane foreshortens a printed disc (:func:`_foreshortening`)."""
    if on_start:
        on_start(source.shown_frames)
    state_path = folder / TRACKER_STATE
    saved = _load_state(state_path, video, roi) if resume else None

    def save_state(state: TrackerState) -> None:
        write_text_atomic(state_path, pickle.dumps({"video": str(Path(video).resolve()),
                                                    "roi": roi, "state": state}))

    def checkpoint(state: TrackerState) -> None:
        write_csv_atomic(folder / TRACKS, tracks_table(state.rows, specs, state.radii()))
        save_state(state)

    try:
        result = track(source, specs, on_frame=on_frame, resume=saved, checkpoint=checkpoint,
                       span=span, roi=roi, foreshortening=foreshortening)
    except TrackingInterrupted as e:
        if e.state.rows:
            checkpoint(e.state)
        raise
    save_state(result.state)  # the finished state: a Ctrl-C in a later step resumes
    tracks = result.tracks
    names = tuple(s.name for s in specs)
    if fill_gaps_frames > 0:
        tracks = fill_gaps(tracks, names, fill_gaps_frames)
    warnings = list(result.problems) + _found_warnings(result.found_fraction,
                                                           result.problems, result.tracks)
    files = {"tracks": write_csv_atomic(folder / TRACKS, tracks)}
    run_info = {
        "schema": RUN_SCHEMA,
        "cranktrack": (libraries := library_versions())["cranktrack"],
        "python": platform.python_version(),
        # What decided the numbers besides the code: another OpenCV, FFmpeg or numba
        # can take another blob first (environment.py).
        "libraries": libraries,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "source": {"path": str(Path(video).resolve()), "kind": source.kind,
                   "codec": source.codec, "width": source.width, "height": source.height,
                   **({} if source.pixel_aspect == 1.0 else
                      {"pixel_aspect": source.pixel_aspect})},
        "markers": {s.name: ({"template": {"at_px": list(s.near_px),
                                           "radius_px": s.template_radius_px}}
                             if s.template_radius_px is not None else
                             {"hue_deg": s.hue_deg, "hue_tol_deg": s.hue_tol_deg,
                              "shape": "disc" if s.flat else "blob"})
                    for s in specs},
        "tracking": {**result.to_dict(), "fill_gaps_frames": fill_gaps_frames,
                     "span": None if span is None or not span.given else
                     {"start": span.start, "end": span.end if np.isfinite(span.end) else None,
                      "unit": span.unit},
                     **({} if roi is None else {"roi": [roi.x, roi.y, roi.w, roi.h]}),
                     **({} if foreshortening is None else
                        {"discs_as_ellipses_up_to": round(foreshortening.most_stretched, 4)}),
                     **({} if not readout_s else {"rolling_shutter_readout_s": readout_s})},
        "warnings": warnings,
    }
    files["run"] = write_json_atomic(folder / RUN_INFO, run_info)

    cal = kinematics = motion = None
    if known_length is not None or calibration is not None:
        measured = _measure_into(folder, tracks, {s.name: s.hue_deg for s in specs},
                                 (source.width, source.height), known_length, calibration,
                                 window_s, readout_s, on_stage, result.problems,
                                 pixel_aspect=source.pixel_aspect)
        tracks, cal, kinematics = measured.tracks, measured.calibration, measured.kinematics
        motion = measured.motion
        files.update(measured.files)
        warnings += measured.warnings
        run_info.update(measured.run_info)
        run_info["warnings"] = warnings
        files["run"] = write_json_atomic(folder / RUN_INFO, run_info)
    on_stage("report")
    from .report.summary import write_report  # matplotlib: loaded once the video is read

    files["report"] = write_report(folder)
    for figure in (KINEMATICS_FIGURE, TRACKS_FIGURE):
        if (folder / figure).is_file():
            files["figure"] = folder / figure
    record_step(folder, "track", [n for n in (TRACKS, KINEMATICS, MOTION)
                                  if (folder / n).exists()], video=video)
    return RunResult(folder, tracks, kinematics, cal, files, warnings, motion)


@dataclass(frozen=True)
class _Measured:
    """What the step from pixels to kinematics wrote: the tracks with plane mm, the
    calibration, the kinematics, their files, its warnings and its part of run.json."""

    tracks: pd.DataFrame
    calibration: PlaneCalibration
    kinematics: pd.DataFrame | None
    motion: pd.DataFrame
    files: dict[str, Path]
    warnings: list[str]
    run_info: dict


def _measure_into(folder: Path, tracks: pd.DataFrame, hues: dict[str, float | None],
                  size: tuple[int, int],
                  known_length: tuple[str, str, float] | None,
                  calibration: PlaneCalibration | None, window_s: float | None,
                  readout_s: float, on_stage: Callable[[str], None],
                  problems: list[str], aligned: bool = False,
                  pixel_aspect: float = 1.0) -> _Measured:
    """Pixels to mm to kinematics, written into ``folder`` as each exists (the
    calibration and the tracks in mm stay on disk if a later step is refused).
    ``calibration`` maps pixels to mm, once aligned to the markers (A at the origin, C
    on +x; ``aligned`` says it is already: a run's own calibration.json), and
    ``known_length`` then only checks it; without it
    ``known_length`` sets the scale. ``hues`` are the markers' (deg, by name; None for
    one found by brightness); ``size`` is the frame's (width, height), px, and
    ``pixel_aspect`` how many times as wide as high its pixels are shown."""
    names = tuple(hues)
    never = [n for n in names if not tracks[f"{n}_ok"].astype(bool).any()]
    if never:
        hue = hues[never[0]]
        # A warning may already say why (refused as shaded, never near its place).
        said = any(p.startswith((f"marker {never[0]} ", f"marker {never[0]}:"))
                   for p in problems)
        raise CranktrackError(
            f"marker {never[0]}{'' if hue is None else f' (hue {hue:g}°)'} was not found in "
            "any frame, so nothing is measured in mm (no motion or kinematics); "
            f"{folder / TRACKS} has what was found; "
            + ("see the warning about it above" if said
               else "check the marker's colour (--marker NAME=COLOUR)"), problems)
    # The plane's x axis runs from A to C; a run without C keeps the image's x direction.
    axis_to = "C" if "C" in names else None
    if calibration is not None:
        # The crank-slider's plane frame is set on A; other markers keep the
        # calibration's own (a ruler's: its first end, x along the image's, y up).
        cal = (calibration if aligned or "A" not in names
               else align_to_markers(calibration, tracks, axis_to=axis_to))
        if known_length is not None:
            cal = check_length(cal, tracks, *known_length)
    else:
        a, b, length = known_length
        cal = calibrate_known_length(tracks, a, b, length, size, axis_to=axis_to,
                                     pixel_aspect=pixel_aspect)
    warnings = list(cal.warnings)
    files = {"calibration": save_calibration(folder / CALIBRATION, cal)}
    tracks = add_plane_coordinates(tracks, cal, names)
    files["tracks"] = write_csv_atomic(folder / TRACKS, tracks)
    on_stage("kinematics")
    timed = tracks if not readout_s else at_frame_times(tracks, readout_s, size[1], names)
    motion, motion_info = marker_motion(timed, names, window_s, scale_sigma=cal.scale_sigma)
    files["motion"] = write_csv_atomic(folder / MOTION, motion)
    run_info = {"calibration": {"method": cal.method, **cal.quality},
                "motion": motion_info.to_dict()}
    if not {"A", "B"} <= set(names):
        # θ, ω and v_B are the crank-slider's: a run of other markers has their motion.
        return _Measured(tracks, cal, None, motion, files, warnings, run_info)
    kinematics, info = measure_kinematics(timed, window_s=window_s, scale_sigma=cal.scale_sigma)
    warnings += _link_warnings(info.links)
    if info.theta_from != "A-C":
        warnings.append(
            "no marker C (--marker C=none): θ is the angle of A→B from the plane's x axis "
            "(the image's x direction, toward its y axis turned up), not the crank-slider's "
            f"angle at A between A→C and A→B; L1 and L3 are empty in {KINEMATICS}, and "
            "`compare` and `fit` need C")
    if info.repeated_frames:
        warnings.append(
            f"{info.repeated_frames} frames repeat the picture before them (a marker all but "
            f"stops between two frames in which it moves on); their rows of {KINEMATICS} are "
            "empty, since their timestamps are not when their picture was taken")
    files["kinematics"] = write_csv_atomic(folder / KINEMATICS, kinematics)
    return _Measured(tracks, cal, kinematics, motion, files, warnings,
                     {**run_info, "kinematics": info.to_dict()})


#: What `track` adds to the tracks table once it has a scale: dropped before measuring again.
_PLANE_SUFFIXES = ("_x_mm", "_y_mm", "_sigma_mm")


def measure_run(run: str | os.PathLike, known_length: tuple[str, str, float] | None = None,
                calibration: PlaneCalibration | None = None, window_s: float | None = None,
                readout_s: float | None = None,
                on_stage: Callable[[str], None] | None = None,
                ruler: Ruler | None = None) -> RunResult:
    """The kinematics of a run folder measured again from its tracks, without tracking
    the video again: with a new scale (``known_length``), plane ``calibration``,
    differentiator window ``window_s`` (s) or rolling shutter readout ``readout_s``
    (s, top row to bottom row; None keeps the run's, 0 takes it off).

    ``ruler`` sets the scale from two points of the frame (in place of ``calibration``).
    With neither ``known_length``, ``calibration`` nor ``ruler``, the run's own
    calibration.json is used again. Rewrites calibration.json, tracks.csv (its pixels as
    tracked, the mm from the new calibration), motion.csv, kinematics.csv (for A and B;
    and their Parquet copies where the run has them), run.json's calibration, motion,
    kinematics, readout and warnings, and the report; a later `compare` or `fit` of the
    run is then out of date, and says so.

    Raises
    ------
    CranktrackError
        The folder holds no tracked run, nothing gives a scale, a readout does not fit
        in a frame, or the run lacks a marker the kinematics or the length need.
    """
    folder = run_folder(run)
    if not folder.path.is_dir():
        raise CranktrackError(f"{folder.path} is not a folder; give the run folder that "
                              "`cranktrack track VIDEO --out RUN` wrote")
    if (folder / TRACKER_STATE).exists():
        raise CranktrackError(f"the run in {folder.path} was interrupted and holds only part "
                              "of the video's tracks; finish it first with the same `cranktrack "
                              "track` command and --resume")
    info = folder.read_json(RUN_INFO)
    source = (info or {}).get("source") or {}
    if not info or "tracking" not in info or not source.get("height"):
        raise CranktrackError(f"{folder / RUN_INFO} is missing or was not written by "
                              f"`cranktrack track`; track the video into {folder.path} first")
    tracks = folder.read_tracks()
    tracks = tracks.drop(columns=[c for c in tracks.columns if c.endswith(_PLANE_SUFFIXES)])
    names = tuple(c[:-3] for c in tracks.columns if c.endswith("_ok"))
    width, height = int(source.get("width") or 0), int(source["height"])
    if ruler is not None and not width:
        raise CranktrackError(f"{folder / RUN_INFO} does not say the frame's width, which "
                              "--ruler needs; track the video again")
    calibration = _with_ruler(calibration, ruler, (width, height),
                              float(source.get("pixel_aspect") or 1.0))
    if known_length is not None:
        missing = [m for m in known_length[:2] if m not in names]
        if missing:
            raise CranktrackError(f"--known-length names {' and '.join(missing)}, not among "
                                  f"the run's markers {', '.join(names)}")
    if calibration is not None and width and calibration.image_size != (width, height):
        size = calibration.image_size
        raise CranktrackError(f"the calibration was made for {size[0]}x{size[1]} images, but "
                              f"the run's video is {width}x{height}; calibrate for this camera "
                              "setting")
    reused = calibration is None and known_length is None
    if reused:
        if not (folder / CALIBRATION).is_file():
            raise CranktrackError(f"{folder.path} has no calibration yet; give a scale: "
                                  "--known-length A-C=MM, --ruler X1,Y1,X2,Y2=MM or --calibration "
                                  "PLANE.json")
        calibration = load_calibration(folder / CALIBRATION, (width, height) if width else None)
    tracking = info["tracking"]
    if readout_s is None:
        readout_s = float(tracking.get("rolling_shutter_readout_s") or 0.0)
    frame_s = float(np.median(np.diff(tracks["t_s"].to_numpy(float)))) if len(tracks) > 1 \
        else np.inf
    _refuse_long_readout(readout_s, frame_s, "the run")
    if window_s is not None and window_s > np.ptp(tracks["t_s"].to_numpy(float)) / 2:
        raise CranktrackError(f"--window-s {window_s:g} is more than half the run; choose a "
                              "window of a few frames")
    problems = list(tracking.get("problems") or [])
    with claimed(folder.path):
        marks = info.get("markers") or {}
        hues = {n: (marks.get(n) or {}).get("hue_deg") for n in names}
        measured = _measure_into(folder.path, tracks, hues, (width, height), known_length,
                                 calibration, window_s, readout_s,
                                 on_stage or (lambda stage: None), problems,
                                 aligned=reused,
                                 pixel_aspect=float(source.get("pixel_aspect") or 1.0))
        files = dict(measured.files)
        warnings = (problems + _found_warnings(tracking.get("found_fraction") or {}, problems,
                                               tracks)
                    + measured.warnings)
        tracking.pop("rolling_shutter_readout_s", None)
        if readout_s:
            tracking["rolling_shutter_readout_s"] = readout_s
        info.update(measured.run_info)
        info["warnings"] = warnings
        files["run"] = write_json_atomic(folder / RUN_INFO, info)
        if (folder / TRACKS_PARQUET).exists():
            files["tracks_parquet"] = write_parquet_atomic(folder / TRACKS_PARQUET,
                                                           measured.tracks)
            if measured.kinematics is not None:
                files["kinematics_parquet"] = write_parquet_atomic(
                    folder / KINEMATICS_PARQUET, measured.kinematics)
            files["motion_parquet"] = write_parquet_atomic(folder / MOTION_PARQUET,
                                                           measured.motion)
        from .report.summary import write_report  # matplotlib: only once measured

        files["report"] = write_report(folder.path)
        if (folder / KINEMATICS_FIGURE).is_file():
            files["figure"] = folder / KINEMATICS_FIGURE
        # The tables are what `track` with these options would have written from the same
        # tracks: its manifest entry is renewed, so compare and fit see them as newer.
        record_step(folder.path, "track", [n for n in (TRACKS, KINEMATICS, MOTION)
                                           if (folder / n).exists()])
    return RunResult(folder.path, measured.tracks, measured.kinematics, measured.calibration,
                     files, warnings, measured.motion)


def read_kinematics(run: Path) -> pd.DataFrame:
    """``run/kinematics.csv``, checked to be a cranktrack kinematics table."""
    return run_folder(run).read_kinematics()


def _image_context(measured: pd.DataFrame, tracks: pd.DataFrame | None,
                   info: dict | None) -> dict[str, np.ndarray]:
    """Where B is in the image, per kinematics row: a camera effect (lens, tilt, rolling
    shutter) leaves a residual that follows these, a mechanism effect does not."""
    if tracks is None or info is None or not {"B_x_px", "B_y_px"} <= set(tracks):
        return {}
    source = info.get("source", {})
    rows = measured[["frame"]].merge(tracks[["frame", "B_x_px", "B_y_px"]], on="frame",
                                     how="left")
    ctx = {"B image row": rows["B_y_px"].to_numpy(float)}
    if source.get("width") and source.get("height"):
        cx, cy = (source["width"] - 1) / 2, (source["height"] - 1) / 2
        ctx["B distance from image centre"] = np.hypot(rows["B_x_px"] - cx,
                                                       rows["B_y_px"] - cy).to_numpy(float)
    return ctx


def camera_view(run: Path, tracks: pd.DataFrame | None = None,
                info: dict | None = None) -> CameraView | None:
    """The run's image geometry for the camera candidates: its calibration, the image size
    and where A and C sit (medians of the tracks); None if the run lacks any of them.
    ``tracks`` and ``info`` (``run.json``) are read from the folder unless given."""
    from .loop.camera_view import CameraView

    folder = run_folder(run)
    try:
        cal = load_calibration(folder / CALIBRATION)
        tracks = pd.read_csv(folder / TRACKS) if tracks is None else tracks
        info = json.loads((folder / RUN_INFO).read_text()) if info is None else info
        source = info.get("source", {})
        size = (int(source["width"]), int(source["height"]))
        A, C = (np.array([np.nanmedian(tracks[f"{m}_x_px"]), np.nanmedian(tracks[f"{m}_y_px"])])
                for m in "AC")
        ab = tracks[["B_x_mm", "B_y_mm"]].to_numpy(float) - tracks[["A_x_mm", "A_y_mm"]].to_numpy(
            float)
        ac = tracks[["C_x_mm", "C_y_mm"]].to_numpy(float) - tracks[["A_x_mm", "A_y_mm"]].to_numpy(
            float)
    except (OSError, ValueError, KeyError, CranktrackError):
        return None
    side = float(np.sign(np.nanmedian(ac[:, 0] * ab[:, 1] - ac[:, 1] * ab[:, 0])))
    if not (np.isfinite(A).all() and np.isfinite(C).all() and side != 0):
        return None
    return CameraView(cal.plane_points, cal.image_points, size, A, C, side)


def _needs_c(run: Path, info: dict | None, command: str) -> None:
    """Refuse ``command`` on a run measured without marker C: the models' θ is the
    angle at A between A→C and A→B, and that run's θ is A→B's from the x axis."""
    theta_from = ((info or {}).get("kinematics") or {}).get("theta_from", "A-C")
    if theta_from != "A-C":
        raise CranktrackError(
            f"the run in {run} was tracked without marker C (--marker C=none), so its θ is "
            f"measured from the plane's x axis, not from A→C as the models' is; `{command}` "
            "needs C tracked")


def fit_run(run: Path, model: str, known: dict[str, float],
            on_fit: Callable[[tuple[str, ...]], None] | None = None
            ) -> tuple[LoopResult, list[Path]]:
    """Close the loop on ``run/kinematics.csv``; write ``run/fit/`` and refresh the report.

    The tracks and ``run.json`` are read once, for the camera candidates' image
    geometry and the frame-motion check. ``on_fit(effects)`` is called before each
    of the loop's fits (for progress)."""
    # The loop's and the report's libraries (scipy.optimize, statsmodels, matplotlib) are
    # imported here, not at the top: `track` starts on the first frame without them.
    from .loop.frame_motion import frame_shake
    from .loop.search import close_loop
    from .report.fit import write_fit_report
    from .report.summary import write_report

    folder = run_folder(run)
    measured = folder.read_kinematics()
    try:
        tracks = pd.read_csv(folder / TRACKS)
    except (OSError, ValueError):
        tracks = None
    info = folder.read_json(RUN_INFO)
    _needs_c(folder.path, info, "fit")
    view = camera_view(folder.path, tracks, info) if tracks is not None and info else None
    result = close_loop(measured, known, model, context=_image_context(measured, tracks, info),
                        view=view, on_fit=on_fit)
    try:
        shake = frame_shake(tracks) if tracks is not None else None
    except (OSError, ValueError):
        shake = None
    if shake is not None:
        result = replace(result, frame_motion=shake.to_dict())
    ok = np.isfinite(measured["t_s"]) & np.isfinite(measured["theta_deg"])
    files = write_fit_report(folder.fit_dir, result, measured["t_s"].to_numpy(float)[ok])
    files.append(write_report(folder.path))
    record_step(folder.path, "fit", [f"{FIT_DIR}/{FIT_TABLE}"], [KINEMATICS, TRACKS])
    return result, files


def _marker_rows(folder: RunFolder, marker: str, span: Span | None) -> pd.DataFrame:
    """The rows of ``folder``'s tracks where ``marker`` was found, within ``span`` (frames
    or s; None: all). Refuses a marker the run does not have."""
    tracks = folder.read_tracks()
    names = [c[:-3] for c in tracks.columns if c.endswith("_ok")]
    if marker not in names:
        raise CranktrackError(f"{folder / TRACKS} has no marker {marker}; it has "
                              f"{', '.join(names)}")
    rows = tracks[tracks[f"{marker}_ok"].astype(bool)]
    if span is not None:
        at = rows["frame"] if span.unit == "frame" else rows["t_s"]
        rows = rows[(at >= span.start) & (at <= span.end)]
    return rows


#: `fit --model flight`'s files in the run's fit/ folder: the loop's figures and, per
#: fix, the place and both models' residuals.
FLIGHT_JSON = "flight.json"
FLIGHT_TABLE = "flight.csv"


def fit_flight_run(run: Path, marker: str, span: Span | None = None
                   ) -> tuple[FlightLoop, list[Path]]:
    """Close the loop on marker ``marker``'s free flight in ``run`` (within ``span``, frames
    or s; default every frame it was found in): g from a parabola through its place in
    mm, and the effect a parabola lacks (:func:`.loop.flight.fit_flight`). Writes
    ``fit/flight.json`` and ``fit/flight.csv``.

    Raises
    ------
    CranktrackError
        The run has no such marker or no scale, or too few fixes in the span.
    """
    from .loop.flight import fit_flight

    folder = run_folder(run)
    rows = _marker_rows(folder, marker, span)
    if f"{marker}_x_mm" not in rows:
        raise CranktrackError(f"the run has no scale, so no g: give one with `cranktrack "
                              f"measure {folder.path} --ruler X1,Y1,X2,Y2=MM`")
    info = folder.read_json(RUN_INFO) or {}
    height = int((info.get("source") or {}).get("height") or 0)
    sigma = rows[f"{marker}_sigma_mm"].to_numpy(float)
    scale_sigma = float(((info.get("calibration") or {}).get("scale_rel_sigma")) or 0.0)
    loop = fit_flight(rows["t_s"].to_numpy(float),
                      rows[[f"{marker}_x_mm", f"{marker}_y_mm"]].to_numpy(float),
                      rows[f"{marker}_y_px"].to_numpy(float), height,
                      float(np.nanmedian(sigma)) if np.isfinite(sigma).any() else 0.0,
                      scale_sigma)
    out = ensure_dir(folder.fit_dir)
    table = pd.DataFrame({"frame": rows["frame"].to_numpy(), "t_s": rows["t_s"].to_numpy(),
                          "x_mm": rows[f"{marker}_x_mm"].to_numpy(),
                          "y_mm": rows[f"{marker}_y_mm"].to_numpy(),
                          "parabola_dx_mm": loop.base.residual[:, 0],
                          "parabola_dy_mm": loop.base.residual[:, 1],
                          "final_dx_mm": loop.final.residual[:, 0],
                          "final_dy_mm": loop.final.residual[:, 1]})
    files = [write_json_atomic(out / FLIGHT_JSON, {"marker": marker, **loop.to_dict()}),
             write_csv_atomic(out / FLIGHT_TABLE, table)]
    from .report.summary import write_report  # matplotlib: only once fitted

    files.append(write_report(folder.path))
    # A later `measure` (a new ruler) leaves this fit out of date, and says so.
    record_step(folder.path, "fit", [f"{FIT_DIR}/{FLIGHT_TABLE}"], [TRACKS])
    return loop, files


#: `fit --model pendulum`'s files in the run's fit/ folder.
SWING_JSON = "swing.json"
SWING_TABLE = "swing.csv"


def fit_swing_run(run: Path, marker: str, span: Span | None = None,
                  length_mm: float | None = None
                  ) -> tuple[SwingLoop, str, float | None, list[Path]]:
    """Close the loop on marker ``marker``'s swing in ``run`` (within ``span``): its
    place along the track's longest direction (mm with a scale, else px), a damped
    sinusoid, then the effects it lacks (:func:`.loop.swing.fit_swing`); with the
    string's ``length_mm``, g. Writes ``fit/swing.json`` and ``fit/swing.csv``, and
    returns the loop, the track's unit, the radius (px) of the arc the swing's angle was
    read from (a track in px; None otherwise or where no arc was found) and the files.

    Raises
    ------
    CranktrackError
        The run has no such marker, or too short a swing in the span.
    """
    from .loop.swing import arc_radius, fit_swing

    if length_mm is not None and not (np.isfinite(length_mm) and length_mm > 0):
        raise CranktrackError(f"--length-mm {length_mm:g} is not a positive length")
    folder = run_folder(run)
    rows = _marker_rows(folder, marker, span)
    unit = "mm" if f"{marker}_x_mm" in rows else "px"
    xy = rows[[f"{marker}_x_{unit}", f"{marker}_y_{unit}"]].to_numpy(float)
    if len(xy) < 3:
        raise CranktrackError(f"marker {marker} was found in {len(xy)} frames of the span; "
                              "a swing needs many")
    # Sideways is the track's longest direction: the bob's swing, whatever the camera's roll.
    centred = xy - xy.mean(axis=0)
    along = np.linalg.svd(centred, full_matrices=False)[2][0]
    sigma = rows[f"{marker}_sigma_{unit}"].to_numpy(float)
    # The string's length in the track's unit bounds a wide swing's slowing: the length
    # given where the track is in mm, else the radius of the circle through the bob's
    # path, about the pivot.
    arc = arc_radius(xy) if unit == "px" else None
    loop = fit_swing(rows["t_s"].to_numpy(float), centred @ along,
                     float(np.nanmedian(sigma)) if np.isfinite(sigma).any() else 0.0,
                     length_mm if unit == "mm" and length_mm is not None else arc)
    arc_px = None
    if unit == "px":
        # Without a scale the swing's angle is its width over the radius of its arc, both
        # in px. Where that circle is not found, the wide-swing correction is left out.
        arc_px = arc
        mm_per_px = (0.0 if arc_px is None or length_mm is None
                     else length_mm / arc_px)

        def in_mm(f):
            return replace(f, envelope=f.envelope * mm_per_px if mm_per_px else np.empty(0))

        loop = replace(loop, base=in_mm(loop.base),
                       candidates={k: in_mm(f) for k, f in loop.candidates.items()})
    out = ensure_dir(folder.fit_dir)
    table = pd.DataFrame({"frame": rows["frame"].to_numpy(), "t_s": rows["t_s"].to_numpy(),
                          f"sideways_{unit}": centred @ along,
                          f"damped_residual_{unit}": loop.base.residual,
                          f"final_residual_{unit}": loop.final.residual})
    info = {"marker": marker, "unit": unit, "direction": [float(v) for v in along],
            **({} if arc_px is None else {"arc_radius_px": arc_px}), **loop.to_dict()}
    if length_mm is not None:
        info["length_mm"] = length_mm
        info["g_mm_s2"] = {k: list(f.g(length_mm)) for k, f in
                           {"damped": loop.base, **loop.candidates}.items()}
    files = [write_json_atomic(out / SWING_JSON, info), write_csv_atomic(out / SWING_TABLE,
                                                                          table)]
    from .report.summary import write_report  # matplotlib: only once fitted

    files.append(write_report(folder.path))
    record_step(folder.path, "fit", [f"{FIT_DIR}/{SWING_TABLE}"], [TRACKS])
    return loop, unit, arc_px, files


#: `fit --model rotation`'s files in the run's fit/ folder.
ROTATION_JSON = "rotation.json"
ROTATION_TABLE = "rotation.csv"


def fit_rotation_run(run: Path, marker: str, span: Span | None = None
                     ) -> tuple[RotationLoop, str, list[Path]]:
    """Close the loop on marker ``marker``'s turn about a fixed axis in ``run`` (within
    ``span``): its rate from a steady turn on a circle, then the effects that lacks
    (:func:`.loop.rotation.fit_rotation`), in mm with a scale, else in px (a rate needs
    none). Writes ``fit/rotation.json`` and ``fit/rotation.csv``; returns the loop, the
    track's unit and the files.

    Raises
    ------
    CranktrackError
        The run has no such marker, or too few fixes or too small a turn in the span.
    """
    from .loop.rotation import fit_rotation

    folder = run_folder(run)
    rows = _marker_rows(folder, marker, span)
    unit = "mm" if f"{marker}_x_mm" in rows else "px"
    xy = rows[[f"{marker}_x_{unit}", f"{marker}_y_{unit}"]].to_numpy(float)
    sigma = rows[f"{marker}_sigma_{unit}"].to_numpy(float)
    loop = fit_rotation(rows["t_s"].to_numpy(float), xy,
                        float(np.nanmedian(sigma)) if np.isfinite(sigma).any() else 0.0)
    out = ensure_dir(folder.fit_dir)
    table = pd.DataFrame({"frame": rows["frame"].to_numpy(), "t_s": rows["t_s"].to_numpy(),
                          f"x_{unit}": xy[:, 0], f"y_{unit}": xy[:, 1],
                          f"circle_dx_{unit}": loop.base.residual[:, 0],
                          f"circle_dy_{unit}": loop.base.residual[:, 1],
                          f"final_dx_{unit}": loop.final.residual[:, 0],
                          f"final_dy_{unit}": loop.final.residual[:, 1]})
    files = [write_json_atomic(out / ROTATION_JSON, {"marker": marker, "unit": unit,
                                                      **loop.to_dict()}),
             write_csv_atomic(out / ROTATION_TABLE, table)]
    from .report.summary import write_report  # matplotlib: only once fitted

    files.append(write_report(folder.path))
    record_step(folder.path, "fit", [f"{FIT_DIR}/{ROTATION_TABLE}"], [TRACKS])
    return loop, unit, files


def compare_run(run: Path, known: dict[str, float],
                on_stage: Callable[[str], None] | None = None
                ) -> tuple[Comparison, list[Path]]:
    """Fit the spool model to ``run/kinematics.csv`` and write the comparison.

    Writes ``compare.csv`` (measured, σ, model and error side by side),
    ``compare.json`` (fitted parameters ± 1σ, fixed ones, error figures),
    ``compare.md`` and the figures; returns the comparison and the paths.
    ``on_stage(name)`` is told each step as it starts (``"fit"``, ``"figures"``,
    ``"report"``).
    """
    stage = on_stage or (lambda name: None)
    stage("fit")
    from .loop.compare import compare_spool
    from .report.compare import compare_markdown
    from .report.plots import plot_comparison
    from .report.summary import write_report

    _needs_c(Path(run), run_folder(run).read_json(RUN_INFO), "compare")
    measured = read_kinematics(run)
    result = compare_spool(measured, known)
    report = {**result.fit.to_dict(), "errors": result.summary.to_dict(orient="records")}
    files = [write_csv_atomic(run / COMPARE_TABLE, result.table),
             write_json_atomic(run / COMPARE_FIT, report)]
    stage("figures")
    figures = plot_comparison(result.table, run, result.curve)
    files.append(write_text_atomic(run / COMPARE_REPORT,
                                   compare_markdown(report, result.summary, figures)))
    stage("report")
    files.append(write_report(run))
    record_step(run, "compare", [COMPARE_TABLE], [KINEMATICS])
    return result, files + figures


def record_run(run: Path, spawn: bool = False, path: Path | None = None) -> Path:
    """Write the run's Rerun recording (default ``run/run.rrd``).

    With a fitted model in the folder (``cranktrack fit``'s final model, else
    ``compare``'s), its markers are drawn over the video, mapped back to pixels
    through the run's own calibration.
    """
    from .calibration.file import load_calibration
    from .loop.simulate import spool_drive
    from .report.recording import write_recording

    run = Path(run)
    if not (run / TRACKS).is_file():
        raise CranktrackError(f"{run} has no {TRACKS}; is it a cranktrack run folder?")
    tracks = pd.read_csv(run / TRACKS)
    info = json.loads((run / RUN_INFO).read_text()) if (run / RUN_INFO).exists() else {}
    video = info.get("source", {}).get("path")
    if video and not Path(video).is_file():
        video = None  # moved or deleted: the recording still has tracks and plots
    kin = pd.read_csv(run / KINEMATICS) if (run / KINEMATICS).exists() else None
    comparison = model_px = None
    t = tracks["t_s"].to_numpy(float)
    theta = L1 = L2 = None
    if (run / COMPARE_TABLE).exists() and (run / COMPARE_FIT).exists():
        comparison = pd.read_csv(run / COMPARE_TABLE)
        report = json.loads((run / COMPARE_FIT).read_text())
        params = {k: v["value"] for k, v in {**report["fixed"], **report["fitted"]}.items()}
        drive = spool_drive(params)
        theta, L1, L2 = drive.bed.theta(drive.slider(t).L3), drive.L1, drive.L2
    fit = pd.read_csv(run / FIT_DIR / FIT_TABLE) if (run / FIT_DIR / FIT_TABLE).exists() else None
    if fit is not None and (run / FIT_DIR / FIT_REPORT_JSON).exists():
        # The closed loop's final model, effects included, is the better overlay.
        values = {k: v["value"] for k, v in
                  json.loads((run / FIT_DIR / FIT_REPORT_JSON).read_text())["parameters"].items()}
        theta = np.interp(t, fit["t_s"], np.radians(fit["theta_deg_final"]),
                          left=np.nan, right=np.nan)
        L1, L2 = values["L1_mm"], values["L2_mm"]
    if theta is not None:
        side = np.sign(np.nanmedian(tracks["B_y_mm"])) if "B_y_mm" in tracks else 1.0
        cal = load_calibration(run / CALIBRATION)
        plane = {"A": (np.zeros_like(t), np.zeros_like(t)),
                 "B": (L2 * np.cos(theta), side * L2 * np.sin(theta)),
                 "C": (np.full_like(t, L1), np.zeros_like(t))}
        model_px = {k: np.stack(cal.to_image(*xy), axis=1) for k, xy in plane.items()}
    return write_recording(path or run / RECORDING, video, tracks, kin, comparison, model_px,
                           spawn=spawn, fit=fit)
