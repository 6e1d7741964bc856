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

    def to_dict(self) -> dict:
        """Plain parameters for ``scene.json``."""
        d = asdict(self)
        d["model"] = "overhead-pinhole"
        return d
