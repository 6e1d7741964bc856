"""Coverage: how much of each pixel a marker covers, unmixed from its colour.

Every centre fit works on a small patch around a coarse detection and on the
*chroma* of the pixels: RGB minus its grey component, in a 2-D basis of the
plane orthogonal to (1, 1, 1). Grey and near-neutral things (links, wire,
board, shadows that only darken) have almost no chroma, so a pixel that is a
mix ``α·marker + (1 − α)·grey`` has chroma ``α·marker_chroma`` whatever the
grey is. Projecting each pixel's chroma, minus the background's (sampled on a
ring just outside the marker, :func:`local_coverage`), on the marker's gives
the coverage ``α`` of each pixel, linear in the data.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

#: Orthonormal basis of the chroma plane (rows), orthogonal to grey (1, 1, 1).
CHROMA_BASIS = np.array(
    [[1.0, -1.0, 0.0], [1.0, 1.0, -2.0]], dtype=np.float32
) / np.array([[np.sqrt(2.0)], [np.sqrt(6.0)]], dtype=np.float32)


#: The same basis in double precision, for the compiled coverage kernel.
_BASIS64 = CHROMA_BASIS.astype(np.float64)
#: A white or black marker has no chroma: it is unmixed on luminance alone (the
#: second axis is zero, so the kernel's plane collapses to a line).
LUMA_BASIS = np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]) / np.sqrt(3.0)


def chroma(rgb: NDArray) -> NDArray[np.float32]:
    """Chroma of RGB pixels, shape (..., 2), in DN."""
    return np.asarray(rgb, dtype=np.float32) @ CHROMA_BASIS.T


def local_coverage(patch_rgb: NDArray, x0: float, y0: float, centre: tuple[float, float],
                   radius: float, marker: NDArray | None = None, luminance: bool = False,
                   unit_px: float = 1.0, by_edge: bool = False
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Coverage α by unmixing chroma against a per-pixel background.

    Each pixel within ``radius + 2`` px of ``centre`` is unmixed as
    ``q = α·m + (1 − α)·b`` in the chroma plane, where ``m`` is the marker's
    chroma and ``b`` the background's along the same ray from the centre,
    sampled just outside the disc (``radius`` + 3…5 px). Links and the wire
    leave a marker radially, so the sample sees what lies under the marker's
    edge; uneven light is followed too. Pixels farther out are NaN, and with
    ``by_edge`` so are those whose ring lies off the patch, where the frame's edge cut
    it (:func:`unmixed_share`): a disc's fit needs only some of its pixels, while a
    centroid needs them all (there, the edge's pixels stand in for what lies past it).

    ``marker`` is the learned marker chroma; without it the median chroma of
    the pixels within 0.6·radius is used (only right when the marker is
    known to be there: at acquisition).

    Returns ``(alpha, marker_chroma_seen)``: the second is the median chroma
    of the middle of the patch, for following slow colour drift.
    ``luminance`` unmixes brightness instead of chroma (a white or black marker).
    ``unit_px`` is how many of the frame's px one of the patch's pixels spans (2 on a
    frame seen block by block, :mod:`.binned`); ``radius`` and ``centre`` are in the
    patch's pixels, and the background ring and the window's margin stay at their
    distances in the frame's px. On the SMA bed filmed 3.2 times closer
    (bench/sma_bed_apart.py --scale 3.2) the crank bar's rounded end reaches 8.6 px
    past A's rim; a ring 6-10 px out took in the board beyond it, and A was 0.056 px
    off, not 0.023.
    """
    known = marker is not None
    m = np.asarray(marker if known else (0.0, 0.0), np.float64)
    # The patch goes in as it is (a uint8 view of the frame): the kernel reads it
    # pixel by pixel, so a float copy per marker per frame would be wasted.
    alpha, seen = _coverage_compiled(np.asarray(patch_rgb),
                                     LUMA_BASIS if luminance else _BASIS64,
                                     float(centre[0] - x0), float(centre[1] - y0),
                                     float(radius), m, known, float(unit_px), by_edge)
    return alpha, seen


#: Where a pixel's background is sampled: this many px past the disc's rim, along the
#: ray from its centre through the pixel (:func:`local_coverage`).
RING_PX = (3.0, 4.0, 5.0)
#: The directions :func:`unmixed_share` counts (720: half a degree apart).
_RAYS = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
_RAY_COS, _RAY_SIN = np.cos(_RAYS), np.sin(_RAYS)


def unmixed_share(x: float, y: float, radius: float, size: tuple[int, int]) -> float:
    """The share (0–1) of a disc of ``radius`` px about (``x``, ``y``) px whose pixels
    :func:`local_coverage` unmixes in a frame of ``size`` (width, height) px: those
    whose background ring samples (:data:`RING_PX`) lie on the frame. A pixel whose ring
    lies past the frame's edge has no background to unmix against (edge pixels repeated
    there are the marker's own where the edge cuts it) and is left NaN. By directions, a
    disc's area being even in angle; exactly 1 where the ring lies clear of the edge.

    >>> unmixed_share(100.0, 100.0, 10.0, (640, 480))
    1.0
    >>> import math
    >>> share = unmixed_share(5.0, 100.0, 10.0, (640, 480))  # ring 15 px out, edge 5.5 px
    >>> exact = math.acos(-5.5 / 15.0) / math.pi  # the arc of the ring left of x = -0.5
    >>> round(share, 3), round(exact, 3)
    (0.621, 0.62)
    """
    w, h = size
    reach = radius + RING_PX[-1]
    if not (np.isfinite(x) and np.isfinite(y) and reach > 0):
        return 0.0
    if x - reach >= -0.5 and y - reach >= -0.5 and x + reach <= w - 0.5 \
            and y + reach <= h - 0.5:
        return 1.0
    sx, sy = x + reach * _RAY_COS, y + reach * _RAY_SIN
    return float(np.mean((sx >= -0.5) & (sx <= w - 0.5) & (sy >= -0.5) & (sy <= h - 0.5)))


#: A pixel this much (px) nearer or farther than the middle's edge in its squared
#: distance is inside or outside it whatever the rounding (which is ~1e-13 px here).
MIDDLE_MARGIN_PX = 0.01


@njit(cache=True, nogil=True)
def _bilinear(P: NDArray, x: float, y: float, out: NDArray) -> None:
    """Add P sampled at (x, y) (bilinear, edges replicated) to ``out`` (2,)."""
    h, w = P.shape[0], P.shape[1]
    x = min(max(x, 0.0), w - 1.0)
    y = min(max(y, 0.0), h - 1.0)
    i, j = min(int(y), h - 2), min(int(x), w - 2)
    fy, fx = y - i, x - j
    for c in range(2):
        out[c] += ((1 - fy) * ((1 - fx) * P[i, j, c] + fx * P[i, j + 1, c])
                   + fy * ((1 - fx) * P[i + 1, j, c] + fx * P[i + 1, j + 1, c]))


@njit(cache=True, nogil=True)
def _coverage_compiled(rgb: NDArray, basis: NDArray, cx: float, cy: float, radius: float,
                       marker: NDArray, known: bool, unit: float, by_edge: bool
                       ) -> tuple[NDArray, NDArray]:
    """:func:`local_coverage` on an RGB patch (h, w, 3), centre in patch px, each of which
    spans ``unit`` frame px."""
    h, w = rgb.shape[0], rgb.shape[1]
    P = np.empty((h, w, 2))
    for i in range(h):
        for j in range(w):
            for c in range(2):
                P[i, j, c] = (basis[c, 0] * rgb[i, j, 0] + basis[c, 1] * rgb[i, j, 1]
                              + basis[c, 2] * rgb[i, j, 2])
    inner_x, inner_y = np.empty(h * w), np.empty(h * w)
    n_inner = 0
    # ``hypot`` is exact and slow (it was a quarter of this kernel's time on yupi's rover
    # clip): a pixel clearly inside or outside, by its squared distance with a margin
    # far beyond any rounding, is decided without it; the rest as before, to the bit.
    middle = 0.6 * radius
    surely_in = max(middle - MIDDLE_MARGIN_PX, 0.0) ** 2
    surely_out = (middle + MIDDLE_MARGIN_PX) ** 2
    for i in range(h):
        for j in range(w):
            q = (j - cx) * (j - cx) + (i - cy) * (i - cy)
            if q > surely_out:
                continue
            if q < surely_in or math.hypot(j - cx, i - cy) + 1e-6 <= middle:
                inner_x[n_inner] = P[i, j, 0]
                inner_y[n_inner] = P[i, j, 1]
                n_inner += 1
    seen = np.empty(2)
    if n_inner >= 3:
        seen[0] = np.median(inner_x[:n_inner])
        seen[1] = np.median(inner_y[:n_inner])
    else:
        seen[0], seen[1] = P[h // 2, w // 2, 0], P[h // 2, w // 2, 1]
    m = marker if known else seen
    alpha = np.full((h, w), np.nan)
    b = np.empty(2)
    for i in range(h):
        for j in range(w):
            dx, dy = j - cx, i - cy
            rho = math.sqrt(dx * dx + dy * dy) + 1e-6
            if rho > radius + 2.0 / unit:
                continue
            ux, uy = dx / rho, dy / rho
            b[:] = 0.0
            off = False
            for k in RING_PX:
                sx = cx + (radius + k / unit) * ux
                sy = cy + (radius + k / unit) * uy
                # A patch reaches past the ring unless the frame's edge cut it: a sample
                # off it would repeat the edge's pixels, the marker's own where the edge
                # cuts the marker (a ball half out of yupi's box unmixed against itself).
                off = off or sx < -0.5 or sy < -0.5 or sx > w - 0.5 or sy > h - 0.5
                _bilinear(P, sx, sy, b)
            if off and by_edge:
                continue
            b /= 3.0
            d0, d1 = m[0] - b[0], m[1] - b[1]
            denom = max(d0 * d0 + d1 * d1, 1e-6)
            alpha[i, j] = ((P[i, j, 0] - b[0]) * d0 + (P[i, j, 1] - b[1]) * d1) / denom
    return alpha, seen
