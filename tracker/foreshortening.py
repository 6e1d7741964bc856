"""How a round mark on the filmed plane looks in the image: an ellipse, whose shape the
plane's calibration knows.

A camera not square to the rig sees a printed disc as an ellipse; so does a lens that
bends lines, away from the frame's middle. A circle fitted to it misfits its rim all
round, which widens the fitted edge: on the second renderer's SMA bed seen 20-35° from
square (``bench/tilted_bed.py``) the edge came out 1.7-2.0 px against 1.2-1.5, so the
wire's end was taken for out of focus and the wire's dark line went unfound.

Where the image-to-plane map is ``J`` (mm per px, 2×2) at a point, a disc of radius
``R`` mm is the set ``|J·d| = R``: ``dᵀ·JᵀJ·d = R²``. :class:`Foreshortening` keeps
``g = JᵀJ / |det J|`` (determinant 1: the ellipse's area stays π·r² in px², which the
tracker's checks of a whole marker compare) on a grid over the frame, and
:func:`.disc.fit_disc` takes it as its metric.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Grid spacing (px) the metric is sampled at. It changes over a frame only as the
#: perspective and the lens do (a few % across a 960 px frame 35° from square), so a
#: bilinear look-up between nodes this far apart is within 1e-4 of it.
GRID_PX = 32.0
#: Half the step (px) of the central differences that give ``J``.
STEP_PX = 0.5


@dataclass(frozen=True)
class Foreshortening:
    """The disc model's metric ``(g11, g12, g22)`` (:func:`.disc.stretch_of`) sampled
    every ``step_px`` over a frame, node (0, 0) at image px ``origin``."""

    metric: NDArray[np.float64]  # (rows, cols, 3)
    step_px: float = GRID_PX
    origin: tuple[float, float] = (0.0, 0.0)

    def at(self, x: float, y: float) -> tuple[float, float, float]:
        """The metric at image px (``x``, ``y``), bilinear between nodes, the nearest
        edge's beyond them."""
        rows, cols = self.metric.shape[:2]
        u = min(max((x - self.origin[0]) / self.step_px, 0.0), cols - 1.0)
        v = min(max((y - self.origin[1]) / self.step_px, 0.0), rows - 1.0)
        j, i = min(int(u), cols - 2) if cols > 1 else 0, min(int(v), rows - 2) if rows > 1 else 0
        fu, fv = u - j, v - i
        j1, i1 = min(j + 1, cols - 1), min(i + 1, rows - 1)
        g = ((1 - fu) * (1 - fv) * self.metric[i, j] + fu * (1 - fv) * self.metric[i, j1]
             + (1 - fu) * fv * self.metric[i1, j] + fu * fv * self.metric[i1, j1])
        return float(g[0]), float(g[1]), float(g[2])

    def shifted(self, dx: float, dy: float) -> Foreshortening:
        """The same metric for an image cut ``dx``, ``dy`` px in (a region of interest):
        its pixel (0, 0) is this one's (``dx``, ``dy``)."""
        return Foreshortening(self.metric, self.step_px,
                              (self.origin[0] - dx, self.origin[1] - dy))

    @property
    def most_stretched(self) -> float:
        """The largest ratio of an ellipse's axes over the grid (1 for a square-on
        camera with a lens that bends nothing)."""
        g11, g12, g22 = np.moveaxis(self.metric, -1, 0)
        spread = np.sqrt(0.25 * (g11 - g22) ** 2 + g12 ** 2)
        half = 0.5 * (g11 + g22)
        return float(np.max(np.sqrt((half + spread) / (half - spread))))


def foreshortening_of(to_plane: Callable[[NDArray, NDArray], tuple[NDArray, NDArray]],
                      size: tuple[int, int], step_px: float = GRID_PX) -> Foreshortening:
    """The :class:`Foreshortening` of the image-to-plane map ``to_plane`` (image px
    arrays to plane mm arrays, as :meth:`.calibration.plane.PlaneCalibration.to_plane`)
    over a frame of ``size`` (width, height) px: ``J`` by central differences of
    :data:`STEP_PX` at each node.

    Raises
    ------
    ValueError
        The map folds or flattens somewhere on the frame (``det J`` zero, not finite,
        or not of one sign at every node): no disc on that plane could be seen there.
    """
    xs = np.arange(0.0, size[0] - 1 + step_px, step_px)
    ys = np.arange(0.0, size[1] - 1 + step_px, step_px)
    x, y = np.meshgrid(np.minimum(xs, size[0] - 1.0), np.minimum(ys, size[1] - 1.0))
    h = STEP_PX

    def at(dx: float, dy: float) -> NDArray:
        u, v = to_plane((x + dx).ravel(), (y + dy).ravel())
        return np.stack([np.asarray(u, float), np.asarray(v, float)], -1).reshape(*x.shape, 2)

    ju = (at(h, 0.0) - at(-h, 0.0)) / (2 * h)  # ∂(mm)/∂x: J's first column
    jv = (at(0.0, h) - at(0.0, -h)) / (2 * h)
    det = ju[..., 0] * jv[..., 1] - ju[..., 1] * jv[..., 0]
    size_of = np.abs(det)
    # A fold between nodes shows as det's sign turning from one node to the next.
    if not (np.all(np.isfinite(det)) and (np.all(det > 0) or np.all(det < 0))):
        raise ValueError("the plane's calibration folds or flattens part of the frame")
    g11 = np.sum(ju * ju, -1) / size_of
    g12 = np.sum(ju * jv, -1) / size_of
    g22 = np.sum(jv * jv, -1) / size_of
    return Foreshortening(np.stack([g11, g12, g22], -1), step_px)
