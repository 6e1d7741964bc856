"""The run folder: every file a run writes, by name, and the readers of its tables.

One run folder holds one video's run (DESIGN.md, "The job, end to end"). Its
files are named here once; the producers (:mod:`.pipeline`, :mod:`.report`) and
the readers use these names, never their own spelling.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from .errors import CranktrackError

#: Per-frame marker positions, px (and mm after a calibration): the tracks table.
TRACKS = "tracks.csv"
#: θ, ω, α, v_B, L3 with σ: the kinematics table.
KINEMATICS = "kinematics.csv"
#: Provenance, tracking and calibration quality, warnings.
RUN_INFO = "run.json"
#: The plane calibration the run used or made.
CALIBRATION = "calibration.json"
#: The run's summary for a person, and its kinematics figure.
REPORT = "report.md"
KINEMATICS_FIGURE = "kinematics.png"
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

#: What a tracking run writes or derives from its tracks: cleared before a fresh run
#: of the same video, so a file of the earlier run (kinematics from an earlier
#: scale, a fit of the earlier tracks) cannot sit beside the new ones.
RUN_OUTPUTS = (TRACKS, KINEMATICS, RUN_INFO, CALIBRATION, REPORT, KINEMATICS_FIGURE,
               COMPARE_TABLE, COMPARE_FIT, COMPARE_REPORT, RECORDING)


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

    def read_kinematics(self) -> pd.DataFrame:
        """The kinematics table, checked to be a cranktrack kinematics table."""
        path = self.path / KINEMATICS
        if not path.is_file():
            raise CranktrackError(f"{path} does not exist; run `cranktrack track VIDEO --out "
                                  f"{self.path} --known-length A-C=MM` first")
        try:
            measured = pd.read_csv(path)
        except (pd.errors.ParserError, UnicodeDecodeError, pd.errors.EmptyDataError) as e:
            raise CranktrackError(f"{path} is not a readable CSV table ({e})") from None
        missing = {"frame", "t_s", "theta_deg", "theta_deg_sigma", "L3_mm"} - set(
            measured.columns)
        if missing:
            raise CranktrackError(f"{path} lacks the column(s) {sorted(missing)}; is it a "
                                  "cranktrack kinematics table?")
        return measured


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


def clear_for(folder: Path, video: str | os.PathLike) -> list[str]:
    """Make ``folder`` ready for a fresh run of ``video``: refuse a folder that holds
    another video's run, and remove the earlier run's outputs (:data:`RUN_OUTPUTS`
    and the fit folder) where it held this one's. Returns the names removed."""
    info = RunFolder(folder).read_json(RUN_INFO)
    here = str(Path(video).resolve())
    before = (info or {}).get("source", {}).get("path")
    if before and before != here:
        raise CranktrackError(f"{folder} already holds the run of {before}; give another --out "
                              "for this video, or delete that folder first")
    removed = []
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
