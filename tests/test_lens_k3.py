"""The fifth distortion coefficient is fitted only where a lens calls for it.

The board's corners are put through a lens written out here (a pinhole whose lens
moves a ray at normalised radius ρ to ρ·(1 + k1·ρ² + k2·ρ⁴ + k3·ρ⁶)), with 0.05 px
of noise, as a corner finder leaves: OpenCV's calibration is fed the corners, not
pictures, so what is checked is the choice of model alone.
"""

import math

import cv2
import numpy as np
import pytest

from cranktrack.calibration.camera import K3_BIC, Board, calibrate_corners

SIZE = (1280, 720)
F_PX, CENTRE = 800.0, (641.0, 357.0)
BOARD = Board("chessboard", (9, 6), 25.0)


def _rotation(ax: float, ay: float, az: float) -> np.ndarray:
    a, b, c = map(math.radians, (ax, ay, az))
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
    return rz @ ry @ rx


def _bend(xn: np.ndarray, yn: np.ndarray, k: tuple[float, float, float]):
    r2 = xn * xn + yn * yn
    f = 1 + k[0] * r2 + k[1] * r2 * r2 + k[2] * r2 ** 3
    return F_PX * xn * f + CENTRE[0], F_PX * yn * f + CENTRE[1]


def _views(k: tuple[float, float, float], seed: int = 3, n: int = 15):
    """Corners of ``n`` board poses spread over the frame, through the lens ``k``."""
    rng = np.random.default_rng(seed)
    board = BOARD.object_points().astype(np.float64)
    board -= board.mean(axis=0)
    obj, img = [], []
    while len(obj) < n:
        r = _rotation(*rng.uniform(-35, 35, 2), rng.uniform(-25, 25))
        t = np.array([rng.uniform(-200, 200), rng.uniform(-110, 110), rng.uniform(420, 620)])
        cam = board @ r.T + t
        u, v = _bend(cam[:, 0] / cam[:, 2], cam[:, 1] / cam[:, 2], k)
        if u.min() < 5 or v.min() < 5 or u.max() > SIZE[0] - 5 or v.max() > SIZE[1] - 5:
            continue
        seen = np.column_stack([u, v]) + rng.normal(0, 0.05, (len(u), 2))
        obj.append(BOARD.object_points().reshape(-1, 1, 3))
        img.append(seen.astype(np.float32).reshape(-1, 1, 2))
    return obj, img, [f"view{i}" for i in range(n)]


def _bend_left(cal, k: tuple[float, float, float], reach_px: float) -> float:
    """The largest error (px) of ``cal``'s ideal points against the lens's on a grid over
    the frame, within ``reach_px`` of the centre as seen, after the best homography
    between the two: what a plane's homography cannot take up."""
    g = np.stack(np.meshgrid(np.linspace(-1, 1, 25), np.linspace(-1, 1, 25)), -1)
    ideal = g.reshape(-1, 2) * np.array([SIZE[0] / 2, SIZE[1] / 2]) + CENTRE
    seen = np.column_stack(_bend((ideal[:, 0] - CENTRE[0]) / F_PX,
                                 (ideal[:, 1] - CENTRE[1]) / F_PX, k))
    keep = np.hypot(*(seen - CENTRE).T) <= reach_px
    ours = cal.undistort_points(seen[keep])
    h, _ = cv2.findHomography(ours, ideal[keep], 0)
    mapped = cv2.perspectiveTransform(ours.reshape(-1, 1, 2), h).reshape(-1, 2)
    return float(np.max(np.hypot(*(mapped - ideal[keep]).T)))


def _reach(img: list[np.ndarray]) -> float:
    """How far from the centre the views' corners reach, px."""
    return float(np.max(np.hypot(*(np.concatenate(img).reshape(-1, 2) - CENTRE).T)))


@pytest.mark.parametrize("k", [(0.0, 0.0, 0.0), (-0.25, 0.05, 0.0)])
def test_a_lens_that_does_not_need_k3_has_it_held_at_zero(k):
    obj, img, names = _views(k)
    cal = calibrate_corners(obj, img, SIZE, names, BOARD)
    assert "fix_k3" in cal.flags and cal.k3_delta_bic < K3_BIC
    assert cal.distortion[4] == 0.0
    assert cal.fx == pytest.approx(F_PX, rel=0.005)
    # Within the views 0.02-0.13 px; over the whole frame, beyond them, 0.13-0.70.
    assert _bend_left(cal, k, _reach(img)) < 0.2
    assert _bend_left(cal, k, np.hypot(*SIZE)) < 1.0


def test_a_lens_that_bends_the_corners_with_k3_has_it_fitted():
    k = (-0.25, 0.05, 0.12)
    obj, img, names = _views(k)
    cal = calibrate_corners(obj, img, SIZE, names, BOARD)
    assert "fix_k3" not in cal.flags and cal.k3_delta_bic > K3_BIC
    assert cal.distortion[4] == pytest.approx(k[2], abs=0.03)
    reach = _reach(img)
    fitted = _bend_left(cal, k, reach)
    assert fitted < 0.1
    held = calibrate_corners(obj, img, SIZE, names, BOARD, k3="fixed")
    assert held.distortion[4] == 0.0 and _bend_left(held, k, reach) > 2 * fitted


def test_an_unknown_k3_choice_is_one_clear_error():
    from cranktrack.errors import CranktrackError
    obj, img, names = _views((0.0, 0.0, 0.0), n=3)
    with pytest.raises(CranktrackError, match="k3 must be one of auto, free, fixed"):
        calibrate_corners(obj, img, SIZE, names, BOARD, k3="loose")
