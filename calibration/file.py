"""Calibration files: JSON with a schema version.

Two kinds share the format: a *plane* calibration (pixels → mm, what
``track --calibration`` needs; it may embed camera intrinsics) and a
*camera* calibration (intrinsics only, from ``calibrate camera``).
Schema 1 files (known-length only) are still read.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..errors import CranktrackError
from ..files import write_json_atomic
from .camera import CameraCalibration
from .plane import PlaneCalibration, similarity

SCHEMA = 2


def save_calibration(path: str | os.PathLike, cal: PlaneCalibration) -> Path:
    """Write a plane calibration."""
    return write_json_atomic(path, {"schema": SCHEMA, "kind": "plane", **cal.to_dict()})


def save_camera(path: str | os.PathLike, camera: CameraCalibration) -> Path:
    """Write a camera (intrinsics) calibration."""
    return write_json_atomic(path, {"schema": SCHEMA, "kind": "camera", "method": "camera",
                                    **camera.to_dict()})


def _read(path: str | os.PathLike) -> tuple[Path, dict]:
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CranktrackError(f"calibration file {p} does not exist") from None
    except IsADirectoryError:
        raise CranktrackError(f"{p} is a folder, not a calibration file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise CranktrackError(f"calibration file {p} is not valid JSON ({e})") from None
    schema = data.get("schema") if isinstance(data, dict) else None
    if schema not in (1, SCHEMA):
        raise CranktrackError(
            f"calibration file {p} has schema {schema!r}; this cranktrack reads schemas 1 and "
            f"{SCHEMA}")
    return p, data


def _check_size(p: Path, made: tuple[int, int], image_size: tuple[int, int] | None) -> None:
    if image_size is not None and tuple(image_size) != tuple(made):
        raise CranktrackError(
            f"calibration file {p} was made for {made[0]}x{made[1]} images, "
            f"but the video is {image_size[0]}x{image_size[1]}; calibrate for this camera setting")


def load_camera(path: str | os.PathLike) -> CameraCalibration:
    """Read camera intrinsics (from a camera file, or embedded in a plane file)."""
    p, data = _read(path)
    try:
        d = data if data.get("kind") == "camera" else data.get("camera")
        if not d:
            raise CranktrackError(f"{p} holds no camera intrinsics; make them with "
                                  "`cranktrack calibrate camera`")
        return CameraCalibration.from_dict(d)
    except (KeyError, IndexError, TypeError, ValueError, OverflowError) as e:
        raise CranktrackError(f"calibration file {p} is missing or has a bad field ({e})") from None


def load_calibration(path: str | os.PathLike,
                     image_size: tuple[int, int] | None = None) -> PlaneCalibration:
    """Read a plane calibration, refusing one made for another image size.

    Raises
    ------
    CranktrackError
        Missing or unreadable file, unknown schema, a camera-only file,
        missing fields, or an image size that differs from ``image_size``.
    """
    p, data = _read(path)
    if data.get("kind") == "camera":
        raise CranktrackError(
            f"{p} holds camera intrinsics only; map the mechanism plane with `cranktrack "
            "calibrate plane` (a board lying in the plane, or four known points)")
    try:
        size = (int(data["image_size"][0]), int(data["image_size"][1]))
        if data["schema"] == 1:  # known-length only: a similarity
            H = similarity(float(data["mm_per_px"]),
                           (float(data["origin_px"][0]), float(data["origin_px"][1])),
                           float(data["x_axis_deg"]))
            camera = None
        else:
            H = np.asarray(data["homography_px_to_mm"], float).reshape(3, 3)
            camera = (CameraCalibration.from_dict(data["camera"]) if data.get("camera")
                      else None)
        cal = PlaneCalibration(str(data["method"]), H, size, camera,
                               dict(data.get("quality", {})), tuple(data.get("warnings", ())))
    except (KeyError, IndexError, TypeError, ValueError, OverflowError) as e:
        # OverflowError: an image size of Infinity (json writes it for inf) cannot be an int.
        raise CranktrackError(f"calibration file {p} is missing or has a bad field ({e})") from None
    _check_size(p, size, image_size)
    return cal
