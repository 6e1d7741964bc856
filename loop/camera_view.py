"""How camera effects bend the angle a run measures: lens, tilts and a rolling shutter.

A :class:`CameraView` holds the run's own image geometry; :func:`camera_theta`
says what angle the run would measure for a true angle through the camera effects
of :data:`.candidates.CAMERA_CANDIDATES`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..calibration.camera_model import distort_points, tilt_points, undistort_points
from .candidates import CAMERA_PARAMETERS, DEFAULT_HFOV_DEG, READOUT


@dataclass(frozen=True)
class CameraView:
    """Where the mechanism sits in the image and how the run maps pixels to the plane.

    What a camera candidate needs to say how it would bend the measured angle:
    ``to_plane`` and ``to_image`` map (n, 2) px ↔ mm as the run's calibration does;
    ``size`` is the image (width, height), px; ``A_px`` and ``C_px`` the
    measured pivot and slider end (medians), px; ``side`` +1 or −1, the side of
    A→C the crank tip is on in the plane.
    """

    to_plane: Callable[[NDArray], NDArray]
    to_image: Callable[[NDArray], NDArray]
    size: tuple[int, int]
    A_px: NDArray[np.float64]
    C_px: NDArray[np.float64]
    side: float


def _camera_maps(values: dict[str, float], size: tuple[int, int]
                 ) -> tuple[Callable[[NDArray], NDArray], Callable[[NDArray], NDArray]]:
    """(seen, ideal): where the camera effects put an ideal image point, and back, px.

    The camera is :mod:`cranktrack.calibration.camera_model`'s: exact pinhole tilts
    (about the image's horizontal axis for ``tilt_vertical_deg``, its vertical axis
    for ``tilt_horizontal_deg``) for a lens of ``hfov_deg`` (:data:`DEFAULT_HFOV_DEG`
    unless known), then OpenCV's radial lens with k1 = ``lens_edge_pct``/100 over
    coordinates centred on the image and divided by its half-width — so a point at
    the middle of the left or right edge moves outward by ``lens_edge_pct`` %.
    """
    c = (np.asarray(size, float) - 1.0) / 2.0
    half = size[0] / 2.0
    k = values.get("lens_edge_pct", 0.0) / 100.0
    lens = np.array([[half, 0.0, c[0]], [0.0, half, c[1]], [0.0, 0.0, 1.0]])
    distortion = np.array([k, 0.0, 0.0, 0.0, 0.0])
    tilts = []
    for axis, about in (("vertical", "x"), ("horizontal", "y")):
        # Signed as ``cranktrack synth --effect tilt_deg`` turns its camera.
        tau = -np.radians(values.get(f"tilt_{axis}_deg", 0.0))
        if tau:
            fov = np.radians(values.get("hfov_deg", DEFAULT_HFOV_DEG))
            tilts.append((tau, half / np.tan(fov / 2.0), about))

    def tilt(px: NDArray, forward: bool) -> NDArray:
        for tau, f, about in tilts if forward else tilts[::-1]:
            px = tilt_points(px, tau, f, c, about, forward)
        return px

    def seen(px: NDArray) -> NDArray:
        px = tilt(px, True)
        return distort_points(px, lens, distortion) if k else px

    def ideal(px: NDArray) -> NDArray:
        return tilt(undistort_points(px, lens, distortion) if k else px, False)

    return seen, ideal


def _crank_tip(theta: NDArray, values: dict[str, float], view: CameraView
               ) -> tuple[NDArray, NDArray]:
    """B in the plane at true angles ``theta`` (rad), A and C where the measured ones
    would be without the camera effects in ``values``, |AB|/|AC| = L2/L1; and B's
    image point through those effects, px."""
    seen, ideal = _camera_maps(values, view.size)
    A, C = view.to_plane(ideal(np.vstack([view.A_px, view.C_px])))
    span = C - A
    e = span / np.hypot(*span)
    n = view.side * np.array([-e[1], e[0]])
    crank = values["L2_mm"] / values["L1_mm"] * np.hypot(*span)
    B = A + crank * (np.cos(theta)[:, None] * e + np.sin(theta)[:, None] * n)
    return B, seen(view.to_image(B))


def camera_theta(theta: NDArray, values: dict[str, float], view: CameraView) -> NDArray:
    """The angle the run would measure for true angles ``theta`` (rad) through the
    camera effects in ``values`` (:data:`CAMERA_CANDIDATES`).

    B is placed by :func:`_crank_tip`, imaged through the effects and mapped
    back to the plane by the run's own calibration, as are the measured A and C.
    """
    Bm = view.to_plane(_crank_tip(theta, values, view)[1])
    Am, Cm = view.to_plane(np.vstack([view.A_px, view.C_px]))
    u, v = Cm - Am, Bm - Am
    return np.arctan2(np.abs(u[0] * v[:, 1] - u[1] * v[:, 0]), v @ u)


def camera_link_mm(theta: NDArray, values: dict[str, float], view: CameraView) -> NDArray:
    """The crank length |AB| (mm) the run would measure at true angles ``theta`` (rad)
    through the camera effects in ``values``: rigid in the plane, bent by the camera."""
    Bm = view.to_plane(_crank_tip(theta, values, view)[1])
    Am = view.to_plane(view.A_px[None, :])[0]
    return np.hypot(*(Bm - Am).T)


def with_camera(simulate: Callable, view: CameraView | None) -> Callable:
    """``simulate`` followed by the camera effects, when there are any.

    A rolling shutter simulates again at the times B is caught (A and C stand
    still on these beds, so B's time is θ's): B's row moves by far less than
    the image between that time and the frame's, so one correction is enough.
    """
    if view is None:
        return simulate

    def run(values: dict[str, float], t_s: NDArray) -> NDArray:
        theta = simulate(values, t_s)
        readout = values.get(READOUT, 0.0)
        if readout:
            row = np.clip(_crank_tip(theta, values, view)[1][:, 1], 0.0, view.size[1])
            late = t_s + readout * row / view.size[1]
            # A negative readout can put the first frame before the first time asked for;
            # the models take times in order, which a readout shorter than a frame keeps.
            theta = simulate(values, late)
        if not any(values.get(k, 0.0) for k in CAMERA_PARAMETERS):
            return theta
        return camera_theta(theta, values, view)

    return run
