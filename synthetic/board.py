"""Photos of a chessboard taken with a synthetic camera, for calibrating it.

The board is rendered by inverse mapping: every ideal-image sub-sample is
traced back onto the board's plane through the board's homography and
coloured by the square it lands in, then the ideal image is bent through the
camera's lens like every other render. Two kinds of photo:

- :func:`intrinsics_views`: the board held in front of the camera in many
  poses (tilted, turned, off-centre), for ``calibrate camera``;
- :func:`plane_view`: the board lying in the mechanism's plane, seen by the
  camera in its working pose, for ``calibrate plane``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from ..files import ensure_dir
from .camera import PinholeCamera


@dataclass(frozen=True)
class BoardSpec:
    """A printed chessboard: ``corners`` inner corners (cols, rows), ``square_mm``,
    and a white margin of ``margin_squares`` squares around the pattern."""

    corners: tuple[int, int] = (9, 6)
    square_mm: float = 12.0
    margin_squares: float = 1.0

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Board outline (lo, hi) in board mm, the first inner corner at (0, 0)."""
        s, m = self.square_mm, self.margin_squares
        lo = np.array([-(1 + m) * s, -(1 + m) * s])
        hi = np.array([(self.corners[0] + m) * s, (self.corners[1] + m) * s])
        return lo, hi

    def colour(self, x: NDArray, y: NDArray) -> NDArray[np.float32]:
        """Grey level (0–255) at board points (mm); NaN off the board."""
        s = self.square_mm
        ix, iy = np.floor(x / s), np.floor(y / s)
        inside = (ix >= -1) & (ix <= self.corners[0] - 1) & (iy >= -1) & (iy <= self.corners[1] - 1)
        lo, hi = self.extent_mm()
        on_board = (x >= lo[0]) & (x <= hi[0]) & (y >= lo[1]) & (y <= hi[1])
        dark = inside & (((ix + iy) % 2) == 0)
        out = np.where(dark, 25.0, 235.0).astype(np.float32)
        return np.where(on_board, out, np.nan).astype(np.float32)


def _render(camera: PinholeCamera, H_board_to_ideal: NDArray, board: BoardSpec,
            background: float = 120.0, supersample: int = 3) -> NDArray[np.uint8]:
    """An RGB photo of the board (grey) through ``camera``'s lens."""
    (cw, ch), (ox, oy) = camera.ideal_canvas()
    S = supersample
    offs = (np.arange(S) + 0.5) / S - 0.5
    Hinv = np.linalg.inv(H_board_to_ideal)
    acc = np.zeros((ch, cw), np.float32)
    xs = np.arange(cw, dtype=np.float64) - ox
    ys = np.arange(ch, dtype=np.float64) - oy
    for dy in offs:
        for dx in offs:
            X, Y = np.meshgrid(xs + dx, ys + dy)
            w = Hinv[2, 0] * X + Hinv[2, 1] * Y + Hinv[2, 2]
            bx = (Hinv[0, 0] * X + Hinv[0, 1] * Y + Hinv[0, 2]) / w
            by = (Hinv[1, 0] * X + Hinv[1, 1] * Y + Hinv[1, 2]) / w
            g = board.colour(bx, by)
            acc += np.where(np.isfinite(g) & (w > 0), g, background)
    ideal = np.repeat((acc / (S * S))[..., None], 3, axis=2)
    img = camera.warp(ideal, (ox, oy))
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def _pose_homography(camera: PinholeCamera, R: NDArray, t: NDArray) -> NDArray:
    return camera.camera_matrix @ np.column_stack([R[:, 0], R[:, 1], t])


def _rot(ax: float, ay: float, az: float) -> NDArray[np.float64]:
    return cv2.Rodrigues(np.array([ax, ay, az], float))[0] @ np.eye(3)


def intrinsics_views(camera: PinholeCamera, board: BoardSpec, n: int = 15, seed: int = 0
                     ) -> list[NDArray[np.uint8]]:
    """``n`` photos of the board held in front of the camera in varied poses.

    The board fills about half the image width, turned up to ±35° out of
    plane and anywhere in-plane, and placed off-centre so its corners sample
    the whole lens (where distortion is strongest).
    """
    rng = np.random.default_rng(seed)
    lo, hi = board.extent_mm()
    centre = (lo + hi) / 2
    width_mm = hi[0] - lo[0]
    distance = camera.focal_px * width_mm / (0.55 * camera.width)
    views = []
    for _ in range(n):
        R = _rot(*np.radians(rng.uniform([-35, -35, -180], [35, 35, 180])))
        shift = rng.uniform(-0.22, 0.22, 2) * np.array([camera.width, camera.height])
        target = np.array([shift[0], shift[1], camera.focal_px]) / camera.focal_px * distance
        # Board centre placed at the target point of the camera frame.
        t = target - R @ np.array([centre[0], centre[1], 0.0])
        views.append(_render(camera, _pose_homography(camera, R, t), board))
    return views


def plane_view(camera: PinholeCamera, board: BoardSpec, origin_mm: tuple[float, float],
               angle_deg: float = 0.0) -> NDArray[np.uint8]:
    """The board lying in the mechanism's plane, its first inner corner at
    ``origin_mm`` and turned by ``angle_deg``, seen by the working camera."""
    R_cam, t_cam = camera.pose()
    a = np.radians(angle_deg)
    # Board → world (z = 0): rotation in the plane and translation.
    R_bw = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1.0]])
    t_bw = np.array([origin_mm[0], origin_mm[1], 0.0])
    R = R_cam @ R_bw
    t = R_cam @ t_bw + t_cam
    return _render(camera, _pose_homography(camera, R, t), board)


def write_views(images: list[NDArray[np.uint8]], folder: str | os.PathLike, stem: str
                ) -> list[Path]:
    """Save photos as PNG (lossless) and return their paths."""
    out = ensure_dir(folder)
    paths = []
    for i, img in enumerate(images):
        p = out / f"{stem}_{i:02d}.png"
        cv2.imwrite(str(p), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
        paths.append(p)
    return paths
