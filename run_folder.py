"""The run folder: every file a run writes, by name, and the readers of its tables.

One run folder holds one video's run (DESIGN.md, "The job, end to end"). Its
files are named here once; the producers (:mod:`.pipeline`, :mod:`.report`) and
the readers use these names, never their own spelling.
"""

from __future__ import annotations

import json
import os
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


def run_folder(path: str | os.PathLike | RunFolder) -> RunFolder:
    """``path`` as a :class:`RunFolder`."""
    return path if isinstance(path, RunFolder) else RunFolder(Path(path))
