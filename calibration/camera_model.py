"""The one camera model on the measuring side: a pinhole, its tilt, and OpenCV's lens.

The lens is OpenCV's (radial k1, k2, k3 and tangential p1, p2 over coordinates
divided by the focal length), so a calibration from :mod:`.camera` and the closed
loop's lens candidate (:mod:`cranktrack.loop.camera_view`) bend points the same way.
Both directions go through OpenCV: :func:`distort_points` is ``cv2.projectPoints``
of a ray, :func:`undistort_points` is ``cv2.undistortPoints`` iterated to
:data:`UNDISTORT_CRITERIA` — OpenCV's default of five steps leaves up to 0.004 px at
the corners of a real 640×480 lens (k1 −0.27), a tenth of the tracker's noise.

The tilt is an exact pinhole tilt about one image axis (:func:`tilt_points`). It is
what a camera not square to the mechanism's plane adds; a board or point plane
calibration (:mod:`.plane`) absorbs it in its homography, the loop fits it.

The renders in :mod:`cranktrack.synthetic` keep their own camera on purpose: their
truth must not share code with what measures it.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

#: Iterate the undistortion until a step moves less than 1e-14 (in focal lengths).
UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)


def _finite_rows(px: NDArray) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    pts = np.asarray(px, np.float64).reshape(-1, 2)
    return pts, np.isfinite(pts).all(axis=1)


def distort_points(ideal_px: NDArray, camera_matrix: NDArray, distortion: NDArray
                   ) -> NDArray[np.float64]:
    """Ideal pinhole points (px, (n, 2)) to where the lens puts them (px), NaN kept.

    ``camera_matrix`` is 3×3 (px); ``distortion`` OpenCV's (k1, k2, p1, p2[, k3]).
    """
    pts, ok = _finite_rows(ideal_px)
    out = np.full_like(pts, np.nan)
    if ok.any():
        K = np.asarray(camera_matrix, np.float64)
        ray = (pts[ok] - K[:2, 2]) / np.array([K[0, 0], K[1, 1]])
        img, _ = cv2.projectPoints(np.hstack([ray, np.ones((len(ray), 1))]), np.zeros(3),
                                   np.zeros(3), K, np.asarray(distortion, np.float64))
        out[ok] = img.reshape(-1, 2)
    return out


def undistort_points(px: NDArray, camera_matrix: NDArray, distortion: NDArray
                     ) -> NDArray[np.float64]:
    """Image points (px, (n, 2)) to ideal pinhole points (px, same camera matrix), NaN
    kept: the inverse of :func:`distort_points`."""
    pts, ok = _finite_rows(px)
    out = np.full_like(pts, np.nan)
    if ok.any():
        K = np.asarray(camera_matrix, np.float64)
        und = cv2.undistortPoints(pts[ok].reshape(-1, 1, 2), K,
                                  np.asarray(distortion, np.float64), P=K,
                                  criteria=UNDISTORT_CRITERIA)
        out[ok] = und.reshape(-1, 2)
    return out


def tilt_points(px: NDArray, tilt_rad: float, focal_px: float, centre_px: NDArray,
                about: str = "x", forward: bool = True) -> NDArray[np.float64]:
    """Where a pinhole turned by ``tilt_rad`` about its ``about`` axis (``"x"``, the
    image's horizontal axis, or ``"y"``) sees the points an untilted one sees at ``px``
    ((n, 2), px); ``forward=False`` goes back.

    ``focal_px`` is the focal length and ``centre_px`` the image centre (px); the
    camera is re-aimed so the point at the centre stays there.
    """
    q = (np.asarray(px, np.float64) - centre_px) / focal_px
    if about == "y":
        q = q[:, ::-1]
    c, s = np.cos(tilt_rad), np.sin(tilt_rad)
    x, y = q[:, 0], q[:, 1]
    if forward:
        y = y - np.tan(tilt_rad)
        d = c - y * s
        q = np.stack([x / d, (y * c + s) / d], axis=1)
    else:
        qy = (y * c - s) / (c + y * s)
        q = np.stack([x * (c - qy * s), qy + np.tan(tilt_rad)], axis=1)
    if about == "y":
        q = q[:, ::-1]
    return centre_px + focal_px * q
