"""The best any unbiased estimator could do on a render: the Cramér–Rao bound."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .render import Style, draw_capsule, render_frame


def marker_crb_px(points_px: dict[str, NDArray[np.float64]], name: str, size: tuple[int, int],
                  px_per_mm: float, noise_dn: float,
                  channels: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                  style: Style | None = None) -> tuple[float, float]:
    """Cramér–Rao bound (per-axis 1-σ, px) on the centre of marker ``name``.

    For independent Gaussian noise of σ ``noise_dn`` on each RGB channel of
    each pixel, the Fisher information of the centre is
    ``Σ (∂μ/∂c)(∂μ/∂c)ᵀ / σ²`` over pixels and channels, with ``μ`` the
    noise-free render and the derivative taken by moving only that marker
    (everything else known). Returns ``(full_rgb, chroma_only)``: the bound
    for all three channels and for the coordinates ``channels`` maps an RGB
    image to (e.g. the tracker's two chroma coordinates: what a grey-blind
    estimator can use). Quantisation to 8 bits is ignored.
    """

    style = style or Style()
    others = Style(**{**style.__dict__,
                      "markers": {k: v for k, v in style.markers.items() if k != name}})
    base = render_frame(points_px, size, px_per_mm, others)
    r = style.marker_radius_mm * px_per_mm
    c = np.asarray(points_px[name], float)
    x0, y0 = int(c[0] - r - 4), int(c[1] - r - 4)
    n = int(2 * r + 9)
    h = 0.01

    def patch(centre: NDArray[np.float64]) -> NDArray[np.float64]:
        img = base.copy()
        draw_capsule(img, centre, centre, r, style.markers[name], style.supersample)
        return img[y0 : y0 + n, x0 : x0 + n].astype(np.float64)

    ex, ey = np.array([h, 0.0]), np.array([0.0, h])
    dx = (patch(c + ex) - patch(c - ex)) / (2 * h)
    dy = (patch(c + ey) - patch(c - ey)) / (2 * h)

    def bound(ax: NDArray, ay: NDArray) -> float:
        D = np.stack([ax.ravel(), ay.ravel()], axis=1)
        cov = np.linalg.inv(D.T @ D / noise_dn**2)
        return float(np.sqrt(np.diag(cov)).mean())

    return bound(dx, dy), bound(channels(dx), channels(dy))
