"""The Python API: what ``cranktrack track`` and ``cranktrack fit`` do, for a notebook.

``import cranktrack as ct`` gives :func:`track`, :func:`measure`, :func:`open_run`,
:func:`fit`, :func:`flight`, :func:`swing` and :func:`rotation`.
They write the same run folder as the commands (so ``cranktrack view`` and the
reports work on it) and hand back DataFrames and a result object. Nothing here
prints, shows a progress bar or changes matplotlib's backend.

>>> import cranktrack as ct
>>> ct.fit("no/such/run")
Traceback (most recent call last):
...
cranktrack.errors.CranktrackError: no/such/run/kinematics.csv does not exist; run ...
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from .errors import CranktrackError
from .pipeline import RunResult, fit_run, measure_run, track_run
from .run_folder import FIT_DIR, FIT_TABLE, KINEMATICS, MOTION, TRACKS, run_folder

if TYPE_CHECKING:
    from .loop.flight import FlightLoop
    from .loop.result import LoopResult
    from .loop.rotation import RotationLoop
    from .loop.swing import SwingLoop

__all__ = ["Fit", "RunResult", "fit", "flight", "measure", "open_run", "rotation", "swing",
           "track"]


def _specs(markers: Mapping[str, str | float] | None):
    from .tracker.markers import DEFAULT_MARKERS, parse_markers

    if not markers:
        return DEFAULT_MARKERS
    return parse_markers([f"{name}={colour}" for name, colour in markers.items()])


def _plane(calibration: str | os.PathLike | None):
    """The plane calibration file ``calibration`` read, or None."""
    if calibration is None:
        return None
    from .calibration.file import load_calibration

    return load_calibration(calibration)


def _ruler(ruler: str | None):
    """``ruler`` ("X1,Y1,X2,Y2=MM", as ``--ruler`` takes it) parsed, or None."""
    if ruler is None:
        return None
    from .calibration.ruler import parse_ruler

    return parse_ruler(str(ruler))


def _known_length(known_length: tuple[str, str, float] | None
                  ) -> tuple[str, str, float] | None:
    """``known_length`` ("A", "C", mm) checked: the mm a positive, finite number."""
    if known_length is None:
        return None
    a, b, mm = known_length
    try:
        mm = float(mm)
    except (TypeError, ValueError):
        raise CranktrackError(f"known_length {a}-{b} = {mm!r} is not a number of mm") from None
    if not (np.isfinite(mm) and mm > 0):
        raise CranktrackError(f"known_length {a}-{b} = {mm} mm is not a positive length")
    return (str(a), str(b), mm)


def track(video: str | os.PathLike, markers: Mapping[str, str | float] | None = None,
          known_length: tuple[str, str, float] | None = None,
          out: str | os.PathLike | None = None, calibration: str | os.PathLike | None = None,
          start_s: float | None = None, end_s: float | None = None,
          roi: tuple[int, int, int, int] | None = None, window_s: float | None = None,
          fill_gaps: int = 0, on_frame: Callable[[int], None] | None = None,
          overwrite: bool = False, table_format: str = "csv",
          rolling_shutter_ms: float = 0.0, fps: float | None = None,
          ruler: str | None = None) -> RunResult:
    """Track ``video`` into a run folder and return the run (``.tracks``, ``.kinematics``).

    ``markers`` maps names to colours as ``--marker`` takes them (``{"A": "green"}``,
    ``{"ball": "white"}``, a hue in degrees, ``"#RRGGBB"``, with a shape and a place:
    ``{"B": "green:blob@423,111"}`` for an LED; ``{"ball": "template@161,53,35"}`` for
    a marker with no colour of its own, followed by its picture; default A green, B
    red, C blue). ``fps`` is the command's ``--fps``: the rate of a folder of pictures,
    or the rate a clip was taken at where it plays at another (a high-speed camera's
    1000 fps stored to play at 30).
    ``known_length`` ("A", "C", mm) sets the scale, or ``calibration`` names a plane
    calibration file; without either the tracks stay in pixels and there are no
    kinematics. ``ruler`` ("X1,Y1,X2,Y2=MM": two points of the frame in px, a known
    length apart) sets the scale for any markers instead; a run with a scale has each
    marker's velocity and acceleration in ``.motion`` (mm/s, mm/s²), and the
    crank-slider's θ, ω and v_B in ``.kinematics`` when it tracked A and B. ``out`` is
    the run folder (default: ``<video name>_run`` beside the
    video). ``start_s``/``end_s`` (s), ``roi`` (x, y, w, h px), ``window_s`` and
    ``fill_gaps`` (frames) are the command's ``--start``, ``--end``, ``--roi``,
    ``--window-s`` and ``--fill-gaps``; ``on_frame(index)`` is called after each frame.
    ``overwrite`` replaces the run of another video that ``out`` holds (otherwise refused).
    ``table_format="parquet"`` also writes the tables as Parquet beside the CSV files.
    ``rolling_shutter_ms`` is the command's ``--rolling-shutter-ms``: a rolling shutter's
    readout time (top row to bottom row), for the kinematics.

    Raises :class:`~cranktrack.errors.CranktrackError` with one sentence on bad input.
    """
    from .tracker.track import Roi, Span

    video = Path(video)
    if start_s is not None and end_s is not None and end_s < start_s:
        raise CranktrackError(f"end_s ({end_s:g}) comes before start_s ({start_s:g})")
    span = None
    if start_s is not None or end_s is not None:
        span = Span(start_s or 0.0, float("inf") if end_s is None else end_s, "s")
    plane = _plane(calibration)
    known_length = _known_length(known_length)
    folder = Path(out) if out is not None else video.with_name(f"{video.stem}_run")
    if fps is not None:
        try:
            fps = float(fps)
        except (TypeError, ValueError):
            fps = float("nan")
        if not (np.isfinite(fps) and fps > 0):
            raise CranktrackError("fps must be a positive number of frames a second")
    return track_run(video, folder, known_length, _specs(markers), fps=fps, window_s=window_s,
                     fill_gaps_frames=fill_gaps, calibration=plane, span=span,
                     roi=None if roi is None else Roi(*roi), on_frame=on_frame,
                     overwrite=overwrite, table_format=table_format,
                     readout_s=float(rolling_shutter_ms) / 1e3, ruler=_ruler(ruler))


def measure(run: RunResult | str | os.PathLike,
            known_length: tuple[str, str, float] | None = None,
            calibration: str | os.PathLike | None = None,
            rolling_shutter_ms: float | None = None,
            window_s: float | None = None, ruler: str | None = None) -> RunResult:
    """A run's kinematics measured again from its tracks, without tracking the video
    again: what ``cranktrack measure`` does. ``known_length`` ("A", "C", mm) or
    ``calibration`` (a plane calibration file) or ``ruler`` ("X1,Y1,X2,Y2=MM") gives a
    new scale (default: the run's
    own calibration.json); ``rolling_shutter_ms`` a new readout (None keeps the run's,
    0 takes it off); ``window_s`` the differentiator's window. The run folder's tables,
    run.json and report are rewritten.

    Raises :class:`~cranktrack.errors.CranktrackError` with one sentence on bad input.
    """
    folder = run.folder if isinstance(run, RunResult) else Path(run)
    readout_s = None if rolling_shutter_ms is None else float(rolling_shutter_ms) / 1e3
    return measure_run(folder, _known_length(known_length), _plane(calibration), window_s,
                       readout_s, ruler=_ruler(ruler))


def open_run(folder: str | os.PathLike) -> RunResult:
    """A run folder written before (by :func:`track` or ``cranktrack track``), read back."""
    from .calibration.file import load_calibration
    from .run_folder import CALIBRATION

    rf = run_folder(folder)
    try:
        tracks = pd.read_csv(rf.path / TRACKS)
    except (OSError, ValueError) as e:
        raise CranktrackError(f"{rf.path / TRACKS} cannot be read ({e})") from None
    kinematics = rf.read_kinematics() if (rf.path / KINEMATICS).exists() else None
    cal = load_calibration(rf.path / CALIBRATION) if (rf.path / CALIBRATION).exists() else None
    motion = pd.read_csv(rf.path / MOTION) if (rf.path / MOTION).exists() else None
    return RunResult(rf.path, tracks, kinematics, cal, motion=motion)


@dataclass(frozen=True)
class Fit:
    """What :func:`fit` found. ``loop`` is the whole :class:`~cranktrack.loop.result.LoopResult`;
    ``table`` has t (s), measured θ, the base and final models and both residuals (deg)
    per fitted frame; ``files`` what was written in the run's ``fit/`` folder."""

    loop: LoopResult
    table: pd.DataFrame
    files: list[Path] = field(default_factory=list)

    @property
    def effects(self) -> list[str]:
        """The effects the loop accepted, in order (empty: the base model is enough)."""
        return list(self.loop.effects)

    @property
    def rmse_before(self) -> float:
        """RMS of θ's residual under the base model, deg."""
        return float(self.loop.diagnosis_before["rmse_deg"])

    @property
    def rmse_after(self) -> float:
        """RMS of θ's residual with the accepted effects, deg."""
        return float(self.loop.diagnosis_after["rmse_deg"])

    @property
    def values(self) -> dict[str, float]:
        """Every parameter of the final model (units as in ``report()["parameters"]``)."""
        return dict(self.loop.final.values)

    def report(self) -> dict:
        """The fit's report, as written to ``fit/report.json``."""
        return self.loop.to_dict()

    def plot(self):
        """θ with both models and the residual before and after, as a matplotlib Figure
        (shown by a notebook, saved with ``.savefig``; the backend is left alone)."""
        from .report.fit import residual_figure

        return residual_figure(self.table, self.loop)


def fit(run: RunResult | str | os.PathLike, model: str = "spool",
        known: Mapping[str, float] | None = None) -> Fit:
    """Close the loop on a run: fit ``model`` (``"spool"``, ``"dynamic"`` or ``"sma"``)
    to its θ(t), try the effects the model lacks, and write ``fit/`` in its folder.

    ``known`` holds parameters measured on the rig (e.g. ``{"L1_mm": 160.8}``), held
    fixed; the rest are fitted. Raises :class:`~cranktrack.errors.CranktrackError` with
    one sentence for an unknown model or parameter, a non-finite value, or a run
    without kinematics.
    """
    from .loop.simulate import known_names

    folder = run.folder if isinstance(run, RunResult) else Path(run)
    names = known_names(model)
    known = dict(known or {})
    for k, v in known.items():
        if k not in names:
            raise CranktrackError(f"{k!r} is not a {model} parameter ({', '.join(names)})")
        try:
            finite = np.isfinite(float(v))
        except (TypeError, ValueError):
            finite = False
        if not finite:
            raise CranktrackError(f"known {k} = {v!r} is not a finite number")
    rf = run_folder(folder)
    result, files = fit_run(rf.path, model, {k: float(v) for k, v in known.items()})
    table = pd.read_csv(rf.path / FIT_DIR / FIT_TABLE)
    return Fit(result, table, files)


def flight(run: RunResult | str | os.PathLike, marker: str, start_s: float | None = None,
           end_s: float | None = None) -> FlightLoop:
    """Close the loop on marker ``marker``'s free flight in a run with a scale: what
    ``cranktrack fit RUN --model flight --marker NAME`` does. ``start_s``/``end_s`` (s)
    bound the flight (default: every frame the marker was found in). The result's
    ``.base`` is the parabola (``g_mm_s2``, ``g_sigma_mm_s2``), ``.accepted`` the effect
    taken (None: the parabola is enough), ``.candidates`` every effect tried; the run's
    ``fit/flight.json`` and ``fit/flight.csv`` are written.

    Raises :class:`~cranktrack.errors.CranktrackError` with one sentence on bad input.
    """
    from .pipeline import fit_flight_run

    return fit_flight_run(_folder(run), marker, _seconds(start_s, end_s))[0]


def swing(run: RunResult | str | os.PathLike, marker: str, length_mm: float | None = None,
          start_s: float | None = None, end_s: float | None = None) -> SwingLoop:
    """Close the loop on marker ``marker``'s swing in a run: what ``cranktrack fit RUN
    --model pendulum --marker NAME`` does. The result's ``.base`` is the damped sinusoid
    (``period_s``, ``period_sigma_s``; ``.g(length_mm)`` gives g in mm/s² and its σ),
    ``.accepted`` the effects taken, one at a time, joined by " + " (None: the sinusoid
    is enough), ``.final`` their fit, ``.candidates`` every fit tried, under the same
    names; ``length_mm`` (the string's) adds g to the run's ``fit/swing.json``.

    Raises :class:`~cranktrack.errors.CranktrackError` with one sentence on bad input.
    """
    from .pipeline import fit_swing_run

    return fit_swing_run(_folder(run), marker, _seconds(start_s, end_s), length_mm)[0]


def rotation(run: RunResult | str | os.PathLike, marker: str, start_s: float | None = None,
             end_s: float | None = None) -> RotationLoop:
    """Close the loop on marker ``marker``'s turn about a fixed axis in a run: what
    ``cranktrack fit RUN --model rotation --marker NAME`` does. The result's ``.base`` is
    the steady turn (``omega_rad_s`` at the track's middle, counterclockwise positive in
    the track's axes, and ``omega_sigma_rad_s``), ``.accepted`` the effects taken, one at
    a time, joined by " + " (None: the steady turn is enough), ``.final`` their fit and
    ``.candidates`` every fit tried.

    Raises :class:`~cranktrack.errors.CranktrackError` with one sentence on bad input.
    """
    from .pipeline import fit_rotation_run

    return fit_rotation_run(_folder(run), marker, _seconds(start_s, end_s))[0]


def _folder(run: RunResult | str | os.PathLike) -> Path:
    return run.folder if isinstance(run, RunResult) else Path(run)


def _seconds(start_s: float | None, end_s: float | None):
    """``start_s``…``end_s`` (s) as a span of the tracks, checked; None for all of them."""
    from .tracker.track import Span

    if start_s is not None and end_s is not None and end_s < start_s:
        raise CranktrackError(f"end_s ({end_s:g}) comes before start_s ({start_s:g})")
    if start_s is None and end_s is None:
        return None
    return Span(start_s or 0.0, float("inf") if end_s is None else end_s, "s")
