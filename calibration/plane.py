"""Pixels → millimetres in the mechanism's plane.

Every plane calibration is the same two steps: undistort the point with the
camera's intrinsics (when known), then a 3×3 homography from ideal pixels to
plane mm. Only marker positions are undistorted, point by point — never whole
frames — so this costs nothing per frame.

Where the homography comes from:

- a known marker-to-marker length (:mod:`.known_length`): a similarity, right
  only for a camera square to the plane with a lens that does not bend lines;
- a calibration board photographed lying in the plane of the mechanism
  (:func:`board_plane`);
- four or more image points with known plane coordinates
  (:func:`points_plane`).

Finally :func:`align_to_markers` moves the plane frame so that A is at the
origin and C on +x, with y 90° counter-clockwise as seen by the camera (the
kinematics' convention); lengths are untouched.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import cv2
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import CranktrackError
from .camera import Board, CameraCalibration


@dataclass(frozen=True)
class PlaneCalibration:
    """A mapping from image pixels to plane millimetres.

    ``homography`` (3×3) maps *ideal* (undistorted) pixel coordinates to
    plane mm; ``camera`` holds the intrinsics used to undistort, or None
    (pixels taken as ideal). ``image_size`` (width, height) is the image
    size it is valid for; ``quality`` a dict of figures; ``warnings``
    sentences for the user.
    """

    method: str
    homography: NDArray[np.float64]
    image_size: tuple[int, int]
    camera: CameraCalibration | None = None
    quality: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    @cached_property
    def _inverse(self) -> NDArray[np.float64]:
        return np.linalg.inv(self.homography)

    def plane_points(self, px: NDArray) -> NDArray[np.float64]:
        """Image points (n, 2) px to plane points (n, 2) mm; NaN in, NaN out."""
        pts = np.asarray(px, float).reshape(-1, 2)
        if self.camera is not None:
            pts = self.camera.undistort_points(pts)
        h = pts @ self.homography[:, :2].T + self.homography[:, 2]
        with np.errstate(invalid="ignore", divide="ignore"):
            return h[:, :2] / h[:, 2:3]

    def image_points(self, mm: NDArray) -> NDArray[np.float64]:
        """Plane points (n, 2) mm back to image pixels (the inverse of :meth:`plane_points`)."""
        pts = np.asarray(mm, float).reshape(-1, 2)
        h = pts @ self._inverse[:, :2].T + self._inverse[:, 2]
        with np.errstate(invalid="ignore", divide="ignore"):
            ideal = h[:, :2] / h[:, 2:3]
        if self.camera is not None:
            ideal = self.camera.distort_points(ideal)
        return ideal

    def to_plane(self, x_px: NDArray, y_px: NDArray) -> tuple[NDArray, NDArray]:
        """Image points (px) to plane points (mm); NaN in, NaN out."""
        xy = self.plane_points(np.stack([np.asarray(x_px, float).ravel(),
                                         np.asarray(y_px, float).ravel()], 1))
        shape = np.shape(x_px)
        return xy[:, 0].reshape(shape), xy[:, 1].reshape(shape)

    def to_image(self, x_mm: NDArray, y_mm: NDArray) -> tuple[NDArray, NDArray]:
        """Plane points (mm) back to image pixels (the inverse of :meth:`to_plane`)."""
        xy = self.image_points(np.stack([np.asarray(x_mm, float).ravel(),
                                         np.asarray(y_mm, float).ravel()], 1))
        shape = np.shape(x_mm)
        return xy[:, 0].reshape(shape), xy[:, 1].reshape(shape)

    def mm_per_px(self, x_px: NDArray, y_px: NDArray) -> NDArray[np.float64]:
        """Local scale (mm per px, RMS over directions) at image points."""
        x, y = np.asarray(x_px, float), np.asarray(y_px, float)
        h = 0.5
        x0, y0 = self.to_plane(x - h, y)
        x1, y1 = self.to_plane(x + h, y)
        x2, y2 = self.to_plane(x, y - h)
        x3, y3 = self.to_plane(x, y + h)
        # Columns of the Jacobian; RMS singular value = √(‖J‖²_F / 2).
        frob = ((x1 - x0) ** 2 + (y1 - y0) ** 2 + (x3 - x2) ** 2 + (y3 - y2) ** 2) / (2 * h) ** 2
        return np.sqrt(frob / 2.0)

    @property
    def scale_sigma(self) -> float:
        """Relative 1-σ of the mapping's scale (dimensionless): an error shared
        by every length and speed the run measures; angles do not see it."""
        return float(self.quality.get("scale_rel_sigma", 0.0))

    def to_dict(self) -> dict:
        return {
            "method": self.method,
            "image_size": list(self.image_size),
            "homography_px_to_mm": self.homography.tolist(),
            "camera": None if self.camera is None else self.camera.to_dict(),
            "quality": self.quality,
            "warnings": list(self.warnings),
        }


def similarity(mm_per_px: float, origin_px: tuple[float, float], x_axis_deg: float
               ) -> NDArray[np.float64]:
    """Homography of a similarity: scale, A at ``origin_px``, +x along ``x_axis_deg``.

    The image's y points down, the plane's up, hence the reflection.
    """
    a = np.radians(x_axis_deg)
    c, s = np.cos(a), np.sin(a)
    R = np.array([[c, s], [-s, c]]) @ np.diag([1.0, -1.0]) * mm_per_px
    t = -R @ np.asarray(origin_px, float)
    return np.vstack([np.hstack([R, t[:, None]]), [0.0, 0.0, 1.0]])


def _fit_homography(ideal_px: NDArray, plane_mm: NDArray) -> tuple[NDArray, dict]:
    """Least-squares homography (all points, no RANSAC) and its quality figures:
    residuals (px, mm) and the relative 1-σ of its scale.

    The scale's σ is that of a least-squares similarity through the same
    points, to first order: the per-axis point scatter (RMS residual with the
    homography's 8 parameters taken out of the 2n degrees of freedom) over
    the points' RMS spread about their centroid.
    """
    H, _ = cv2.findHomography(ideal_px.reshape(-1, 1, 2), plane_mm.reshape(-1, 1, 2), 0)
    if H is None or not np.all(np.isfinite(H)):
        raise CranktrackError("the points do not determine a plane mapping (are four of them "
                              "on one line?)")
    proj = cv2.perspectiveTransform(ideal_px.reshape(-1, 1, 2).astype(np.float64), H)
    rms_mm = float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - plane_mm) ** 2, axis=1))))
    back = cv2.perspectiveTransform(plane_mm.reshape(-1, 1, 2).astype(np.float64),
                                    np.linalg.inv(H))
    rms_px = float(np.sqrt(np.mean(np.sum((back.reshape(-1, 2) - ideal_px) ** 2, axis=1))))
    n = len(plane_mm)
    per_axis = rms_mm * np.sqrt(n / max(2 * n - 8, 1))
    spread = float(np.sqrt(np.sum((plane_mm - plane_mm.mean(axis=0)) ** 2)))
    return H, {"points": n, "homography_rms_px": rms_px, "homography_rms_mm": rms_mm,
               "scale_rel_sigma": float(per_axis / spread) if spread > 0 else 0.0}


def board_plane(grey: NDArray[np.uint8], board: Board, camera: CameraCalibration | None
                ) -> PlaneCalibration:
    """The plane of a board photographed lying where the mechanism moves.

    Raises
    ------
    CranktrackError
        The board is not found, or the photo's size differs from the camera's.
    """
    size = (grey.shape[1], grey.shape[0])
    if camera is not None and camera.image_size != size:
        raise CranktrackError(
            f"the plane photo is {size[0]}x{size[1]} but the camera was calibrated at "
            f"{camera.image_size[0]}x{camera.image_size[1]}")
    found = board.detect(grey)
    if found is None:
        raise CranktrackError(f"the {board.kind} {board.size[0]}x{board.size[1]} was not found "
                              "in the plane photo")
    obj, img = found
    img = img.reshape(-1, 2).astype(np.float64)
    ideal = camera.undistort_points(img) if camera is not None else img
    H, quality = _fit_homography(ideal, obj[:, :2].astype(np.float64))
    return PlaneCalibration("board-plane", H, size, camera, {**quality, "board": board.to_dict()})


def points_plane(image_px: NDArray, plane_mm: NDArray, image_size: tuple[int, int],
                 camera: CameraCalibration | None) -> PlaneCalibration:
    """The plane from four or more image points with known plane coordinates (mm)."""
    img = np.asarray(image_px, float).reshape(-1, 2)
    mm = np.asarray(plane_mm, float).reshape(-1, 2)
    if len(img) < 4 or len(img) != len(mm):
        raise CranktrackError(f"a plane needs at least 4 points with both pixel and mm "
                              f"coordinates; got {len(img)}")
    ideal = camera.undistort_points(img) if camera is not None else img
    H, quality = _fit_homography(ideal, mm)
    return PlaneCalibration("points-plane", H, tuple(image_size), camera, quality)


def align_to_markers(cal: PlaneCalibration, tracks: pd.DataFrame, origin: str = "A",
                     axis_to: str | None = "C") -> PlaneCalibration:
    """Move the plane frame so ``origin`` is at (0, 0) and ``axis_to`` on +x (None:
    +x where the image's x direction at ``origin`` maps to).

    Uses the median plane positions over the run. The new y axis is 90°
    counter-clockwise from x *as the camera sees it*, whatever the
    handedness of the board's own frame.
    """
    pts = {}
    for m in (origin,) if axis_to is None else (origin, axis_to):
        ok = tracks[f"{m}_ok"].to_numpy(bool)
        if not ok.any():
            raise CranktrackError(f"marker {m} is never found, so the plane frame (A at the "
                                  "origin, C on +x) cannot be set")
        x, y = cal.to_plane(tracks.loc[ok, f"{m}_x_px"].to_numpy(),
                            tracks.loc[ok, f"{m}_y_px"].to_numpy())
        pts[m] = np.array([np.median(x), np.median(y)])
    if axis_to is None:
        ok = tracks[f"{origin}_ok"].to_numpy(bool)
        o_px = np.array([np.median(tracks.loc[ok, f"{origin}_x_px"]),
                         np.median(tracks.loc[ok, f"{origin}_y_px"])])
        x, y = cal.to_plane(np.array([o_px[0], o_px[0] + 1.0]), np.array([o_px[1]] * 2))
        ex = np.array([x[1] - x[0], y[1] - y[0]])
    else:
        ex = pts[axis_to] - pts[origin]
    if not np.hypot(*ex) > 0:
        raise CranktrackError(f"markers {origin} and {axis_to} coincide in the plane")
    ex = ex / np.hypot(*ex)
    ey = np.array([-ex[1], ex[0]])
    # Handedness: seen in the image (y flipped to point up), x then y must turn
    # counter-clockwise. Probe with image points 1 px along each mapped axis.
    Hinv = np.linalg.inv(cal.homography)

    def ideal(p: NDArray) -> NDArray:
        v = Hinv @ np.array([p[0], p[1], 1.0])
        return v[:2] / v[2]

    o = ideal(pts[origin])
    u, v = ideal(pts[origin] + ex) - o, ideal(pts[origin] + ey) - o
    if u[0] * (-v[1]) - (-u[1]) * v[0] < 0:
        ey = -ey
    R = np.vstack([ex, ey])  # rows: new axes in old coordinates
    T = np.eye(3)
    T[:2, :2] = R
    T[:2, 2] = -R @ pts[origin]
    return replace(cal, homography=T @ cal.homography)


def add_plane_coordinates(tracks: pd.DataFrame, cal: PlaneCalibration,
                          markers: tuple[str, ...]) -> pd.DataFrame:
    """A copy of ``tracks`` with ``_x_mm``, ``_y_mm`` and ``_sigma_mm`` per marker.

    ``_sigma_mm`` is ``_sigma_px`` times the local scale of the mapping at
    that point (perspective and distortion make it vary over the image).
    """
    out = tracks.copy()
    for m in markers:
        xp, yp = out[f"{m}_x_px"].to_numpy(), out[f"{m}_y_px"].to_numpy()
        x, y = cal.to_plane(xp, yp)
        out[f"{m}_x_mm"], out[f"{m}_y_mm"] = x, y
        out[f"{m}_sigma_mm"] = out[f"{m}_sigma_px"].to_numpy() * cal.mm_per_px(xp, yp)
    return out
