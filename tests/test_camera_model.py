"""The one camera model (calibration/camera_model.py), against formulas written here.

The lens is checked against the Brown–Conrady polynomial as OpenCV documents it, written
out in this file; the tilt against ``cv2.projectPoints`` of a plane seen by a camera moved
and turned in 3-D. Neither shares code with the model.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cranktrack.calibration.camera import CameraCalibration
from cranktrack.calibration.camera_model import distort_points, tilt_points, undistort_points
from cranktrack.loop.camera_view import _camera_maps

# OpenCV's published intrinsics for its left01–14 chessboard photos (samples/data), as
# copied into ../shared/data/calibration/chessboard_9x6/PROVENANCE.md.
K = np.array([[536.07, 0.0, 342.37], [0.0, 536.02, 235.54], [0.0, 0.0, 1.0]])
D = np.array([-0.26637, -0.038589, 0.0017832, -0.00028122, 0.23839])


def _brown_conrady(px: np.ndarray) -> np.ndarray:
    x, y = ((px - K[:2, 2]) / [K[0, 0], K[1, 1]]).T
    k1, k2, p1, p2, k3 = D
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd * K[0, 0] + K[0, 2], yd * K[1, 1] + K[1, 2]], axis=1)


def _grid() -> np.ndarray:
    return np.mgrid[0:641:32, 0:481:32].reshape(2, -1).T.astype(float)


def test_the_lens_bends_points_as_opencv_documents_and_undoes_it_to_a_nanopixel():
    ideal = _grid()
    seen = distort_points(ideal, K, D)
    assert np.max(np.abs(seen - _brown_conrady(ideal))) < 1e-9
    back = undistort_points(seen, K, D)
    assert np.max(np.abs(back - ideal)) < 1e-9
    # OpenCV's default five steps are 1000× further off at the corners.
    default = cv2.undistortPoints(seen.reshape(-1, 1, 2), K, D, P=K).reshape(-1, 2)
    assert np.max(np.abs(default - ideal)) > 1e-3


def test_a_calibration_and_its_plane_keep_nan_rows_and_round_trip():
    cal = CameraCalibration(K, D, (640, 480), 0.39, {})
    pts = np.array([[10.0, 20.0], [np.nan, 5.0], [600.0, 470.0]])
    und = cal.undistort_points(pts)
    assert np.isnan(und[1]).all() and np.isfinite(und[[0, 2]]).all()
    assert np.allclose(cal.distort_points(und)[[0, 2]], pts[[0, 2]], atol=1e-9)


@pytest.mark.parametrize("pct", [-3.0, 2.0])
def test_the_loops_lens_moves_the_middle_of_the_side_edge_by_its_percentage(pct):
    size = (640, 480)
    seen, ideal = _camera_maps({"lens_edge_pct": pct}, size)
    c = (np.array(size) - 1) / 2
    edge = np.array([[c[0] + 320.0, c[1]], [c[0], c[1] - 320.0]])
    assert np.allclose(seen(edge) - c, (edge - c) * (1 + pct / 100), atol=1e-9)
    assert np.allclose(ideal(seen(edge)), edge, atol=1e-9)
    assert np.allclose(seen(c[None, :]), c, atol=1e-12)


@pytest.mark.parametrize("tau_deg", [-12.0, 7.0])
def test_a_tilt_is_a_camera_moved_and_turned_to_look_at_the_same_centre(tau_deg):
    """An untilted pinhole at height Z over the plane; the tilted one moved by Z·tan τ
    and turned by τ about its x axis, seen through ``cv2.projectPoints``."""
    tau, f, Z = np.radians(tau_deg), 600.0, 500.0
    centre = np.array([319.5, 239.5])
    Kf = np.array([[f, 0, centre[0]], [0, f, centre[1]], [0, 0, 1.0]])
    plane = np.c_[np.mgrid[-150:151:50, -100:101:50].reshape(2, -1).T, np.zeros(35)]

    def project(R: np.ndarray, C: np.ndarray) -> np.ndarray:
        img, _ = cv2.projectPoints(plane, cv2.Rodrigues(R)[0], -R @ C, Kf, np.zeros(5))
        return img.reshape(-1, 2)

    c, s = np.cos(tau), np.sin(tau)
    straight = project(np.eye(3), np.array([0.0, 0.0, -Z]))
    turned = project(np.array([[1, 0, 0], [0, c, s], [0, -s, c]]),
                     np.array([0.0, Z * np.tan(tau), -Z]))
    model = tilt_points(straight, tau, f, centre, "x", forward=True)
    assert np.max(np.abs(model - turned)) < 1e-9
    assert np.allclose(tilt_points(model, tau, f, centre, "x", forward=False), straight,
                       atol=1e-9)
    # About the other axis it is the same turn with the image's axes swapped.
    swapped = tilt_points(straight[:, ::-1], tau, f, centre[::-1], "y", forward=True)
    assert np.allclose(swapped[:, ::-1], model, atol=1e-9)
