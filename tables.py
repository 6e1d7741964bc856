"""Column names of the tables that pass between the parts (DESIGN.md, "Contracts").

Units are in the names. Angles in files are degrees; inside code, radians.
"""

from __future__ import annotations

#: The default markers: green A (pivot), red B (crank tip), blue C (slider/wire end).
MARKERS: tuple[str, ...] = ("A", "B", "C")

#: Per-marker columns of the tracks table, pixel space (OpenCV convention:
#: centre of the top-left pixel is (0, 0), x right, y down).
TRACK_PX_SUFFIXES: tuple[str, ...] = ("_x_px", "_y_px", "_sigma_px", "_ok")

#: Per-marker status the tracker adds after the pixel columns: ``ok``, ``not_found``,
#: ``partly_covered``, ``interpolated`` (``--fill-gaps``), …
STATUS_SUFFIX = "_status"

#: Per-marker columns a calibration adds (mechanism plane: A at the origin, C on +x).
TRACK_MM_SUFFIXES: tuple[str, ...] = ("_x_mm", "_y_mm", "_sigma_mm")

#: The kinematics table; each also has a ``<name>_sigma`` column (1-σ, same unit).
KINEMATICS_VALUES: tuple[str, ...] = (
    "theta_deg",
    "omega_rad_s",
    "alpha_rad_s2",
    "vB_x_mm_s",
    "vB_y_mm_s",
    "vB_mm_s",
    "vB_dir_deg",
    "L3_mm",
    "L3_rate_mm_s",
)


def track_px_columns(markers: tuple[str, ...] = MARKERS) -> list[str]:
    """``frame``, ``t_s`` and the pixel columns for each marker, in file order."""
    return ["frame", "t_s"] + [m + s for m in markers for s in TRACK_PX_SUFFIXES]


def tracker_columns(markers: tuple[str, ...] = MARKERS) -> list[str]:
    """The columns the tracker writes, in file order: the pixel ones and each status."""
    return ["frame", "t_s"] + [m + s for m in markers
                               for s in (*TRACK_PX_SUFFIXES, STATUS_SUFFIX)]


def track_mm_columns(markers: tuple[str, ...] = MARKERS) -> list[str]:
    """The plane-coordinate columns a calibration adds for each marker."""
    return [m + s for m in markers for s in TRACK_MM_SUFFIXES]


def kinematics_columns() -> list[str]:
    """``frame``, ``t_s`` and every kinematics value followed by its ``_sigma``."""
    cols = ["frame", "t_s"]
    for name in KINEMATICS_VALUES:
        cols += [name, name + "_sigma"]
    return cols
