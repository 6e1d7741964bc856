"""The calibration file: JSON with a schema version."""

from __future__ import annotations

import json
import os
from pathlib import Path

from cranktrack.calibration.known_length import PlaneCalibration
from cranktrack.errors import CranktrackError
from cranktrack.files import write_json_atomic

SCHEMA = 1


def save_calibration(path: str | os.PathLike, cal: PlaneCalibration) -> Path:
    """Write ``cal`` as a schema-versioned JSON file."""
    return write_json_atomic(path, {
        "schema": SCHEMA,
        "method": cal.method,
        "image_size": list(cal.image_size),
        "mm_per_px": cal.mm_per_px,
        "origin_px": list(cal.origin_px),
        "x_axis_deg": cal.x_axis_deg,
        "quality": cal.quality,
        "warnings": list(cal.warnings),
    })


def load_calibration(path: str | os.PathLike,
                     image_size: tuple[int, int] | None = None) -> PlaneCalibration:
    """Read a calibration file, refusing one made for another image size.

    Raises
    ------
    CranktrackError
        Missing or unreadable file, unknown schema, missing fields, or an
        image size that differs from ``image_size``.
    """
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CranktrackError(f"calibration file {p} does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise CranktrackError(f"calibration file {p} is not valid JSON ({e})") from None
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        found = data.get("schema") if isinstance(data, dict) else None
        raise CranktrackError(
            f"calibration file {p} has schema {found!r}; this cranktrack reads schema {SCHEMA}")
    try:
        cal = PlaneCalibration(
            method=str(data["method"]),
            mm_per_px=float(data["mm_per_px"]),
            origin_px=(float(data["origin_px"][0]), float(data["origin_px"][1])),
            x_axis_deg=float(data["x_axis_deg"]),
            image_size=(int(data["image_size"][0]), int(data["image_size"][1])),
            quality=dict(data.get("quality", {})),
            warnings=tuple(data.get("warnings", ())),
        )
    except (KeyError, IndexError, TypeError, ValueError) as e:
        raise CranktrackError(f"calibration file {p} is missing or has a bad field ({e})") from None
    if image_size is not None and tuple(image_size) != cal.image_size:
        raise CranktrackError(
            f"calibration file {p} was made for {cal.image_size[0]}x{cal.image_size[1]} images, "
            f"but the video is {image_size[0]}x{image_size[1]}; calibrate for this camera setting")
    return cal
