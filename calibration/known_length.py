"""Scale from a known marker-to-marker length, and the mechanism's plane frame.

The simplest calibration, as in the thesis ("calibrating pixel width and
height to real units"): one scale for the whole image, from a distance that
is constant in the mechanism (by default the frame A–C). The plane frame puts
A at the origin and C on +x (median positions over the run), with y 90°
counter-clockwise in the plane, which for a camera looking down is *up* in
the image.

The result is a :class:`~cranktrack.calibration.plane.PlaneCalibration`
whose homography is that similarity. This is only right for a camera square
to the plane with a lens that does
not bend lines; the spread of the known length over the run is reported as
the quality figure, because tilt and distortion show up as a length that
changes with position.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import CranktrackError
from .plane import PlaneCalibration, similarity

#: Relative spread (std / median) of the known length above which we warn.
SPREAD_WARNING = 0.01


def parse_known_length(text: str) -> tuple[str, str, float]:
    """Parse ``"A-C=160.8"`` into ``("A", "C", 160.8)``."""
    try:
        pair, value = text.split("=")
        a, b = (s.strip() for s in pair.split("-"))
        length = float(value)
    except ValueError:
        raise CranktrackError(
            f"--known-length {text!r} is not of the form NAME-NAME=MILLIMETRES, "
            "e.g. A-C=160.8") from None
    if not a or not b or a == b or not 0 < length < float("inf"):
        raise CranktrackError(
            f"--known-length {text!r} needs two different markers and a positive, finite "
            "length")
    return a, b, length


def _median_point(tracks: pd.DataFrame, name: str) -> tuple[float, float]:
    ok = tracks[f"{name}_ok"].to_numpy(bool)
    return (float(np.median(tracks.loc[ok, f"{name}_x_px"])),
            float(np.median(tracks.loc[ok, f"{name}_y_px"])))


def calibrate_known_length(
    tracks: pd.DataFrame,
    a: str,
    b: str,
    length_mm: float,
    image_size: tuple[int, int],
    origin: str = "A",
    axis_to: str | None = "C",
    pixel_aspect: float = 1.0,
) -> PlaneCalibration:
    """Scale from the known distance between markers ``a`` and ``b``.

    Uses every frame where both are found; the scale comes from the median
    pixel distance. The plane frame has ``origin`` at (0, 0) and ``axis_to``
    on +x (None: +x along the image's x, +y up). ``pixel_aspect`` is how many times
    as wide as high a pixel is shown (:attr:`.FrameSource.pixel_aspect`): distances
    and angles are taken with x widened by it, and ``mm_per_px`` is per pixel of
    height.

    Raises
    ------
    CranktrackError
        A named marker is not in the table or never found together with the other.
    """
    for name in {a, b, origin, axis_to} - {None}:
        if f"{name}_ok" not in tracks:
            raise CranktrackError(f"marker {name} is not tracked, so it cannot be used for "
                                  "calibration")
    both = tracks[f"{a}_ok"].to_numpy(bool) & tracks[f"{b}_ok"].to_numpy(bool)
    if not both.any():
        raise CranktrackError(
            f"markers {a} and {b} are never found in the same frame, so their known length "
            "cannot set the scale")
    d_px = np.hypot(pixel_aspect * (tracks.loc[both, f"{a}_x_px"]
                                    - tracks.loc[both, f"{b}_x_px"]),
                    tracks.loc[both, f"{a}_y_px"] - tracks.loc[both, f"{b}_y_px"]).to_numpy()
    med = float(np.median(d_px))
    if not med > 0:
        raise CranktrackError(f"markers {a} and {b} sit on the same pixel; cannot set a scale")
    mm_per_px = length_mm / med
    d_mm = d_px * mm_per_px
    spread = float(np.std(d_mm))
    o = _median_point(tracks, origin)
    if axis_to is None:
        axis = 0.0
    else:
        c = _median_point(tracks, axis_to)
        axis = float(np.degrees(np.arctan2(-(c[1] - o[1]), pixel_aspect * (c[0] - o[0]))))
    # The scale's error is that of the two markers' positions, and on compressed
    # video most of a position's error persists from frame to frame (a bias), so
    # the median over frames does not average it away: no 1/√n.
    sig = [float(np.nanmedian(tracks.loc[both, f"{m}_sigma_px"])) if f"{m}_sigma_px" in tracks
           else 0.0 for m in (a, b)]
    quality = {
        "mm_per_px": mm_per_px,
        **({} if pixel_aspect == 1.0 else {"pixel_aspect": pixel_aspect}),
        "scale_rel_sigma": float(np.hypot(*sig) / med) if np.all(np.isfinite(sig)) else 0.0,
        "origin_px": list(o),
        "x_axis_deg": axis,
        "known_length": f"{a}-{b}",
        "known_length_mm": length_mm,
        "frames_used": int(both.sum()),
        "length_std_mm": spread,
        "length_range_mm": float(d_mm.max() - d_mm.min()),
        "length_relative_spread": spread / length_mm,
    }
    warnings = []
    if spread / length_mm > SPREAD_WARNING:
        warnings.append(
            f"the {a}-{b} distance varies by {100 * spread / length_mm:.1f}% (1σ) over the run; "
            "a rigid length should not, so the camera may be tilted or the lens distorting")
    # The similarity acts on pixels widened to square: x times the aspect.
    square = np.diag([pixel_aspect, 1.0, 1.0])
    homography = similarity(mm_per_px, (pixel_aspect * o[0], o[1]), axis) @ square
    return PlaneCalibration("known-length", homography, tuple(image_size), None, quality,
                            tuple(warnings))


def check_length(cal: PlaneCalibration, tracks: pd.DataFrame, a: str, b: str,
                 length_mm: float) -> PlaneCalibration:
    """Add a check-length figure to a calibration: how far the mapped a–b
    distance is from ``length_mm`` (median over the run, mm) and its spread."""
    both = tracks[f"{a}_ok"].to_numpy(bool) & tracks[f"{b}_ok"].to_numpy(bool)
    if not both.any():
        raise CranktrackError(f"markers {a} and {b} are never found in the same frame, so "
                              "the check length cannot be measured")
    xa, ya = cal.to_plane(tracks.loc[both, f"{a}_x_px"].to_numpy(),
                          tracks.loc[both, f"{a}_y_px"].to_numpy())
    xb, yb = cal.to_plane(tracks.loc[both, f"{b}_x_px"].to_numpy(),
                          tracks.loc[both, f"{b}_y_px"].to_numpy())
    d = np.hypot(xa - xb, ya - yb)
    residual = float(np.median(d) - length_mm)
    quality = {**cal.quality, "check_length": f"{a}-{b}", "check_length_mm": length_mm,
               "check_residual_mm": residual, "check_std_mm": float(np.std(d))}
    warnings = list(cal.warnings)
    if abs(residual) > 0.01 * length_mm:
        warnings.append(f"the calibrated {a}-{b} distance is {residual:+.2f} mm off the given "
                        f"{length_mm} mm; check the calibration or the length")
    return PlaneCalibration(cal.method, cal.homography, cal.image_size, cal.camera, quality,
                            tuple(warnings))
