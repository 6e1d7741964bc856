"""Where the mechanism plane lands in the image.

To start with the camera looks straight down on the mechanism plane (an
ideal pinhole, no distortion), so the mapping is a similarity: scale,
rotation and placement. :meth:`Camera.project` is the one seam through which
every plane point reaches the image, so lens distortion and tilt (later
issues) change this module only.

Plane coordinates are mm with y 90° counter-clockwise from x (y up); the image
follows OpenCV (y down), so the mapping flips y.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class Camera:
    """A straight-down pinhole camera over the mechanism plane.

    Parameters
    ----------
    width, height : int
        Image size, px.
    px_per_mm : float
        Image scale in the plane, px/mm.
    origin_px : tuple of float
        Image position of the plane origin (the pivot A), px.
    rotation_deg : float
        Counter-clockwise rotation of the plane's x axis in the image, degrees.
    """

    width: int
    height: int
    px_per_mm: float
    origin_px: tuple[float, float]
    rotation_deg: float = 0.0

    @classmethod
    def framing(
        cls,
        width: int,
        height: int,
        lo_mm: ArrayLike,
        hi_mm: ArrayLike,
        fill: float = 0.8,
        rotation_deg: float = 0.0,
    ) -> Camera:
        """A camera that centres the plane box ``lo_mm``–``hi_mm`` in the image.

        The box (mm, x and y) is scaled to fill ``fill`` of the tighter image
        dimension; used to frame a scenario's whole range of motion.
        """
        lo, hi = np.asarray(lo_mm, float), np.asarray(hi_mm, float)
        span = np.maximum(hi - lo, 1e-9)
        scale = fill * min(width / span[0], height / span[1])
        centre = (lo + hi) / 2
        # Image centre is at ((w-1)/2, (h-1)/2) in OpenCV's pixel-centre convention.
        probe = cls(width, height, scale, (0.0, 0.0), rotation_deg)
        c_img = probe.project(centre)
        origin = ((width - 1) / 2 - c_img[0], (height - 1) / 2 - c_img[1])
        return cls(width, height, float(scale), (float(origin[0]), float(origin[1])),
                   rotation_deg)

    def project(self, xy_mm: ArrayLike) -> NDArray[np.float64]:
        """Plane points (mm, shape (..., 2)) to image points (px, shape (..., 2))."""
        xy = np.asarray(xy_mm, dtype=float)
        r = np.radians(self.rotation_deg)
        c, s = np.cos(r), np.sin(r)
        x, y = xy[..., 0], xy[..., 1]
        u = self.origin_px[0] + self.px_per_mm * (c * x - s * y)
        v = self.origin_px[1] - self.px_per_mm * (s * x + c * y)
        return np.stack([u, v], axis=-1)

    def ideal_project(self, xy_mm: ArrayLike) -> NDArray[np.float64]:
        """No lens distortion: the same as :meth:`project`."""
        return self.project(xy_mm)

    def local_scale(self, xy_mm: ArrayLike) -> NDArray[np.float64]:
        """px per mm at plane points (uniform for this camera)."""
        return np.full(np.shape(xy_mm)[:-1], self.px_per_mm)

    def ideal_canvas(self) -> tuple[tuple[int, int], tuple[float, float]]:
        """The ideal image is the image itself."""
        return (self.width, self.height), (0.0, 0.0)

    def warp(self, ideal: NDArray[np.float32], offset: tuple[float, float]) -> NDArray:
        """No lens: nothing to bend."""
        return ideal

    def canvas_to_plane(self, offset: tuple[float, float]) -> None:
        """None: straight overhead a disc is a circle, so shapes are drawn in px."""
        return None

    def to_dict(self) -> dict:
        """Plain parameters for ``scene.json``."""
        d = asdict(self)
        d["model"] = "overhead-pinhole"
        return d


@dataclass(frozen=True)
class PinholeCamera:
    """A pinhole camera over the mechanism plane, possibly tilted, with radial distortion.

    The world is the mechanism plane z = 0 (mm, y up as seen from above). The
    camera's optical axis passes through ``target_mm`` on the plane from
    ``distance_mm`` away, tilted by ``tilt_deg`` about the image's x axis.
    ``k1``, ``k2`` are OpenCV's radial distortion coefficients (k1 < 0:
    barrel). Rendering draws in the ideal image (:meth:`ideal_project`,
    :meth:`local_scale`) and then bends it through the lens (:meth:`warp`);
    everything on the plane (discs, bars, the wire) is drawn through
    :meth:`canvas_to_plane`, so a tilted camera sees a disc as the ellipse it is.
    """

    width: int
    height: int
    focal_px: float
    target_mm: tuple[float, float]
    distance_mm: float
    tilt_deg: float = 0.0
    k1: float = 0.0
    k2: float = 0.0

    @classmethod
    def framing(cls, width: int, height: int, lo_mm: ArrayLike, hi_mm: ArrayLike,
                fill: float = 0.8, hfov_deg: float = 60.0, tilt_deg: float = 0.0,
                k1: float = 0.0, k2: float = 0.0) -> PinholeCamera:
        """A camera of horizontal field ``hfov_deg`` whose distance frames the box like
        :meth:`Camera.framing` would (before tilt and distortion)."""
        lo, hi = np.asarray(lo_mm, float), np.asarray(hi_mm, float)
        span = np.maximum(hi - lo, 1e-9)
        f = (width / 2) / np.tan(np.radians(hfov_deg) / 2)
        scale = fill * min(width / span[0], height / span[1])  # px per mm at the target
        centre = (lo + hi) / 2
        return cls(width, height, float(f), (float(centre[0]), float(centre[1])),
                   float(f / scale), tilt_deg, k1, k2)

    @property
    def camera_matrix(self) -> NDArray[np.float64]:
        return np.array([[self.focal_px, 0, (self.width - 1) / 2],
                         [0, self.focal_px, (self.height - 1) / 2], [0, 0, 1.0]])

    @property
    def distortion(self) -> NDArray[np.float64]:
        return np.array([self.k1, self.k2, 0.0, 0.0, 0.0])

    def pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World → camera rotation matrix and translation (mm)."""
        down = np.diag([1.0, -1.0, -1.0])  # looking down: image x = world x, image y = −y
        a = np.radians(self.tilt_deg)
        rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
        R = rx @ down
        axis = R.T @ np.array([0.0, 0.0, 1.0])  # optical axis in the world
        centre = np.array([*self.target_mm, 0.0]) - self.distance_mm * axis
        return R, -R @ centre

    def _homography(self) -> NDArray[np.float64]:
        R, t = self.pose()
        return self.camera_matrix @ np.column_stack([R[:, 0], R[:, 1], t])

    def ideal_project(self, xy_mm: ArrayLike) -> NDArray[np.float64]:
        """Plane points (mm) to the undistorted image (px)."""
        xy = np.asarray(xy_mm, float)
        h = np.concatenate([xy, np.ones((*xy.shape[:-1], 1))], axis=-1) @ self._homography().T
        return h[..., :2] / h[..., 2:3]

    def canvas_to_plane(self, offset: tuple[float, float]) -> NDArray[np.float64]:
        """Homography from the ideal canvas (drawn with ``offset``, px, see
        :meth:`ideal_canvas`) back to the plane (mm)."""
        shift = np.array([[1.0, 0.0, offset[0]], [0.0, 1.0, offset[1]], [0.0, 0.0, 1.0]])
        return np.linalg.inv(shift @ self._homography())

    def project(self, xy_mm: ArrayLike) -> NDArray[np.float64]:
        """Plane points (mm) to the image as the lens bends it (px)."""
        xy = np.asarray(xy_mm, float)
        flat = xy.reshape(-1, 2)
        pts = np.hstack([flat, np.zeros((len(flat), 1))])
        R, t = self.pose()
        img, _ = cv2.projectPoints(pts, cv2.Rodrigues(R)[0], t, self.camera_matrix,
                                   self.distortion)
        return img.reshape(xy.shape)

    def local_scale(self, xy_mm: ArrayLike) -> NDArray[np.float64]:
        """Ideal-image px per mm at plane points (RMS over directions)."""
        xy = np.asarray(xy_mm, float)
        d = 0.01
        ex, ey = np.array([d, 0.0]), np.array([0.0, d])
        jx = (self.ideal_project(xy + ex) - self.ideal_project(xy - ex)) / (2 * d)
        jy = (self.ideal_project(xy + ey) - self.ideal_project(xy - ey)) / (2 * d)
        return np.sqrt(((jx**2).sum(-1) + (jy**2).sum(-1)) / 2)

    def ideal_canvas(self) -> tuple[tuple[int, int], tuple[float, float]]:
        """Size and offset (px) of an ideal image that covers the whole lens view."""
        src = self._lens_map_raw()
        lo = np.floor(src.reshape(-1, 2).min(axis=0)) - 2
        hi = np.ceil(src.reshape(-1, 2).max(axis=0)) + 2
        return (int(hi[0] - lo[0]) + 1, int(hi[1] - lo[1]) + 1), (float(-lo[0]), float(-lo[1]))

    def _lens_map_raw(self) -> NDArray[np.float32]:
        key = (self.width, self.height, self.focal_px, self.k1, self.k2)
        if key not in _LENS_MAPS:
            ys, xs = np.mgrid[0 : self.height, 0 : self.width].astype(np.float64)
            pts = np.stack([xs.ravel(), ys.ravel()], 1).reshape(-1, 1, 2)
            und = cv2.undistortPoints(pts, self.camera_matrix, self.distortion,
                                      P=self.camera_matrix)
            _LENS_MAPS[key] = und.reshape(self.height, self.width, 2).astype(np.float32)
        return _LENS_MAPS[key]

    def warp(self, ideal: NDArray[np.float32], offset: tuple[float, float]) -> NDArray:
        """Bend an ideal image (drawn with ``offset``, see :meth:`ideal_canvas`)
        through the lens into the camera's image."""
        src = self._lens_map_raw()
        mx = src[..., 0] + np.float32(offset[0])
        my = src[..., 1] + np.float32(offset[1])
        return cv2.remap(ideal, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["model"] = "pinhole"
        return d


_LENS_MAPS: dict[tuple, NDArray[np.float32]] = {}
