"""Many videos at once: one run folder per video and a summary table.

Locally the videos are spread over processes (all cores by default); given
the address of a Dask ``distributed`` scheduler they run on that cluster
instead. One video failing is a row in the summary, not the end of the batch.
"""

from __future__ import annotations

import glob
import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from .errors import CranktrackError, RunInterrupted
from .files import ensure_dir, write_csv_atomic

if TYPE_CHECKING:
    from .calibration.ruler import Ruler
    from .tracker.markers import MarkerSpec


def find_videos(pattern: str) -> list[Path]:
    """Videos matching a glob pattern (``'recordings/*.mp4'``), sorted."""
    paths = sorted(Path(p) for p in glob.glob(os.path.expanduser(pattern), recursive=True))
    paths = [p for p in paths if p.is_file()]
    if not paths:
        raise CranktrackError(f"no files match {pattern!r}; quote the pattern so the shell "
                              "passes it unexpanded, e.g. 'recordings/*.mp4'")
    return paths


def _folder_for(video: Path, out: Path, taken: set[str]) -> Path:
    name = video.stem
    k = 1
    while name in taken:  # two videos of one name in different folders
        k += 1
        name = f"{video.stem}_{k}"
    taken.add(name)
    return out / name


def process_one(video: str, folder: str, known_length: tuple[str, str, float] | None,
                compare: bool, resume: bool = False, readout_s: float = 0.0,
                specs: tuple[MarkerSpec, ...] | None = None,
                fps: float | None = None, ruler: Ruler | None = None) -> dict:
    """Track (and optionally compare) one video; never raises for bad input.

    Runs in a worker process or on a Dask worker, so it imports what it needs.
    With ``resume``, a run interrupted in ``folder`` continues where it stopped.
    ``readout_s`` is the camera's rolling-shutter readout (s, top row to bottom row).
    ``specs`` are the markers to track (None: the crank-slider's A, B and C), ``fps``
    the rate the video was taken at (`track`'s ``--fps``; None: its own clock),
    ``ruler`` the scale from two points of the frame (`track`'s ``--ruler``): the row
    then has each marker's median acceleration, ``NAME_ax_median_mm_s2`` and
    ``NAME_ay_median_mm_s2`` (a drop's −g).
    """
    from .pipeline import compare_run, track_run
    from .run_folder import TRACKER_STATE
    from .tracker.markers import DEFAULT_MARKERS

    row: dict = {"video": video, "run": folder, "status": "ok", "message": ""}
    try:
        resume = resume and (Path(folder) / TRACKER_STATE).exists()
        run = track_run(video, folder, known_length, specs or DEFAULT_MARKERS, fps=fps,
                        resume=resume, readout_s=readout_s, ruler=ruler)
        t = run.tracks
        row["frames"] = len(t)
        for m in [c[:-3] for c in t.columns if c.endswith("_ok")]:
            row[f"{m}_found_pct"] = round(100 * float(t[f"{m}_ok"].mean()), 2)
            for axis in ("ax", "ay"):
                col = f"{m}_{axis}_mm_s2"
                if run.motion is not None and run.motion[col].notna().any():
                    row[f"{m}_{axis}_median_mm_s2"] = float(run.motion[col].median())
        if run.kinematics is not None:
            th = run.kinematics["theta_deg"]
            row["theta_min_deg"], row["theta_max_deg"] = float(th.min()), float(th.max())
            row["rocking_deg"] = float(th.max() - th.min())
        if compare and run.kinematics is not None:
            result, _ = compare_run(Path(folder), {"speed_mm_s": 14.0})
            s = result.summary.set_index("quantity")
            for q in ("theta_deg", "omega_rad_s", "vB_mm_s"):
                row[f"{q}_rmse"] = float(s.loc[q, "rms"])
                row[f"{q}_fit_pct"] = float(s.loc[q, "fit_pct"])
        row["warnings"] = len(run.warnings)
    except CranktrackError as e:
        row["status"], row["message"] = "failed", str(e)
    except Exception as e:  # a bug, but one video must not stop the batch
        row["status"], row["message"] = "error", f"{type(e).__name__}: {e}"
    return row


def run_batch(
    pattern: str,
    out_dir: str | os.PathLike,
    known_length: tuple[str, str, float] | None = None,
    compare: bool = False,
    jobs: int | None = None,
    scheduler: str | object | None = None,
    on_done: Callable[[dict], None] | None = None,
    on_start: Callable[[int], None] | None = None,
    resume: bool = False,
    readout_s: float = 0.0,
    specs: tuple[MarkerSpec, ...] | None = None,
    fps: float | None = None,
    ruler: Ruler | None = None,
) -> pd.DataFrame:
    """Process every video matching ``pattern``; write and return ``summary.csv``.

    ``scheduler`` is a Dask scheduler address (``tcp://host:8786``) or a
    ``distributed.Client``; without it, ``jobs`` local processes (default:
    all cores). ``on_start(n)`` is called with the number of videos to do, ``on_done(row)``
    as each video finishes.

    Ctrl-C writes the summary of the videos that finished (the others are rows
    with status ``interrupted``) and raises :class:`RunInterrupted`. ``resume``
    keeps the rows of videos an earlier ``summary.csv`` has as ``ok`` and runs
    only the rest, each continuing from where it was interrupted. ``readout_s`` (s) is
    the rolling-shutter readout of the one camera that filmed them all (`track`'s
    ``--rolling-shutter-ms``); a video whose frame it does not fit in fails alone.
    ``specs`` are the markers tracked in every video (`track`'s ``--marker``, parsed;
    None: A, B and C), ``fps`` the rate they were all taken at (``--fps``), ``ruler`` the
    scale of the one camera's view (``--ruler``, parsed).

    The local processes start afresh and import the calling script again, so from a
    script call it under ``if __name__ == "__main__":``. A worker that stops abruptly
    (killed, out of memory, or an unguarded script) ends the batch with one
    :class:`CranktrackError`, after the summary of the videos that finished is
    written (the others are rows with status ``not run``).
    """
    videos = find_videos(pattern)
    out = ensure_dir(out_dir)
    taken: set[str] = set()
    tasks = [(str(v), str(_folder_for(v, out, taken)), known_length, compare, resume,
              readout_s, specs, fps, ruler) for v in videos]
    rows = _finished(out / SUMMARY, {t[0] for t in tasks}) if resume else []
    done = {r["video"] for r in rows}
    tasks = [t for t in tasks if t[0] not in done]
    if on_start:
        on_start(len(tasks))
    try:
        _run_tasks(tasks, rows, jobs, scheduler, on_done)
    except KeyboardInterrupt as e:
        _write_summary(out, _with_unfinished(rows, tasks, "interrupted", "stopped by Ctrl-C"))
        raise RunInterrupted(str(out), True) from e
    except BrokenProcessPool:
        why = ("a worker process of the batch stopped abruptly: it was killed or ran out of "
               "memory, or run_batch was called from a script outside "
               "`if __name__ == \"__main__\":` (its workers import the script again)")
        _write_summary(out, _with_unfinished(rows, tasks, "not run", why))
        raise CranktrackError(f"{why}; the videos that finished are in "
                              f"{out / SUMMARY}") from None
    return _write_summary(out, rows)


def _with_unfinished(rows: list[dict], tasks: list[tuple], status: str, message: str
                     ) -> list[dict]:
    """``rows`` and a row of ``status`` for each task that has none."""
    finished = {r["video"] for r in rows}
    return rows + [{"video": t[0], "run": t[1], "status": status, "message": message}
                   for t in tasks if t[0] not in finished]


#: The batch's table, one row per video.
SUMMARY = "summary.csv"


def _finished(path: Path, videos: set[str]) -> list[dict]:
    """The rows of an earlier summary whose video finished ``ok`` and is still asked for."""
    if not path.exists():
        return []
    try:
        old = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as e:
        raise CranktrackError(f"{path} cannot be read ({e}); run without --resume") from None
    if not {"video", "status"} <= set(old.columns):
        raise CranktrackError(f"{path} is not a cranktrack batch summary; run without --resume")
    keep = old[(old["status"] == "ok") & old["video"].isin(videos)]
    return [{k: v for k, v in row.items() if pd.notna(v)} for row in keep.to_dict("records")]


def _write_summary(out: Path, rows: list[dict]) -> pd.DataFrame:
    summary = pd.DataFrame(rows)
    if len(summary):
        summary = summary.sort_values("video").reset_index(drop=True)
    write_csv_atomic(out / SUMMARY, summary)
    return summary


def _run_tasks(tasks: list[tuple], rows: list[dict], jobs: int | None,
               scheduler: str | object | None, on_done: Callable[[dict], None] | None
               ) -> None:
    """Run ``process_one`` on each task, appending each finished row to ``rows``."""
    if not tasks:
        return
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise CranktrackError(
                "--scheduler needs Dask: pip install 'cranktrack[dask]'") from None
        client = scheduler if isinstance(scheduler, Client) else None
        try:
            client = client or Client(scheduler, timeout="10s")
        except OSError as e:
            raise CranktrackError(f"cannot reach the Dask scheduler at {scheduler} ({e})") from None
        try:
            futures = client.map(lambda a: process_one(*a), tasks, pure=False)
            for fut in _as_completed_dask(futures):
                rows.append(fut.result())
                if on_done:
                    on_done(rows[-1])
        finally:
            if client is not scheduler:
                client.close()
    else:
        workers = jobs or os.cpu_count() or 1
        # Started afresh, not forked: a fork copies a process that holds OpenCV's,
        # numba's and the decoder's threads, and a lock one of them held at that moment
        # is never let go in the copy (a test's batch of two, forked from a pytest
        # worker that had tracked before, hung asleep once in CI).
        with ProcessPoolExecutor(max_workers=min(workers, len(tasks)),
                                 mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = [pool.submit(process_one, *a) for a in tasks]
            try:
                for fut in as_completed(futures):
                    rows.append(fut.result())
                    if on_done:
                        on_done(rows[-1])
            except KeyboardInterrupt:
                pool.shutdown(wait=True, cancel_futures=True)
                raise


def _as_completed_dask(futures):
    from distributed import as_completed as dask_as_completed

    return dask_as_completed(futures)

