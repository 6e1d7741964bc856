"""A pendulum as a camera sees it: the physics a real pendulum clip is checked against.

Written for the bench, apart from the tracker (nothing here is imported from
cranktrack): the bob of a string pendulum moves on a sphere about the pivot under
gravity, against linear and quadratic air drag,

    r'' = −g ẑ + λ r − b r' − c |r'| r',   λ = (g z − |r'|²) / L²

(λ keeps |r| = L), and is seen through a pinhole camera at an unknown place and
attitude. A plane swing seen square-on is the special case; a real bob also swings
a little across (an ellipse) and the camera looks at it from a little above, which
a plane fit leaves as pixels of smooth residual. With g taken as known, the period
gives the length, which the clip's author measured.

The fit is staged, each stage started from the one before: a circle through the
path (pivot and radius in px), a plane damped swing about it, then the sphere.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

#: Free fall, m/s².
G = 9.80
#: The camera looks along +y of the world (z up): image x is world x, image y is −z.
_FACING = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True)
class SwingFit:
    """A pendulum fitted to a track: the string's length (m, from the period with
    g = :data:`G`), the small-swing period (s), the residual (n, 2) px and the number
    of parameters fitted."""

    length_m: float
    period_s: float
    residual: NDArray[np.float64]
    parameters: int


def circle_through(xy: NDArray) -> tuple[float, float, float]:
    """Centre (px) and radius (px) of the least-squares circle through points (n, 2):
    the algebraic fit, x² + y² = 2a·x + 2b·y + c."""
    A = np.c_[2 * xy, np.ones(len(xy))]
    a, b, c = np.linalg.lstsq(A, (xy**2).sum(axis=1), rcond=None)[0]
    return float(a), float(b), float(np.sqrt(c + a * a + b * b))


def _swing_angle(t: NDArray, phi0: float, w0: float, w2: float, b: float) -> NDArray:
    """Angle (rad) from the vertical of a plane pendulum, φ'' = −w2·sin φ − b·φ'."""
    sol = solve_ivp(lambda _, u: [u[1], -w2 * np.sin(u[0]) - b * u[1]], (t[0], t[-1]),
                    [phi0, w0], t_eval=t, rtol=1e-10, atol=1e-12, method="DOP853")
    return sol.y[0]


def plane_swing(t: NDArray, xy: NDArray, period_guess_s: float) -> tuple[NDArray, NDArray]:
    """A damped plane pendulum seen square-on, fitted to a track (t s, xy px): the
    parameters (φ0 rad, φ'0 rad/s, ω² 1/s², b 1/s, pivot x, pivot y, radius px) and the
    residual (n, 2) px."""
    px, py, radius = circle_through(xy)
    phi = np.arctan2(xy[:, 0] - px, xy[:, 1] - py)

    def model(p: NDArray) -> NDArray:
        a = _swing_angle(t, *p[:4])
        return np.c_[p[4] + p[6] * np.sin(a), p[5] + p[6] * np.cos(a)]

    start = np.r_[phi[0], (phi[1] - phi[0]) / (t[1] - t[0]), (2 * np.pi / period_guess_s) ** 2,
                  0.01, px, py, radius]
    fit = least_squares(lambda p: (model(p) - xy).ravel(), start, x_scale="jac")
    return fit.x, xy - model(fit.x)


def _bob(t: NDArray, p: NDArray) -> NDArray:
    """World positions (n, 3) m of the bob: p = (x0, y0, vx0, vy0, L, b, c), the
    horizontal start (m, m/s) below a pivot at the origin."""
    x0, y0, vx, vy, length, b, c = p
    z0 = -np.sqrt(max(length**2 - x0**2 - y0**2, 1e-9))
    vz = -(x0 * vx + y0 * vy) / z0  # along the sphere

    def rate(_: float, u: NDArray) -> list:
        r, v = u[:3], u[3:]
        speed2 = v @ v
        lam = (G * r[2] - speed2) / length**2
        a = lam * r - b * v - c * np.sqrt(speed2) * v
        a[2] -= G
        return [*v, *a]

    sol = solve_ivp(rate, (t[0], t[-1]), [x0, y0, z0, vx, vy, vz], t_eval=t, rtol=1e-10,
                    atol=1e-12, method="DOP853")
    return sol.y[:3].T


def _seen(P: NDArray, q: NDArray, centre: NDArray) -> NDArray:
    """Image px (n, 2) of world points P seen by a pinhole: q = (Rodrigues rotation of
    the camera from :data:`_FACING` (3), its position (3, m), ln focal length (px)),
    principal point at ``centre``."""
    R = cv2.Rodrigues(np.asarray(q[:3], float))[0] @ _FACING
    Pc = (P - q[3:6]) @ R.T
    return centre + np.exp(q[6]) * Pc[:, :2] / Pc[:, 2:]


def sphere_swing(t: NDArray, xy: NDArray, size: tuple[int, int], length_guess_m: float,
                 period_guess_s: float) -> SwingFit:
    """The pendulum of the module's docstring fitted to a track (t s, xy px) from a
    camera of ``size`` (w, h px), started from a plane swing. ``length_guess_m`` only
    sets the scale of the start (the camera's distance); the period decides the
    length."""
    plane, _ = plane_swing(t, xy, period_guess_s)
    phi0, w0, _, b, px, py, radius = plane
    centre = np.array(size, float) / 2.0
    focal = 0.9 * size[0]  # a phone's or webcam's ≈ 60° across, to start
    length = length_guess_m
    distance = focal * length / radius
    lowest = py + radius
    start = np.r_[length * np.sin(phi0), 0.0, length * np.cos(phi0) * w0, 0.0, length, b, 0.0,
                  0.0, 0.0, 0.0, (centre[0] - px) * distance / focal, -distance,
                  -length + (lowest - centre[1]) * distance / focal, np.log(focal)]

    def model(p: NDArray) -> NDArray:
        return _seen(_bob(t, p[:7]), p[7:], centre)

    # First without the quadratic drag and with the focal length held: the camera's
    # distance and focal length trade against each other until the attitude is found.
    stages = ([0, 1, 2, 3, 4, 5, 7, 8, 9, 10, 11, 12], list(range(14)))
    p = start.copy()
    for free in stages:
        def residual(q: NDArray, free: list[int] = free) -> NDArray:
            full = p.copy()
            full[free] = q
            return (model(full) - xy).ravel()

        fit = least_squares(residual, p[free], x_scale="jac", max_nfev=3000)
        p[free] = fit.x
    return SwingFit(length_m=float(p[4]), period_s=float(2 * np.pi * np.sqrt(p[4] / G)),
                    residual=xy - model(p), parameters=len(stages[-1]))
