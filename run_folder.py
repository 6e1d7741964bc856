"""The run folder: every file a run writes, by name, and the readers of its tables.

One run folder holds one video's run (DESIGN.md, "The job, end to end"). Its
files are named here once; the producers (:mod:`.pipeline`, :mod:`.report`) and
the readers use these names, never their own spelling.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from .errors import CranktrackError
from .files import write_json_atomic

#: Per-frame marker positions, px (and mm after a calibration): the tracks table.
TRACKS = "tracks.csv"
#: θ, ω, α, v_B, L3 with σ: the kinematics table.
KINEMATICS = "kinematics.csv"
#: Every marker's velocity and acceleration with σ (mm/s, mm/s²), once there is a scale.
MOTION = "motion.csv"
#: Provenance, tracking and calibration quality, warnings.
RUN_INFO = "run.json"
#: The plane calibration the run used or made.
CALIBRATION = "calibration.json"
#: `track --format parquet`: the same two tables as Parquet, beside the CSV files
#: (which the other commands read).
TRACKS_PARQUET = "tracks.parquet"
KINEMATICS_PARQUET = "kinematics.parquet"
MOTION_PARQUET = "motion.parquet"
#: The run's summary for a person, and its kinematics figure (or, in a run without
#: kinematics, the figure of its tracks).
REPORT = "report.md"
KINEMATICS_FIGURE = "kinematics.png"
TRACKS_FIGURE = "tracks.png"
#: `cranktrack compare`: measured and model side by side, the fit, its summary.
COMPARE_TABLE = "compare.csv"
COMPARE_FIT = "compare.json"
COMPARE_REPORT = "compare.md"
#: `cranktrack fit`: the closed loop's folder and its files.
FIT_DIR = "fit"
FIT_TABLE = "fit.csv"
FIT_REPORT_JSON = "report.json"
FIT_REPORT = "report.md"
FIT_FIGURE = "residuals.png"
#: The Rerun recording.
RECORDING = "run.rrd"
#: The tracker's state after an interruption, for `track --resume`.
TRACKER_STATE = ".tracker_state.pkl"
#: Held while a `track` writes the folder: the writer's process id.
LOCK = ".cranktrack.lock"
#: What each step made and from what: the SHA-256 of the tables it wrote and read,
#: and the video's size and time, so a later step can tell what is out of date.
MANIFEST = "manifest.json"

#: What a tracking run writes or derives from its tracks: cleared before a fresh run
#: of the same video, so a file of the earlier run (kinematics from an earlier
#: scale, a fit of the earlier tracks) cannot sit beside the new ones.
RUN_OUTPUTS = (TRACKS, KINEMATICS, MOTION, TRACKS_PARQUET, KINEMATICS_PARQUET,
               MOTION_PARQUET, RUN_INFO,
               CALIBRATION, REPORT, KINEMATICS_FIGURE, TRACKS_FIGURE, COMPARE_TABLE, COMPARE_FIT,
               COMPARE_REPORT, RECORDING, MANIFEST)


@dataclass(frozen=True)
class RunFolder:
    """The paths of one run folder (``path``) and its tables, read on demand."""

    path: Path

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    @property
    def fit_dir(self) -> Path:
        return self.path / FIT_DIR

    def read_json(self, name: str) -> dict | None:
        """The JSON file ``name`` of the folder, or None where it is missing or unreadable."""
        try:
            return json.loads((self.path / name).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None

    def _read_table(self, name: str, options: str, needed: set[str], what: str
                    ) -> pd.DataFrame:
        """The CSV table ``name`` of the folder, with the columns ``needed``; ``options``
        are those `cranktrack track` needs to write it, ``what`` names the table."""
        path = self.path / name
        if not path.is_file():
            raise CranktrackError(f"{path} does not exist; run `cranktrack track VIDEO --out "
                                  f"{self.path}{options}` first")
        try:
            table = pd.read_csv(path)
        except (pd.errors.ParserError, UnicodeDecodeError, pd.errors.EmptyDataError) as e:
            raise CranktrackError(f"{path} is not a readable CSV table ({e})") from None
        missing = needed - set(table.columns)
        if missing:
            raise CranktrackError(f"{path} lacks the column(s) {sorted(missing)}; is it a "
                                  f"cranktrack {what} table?")
        return table

    def read_tracks(self) -> pd.DataFrame:
        """The tracks table (pixels, and plane mm where a scale was given)."""
        return self._read_table(TRACKS, "", {"frame", "t_s"}, "tracks")

    def read_kinematics(self) -> pd.DataFrame:
        """The kinematics table, checked to be a cranktrack kinematics table."""
        return self._read_table(KINEMATICS, " --known-length A-C=MM",
                                {"frame", "t_s", "theta_deg", "theta_deg_sigma", "L3_mm"},
                                "kinematics")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: alive
        return True
    return True


@contextmanager
def claimed(folder: Path) -> Iterator[Path]:
    """Hold ``folder`` for one writer: a second `track` into it while the first runs is
    refused with one sentence. A lock left by a process that has died is taken over."""
    lock = Path(folder) / LOCK
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                pid = int(lock.read_text().strip() or 0)
            except (OSError, ValueError):
                pid = 0
            if pid and pid != os.getpid() and _alive(pid):
                raise CranktrackError(f"another cranktrack (process {pid}) is writing {folder}; "
                                      "wait for it to finish or give another --out") from None
            lock.unlink(missing_ok=True)  # stale: its writer is gone
            continue
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
        break
    else:  # another writer took the stale lock between our two tries
        raise CranktrackError(f"another cranktrack is starting to write {folder}; wait for it "
                              "to finish or give another --out")
    try:
        yield Path(folder)
    finally:
        lock.unlink(missing_ok=True)


def clear_for(folder: Path, video: str | os.PathLike, overwrite: bool = False) -> list[str]:
    """Make ``folder`` ready for a fresh run of ``video``: refuse a folder that holds
    another video's run (unless ``overwrite``), and remove the earlier run's outputs
    (:data:`RUN_OUTPUTS`, the fit folder and any interrupted run's tracker state).
    Returns the names removed."""
    info = RunFolder(folder).read_json(RUN_INFO)
    here = str(Path(video).resolve())
    before = (info or {}).get("source", {}).get("path")
    if before and before != here and not overwrite:
        raise CranktrackError(f"{folder} already holds the run of {before}; give another --out "
                              "for this video, or --overwrite to replace that run")
    removed = []
    if (Path(folder) / TRACKER_STATE).exists():  # a fresh run: nothing of it to resume
        (Path(folder) / TRACKER_STATE).unlink()
        removed.append(TRACKER_STATE)
    for name in RUN_OUTPUTS:
        if (Path(folder) / name).exists():
            (Path(folder) / name).unlink()
            removed.append(name)
    fit = Path(folder) / FIT_DIR
    if fit.is_dir():
        shutil.rmtree(fit)
        removed.append(FIT_DIR)
    return removed


def run_folder(path: str | os.PathLike | RunFolder) -> RunFolder:
    """``path`` as a :class:`RunFolder`."""
    return path if isinstance(path, RunFolder) else RunFolder(Path(path))


def _sha256(path: Path) -> str | None:
    """The file's SHA-256 (hex), or None where it is missing or unreadable."""
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def _video_stamp(video: str | os.PathLike) -> dict:
    """What says a video is the same file: its path, size (bytes) and modification time."""
    p = Path(video).resolve()
    try:
        st = p.stat()
    except OSError:
        return {"path": str(p)}
    return {"path": str(p), "bytes": st.st_size, "mtime_ns": st.st_mtime_ns}


def record_step(folder: str | os.PathLike, step: str, made: Sequence[str],
                read: Sequence[str] = (), video: str | os.PathLike | None = None) -> Path:
    """Write into the folder's manifest what ``step`` (``track``, ``compare``, ``fit``)
    ``made`` and ``read``: each file's SHA-256, by its name in the folder. ``track``
    also gives the ``video``. The other steps' entries are kept: a fresh run has
    cleared the manifest with the rest (:func:`clear_for`), and after a resumed one
    they say which results were made from the tables before it."""
    folder = Path(folder)
    manifest = RunFolder(folder).read_json(MANIFEST) or {"schema": 1, "steps": {}}
    if video is not None:
        manifest["video"] = _video_stamp(video)
    manifest["steps"][step] = {"made": {n: _sha256(folder / n) for n in made},
                               "read": {n: _sha256(folder / n) for n in read}}
    return write_json_atomic(folder / MANIFEST, manifest)


def out_of_date(folder: str | os.PathLike, steps: Sequence[str] | None = None) -> list[str]:
    """Sentences on what in the run folder no longer matches what made it: a table
    changed since the step that wrote it, a step's results made from an earlier table,
    a video changed since it was tracked. Only the ``steps`` named are looked at (all
    by default). Empty for a folder without a manifest (made before there was one) or
    with nothing out of date."""
    folder = Path(folder)
    manifest = RunFolder(folder).read_json(MANIFEST)
    if not manifest:
        return []
    notes = []
    digests: dict[str, str | None] = {}  # each table hashed once, however many steps name it

    def now(name: str) -> str | None:
        if name not in digests:
            digests[name] = _sha256(folder / name)
        return digests[name]

    stamp = manifest.get("video") or {}
    if "bytes" in stamp and _video_stamp(stamp["path"]) != stamp:
        notes.append(f"the video {stamp['path']} has changed or gone since it was tracked; "
                     "track it again for results of the video as it is now")
    for step, entry in manifest.get("steps", {}).items():
        if steps is not None and step not in steps:
            continue
        for name, digest in entry.get("made", {}).items():
            if digest and now(name) and now(name) != digest:
                notes.append(f"{name} has changed since `cranktrack {step}` wrote it (edited, "
                             "or written by another program)")
        stale = [name for name, digest in entry.get("read", {}).items()
                 if digest and now(name) != digest]
        if stale:
            made = list(entry.get("made", {})) or ["its results"]
            notes.append(f"{', '.join(made)} {'was' if len(made) == 1 else 'were'} made from "
                         f"an earlier {' and '.join(stale)}; run `cranktrack {step}` again")
    return notes
