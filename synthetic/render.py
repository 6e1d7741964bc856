"""Anti-aliased drawing of the mechanism.

Every shape is a *capsule* (the set of points within a half-width of a
segment; a disc is a capsule of zero length). A pixel's value is the
area-average of the shape's coverage over the pixel, estimated on an
``S×S`` grid of sub-samples, each of which is itself anti-aliased with a
linear ramp one sub-sample wide. The result is radially symmetric about a
marker's true centre up to the sub-sampling, which keeps the intensity
centroid of a noise-free marker within a few thousandths of a pixel of the
truth (tested in ``tests/test_render.py``).

A camera that is tilted to the plane sees a printed disc as an ellipse, and a
bar's width shrinks with its distance. :func:`render_frame` with ``to_plane``
draws for such a camera: each sub-sample is traced back onto the mechanism's plane through the
camera's homography and the shape is measured there, in mm, so a disc is the
exact image of a circle on the plane (as :mod:`.board` draws a chessboard).

Images are RGB, float32 in [0, 255] while drawing; :func:`to_uint8` adds
sensor noise and quantises.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

RGB = tuple[float, float, float]


@dataclass(frozen=True)
class Style:
    """Colours (RGB, 0–255) and sizes (mm) of the drawn mechanism."""

    background: RGB = (214.0, 212.0, 204.0)
    frame_link: RGB = (105.0, 105.0, 110.0)
    crank: RGB = (150.0, 148.0, 145.0)
    wire: RGB = (40.0, 40.0, 40.0)
    markers: dict[str, RGB] = field(
        default_factory=lambda: {
            "A": (40.0, 160.0, 70.0),  # green
            "B": (205.0, 40.0, 45.0),  # red
            "C": (35.0, 75.0, 200.0),  # blue
        }
    )
    marker_radius_mm: float = 2.35
    frame_half_width_mm: float = 1.2
    crank_half_width_mm: float = 1.4
    wire_half_width_mm: float = 0.25
    supersample: int = 4
    #: Per-channel gain of the light (1, 1, 1 is neutral); e.g. (1.15, 1.0, 0.8) is a
    #: warm, tungsten-like cast that shifts every hue the camera sees.
    illuminant: RGB = (1.0, 1.0, 1.0)


def capsule_coverage(
    xs: NDArray[np.float64],
    ys: NDArray[np.float64],
    p0: NDArray[np.float64],
    p1: NDArray[np.float64],
    half_width: float,
    supersample: int,
    to_plane: NDArray[np.float64] | None = None,
) -> NDArray[np.float32]:
    """Fraction of each pixel covered by a capsule.

    Parameters
    ----------
    xs, ys : ndarray
        1-D pixel-centre coordinates of the patch columns and rows, px.
    p0, p1 : ndarray
        Segment end points (x, y), px, or plane mm with ``to_plane``.
        ``p0 == p1`` draws a disc.
    half_width : float
        Capsule radius, px, or plane mm with ``to_plane``.
    supersample : int
        Sub-samples per pixel side.
    to_plane : ndarray (3, 3), optional
        Homography from image px to the plane the capsule lies on (mm). Each
        sub-sample is measured there, so the capsule is drawn as the camera
        sees it: a disc becomes the exact image of a circle on the plane.

    Returns
    -------
    ndarray, float32, shape (len(ys), len(xs))
        Coverage in [0, 1].
    """
    S = int(supersample)
    X, Y = np.meshgrid(np.asarray(xs, float), np.asarray(ys, float))
    if to_plane is None:
        dist = _capsule_distance(X, Y, p0, p1)
        step = 1.0  # shape units per px
    else:
        x0, y0 = apply_homography(to_plane, X, Y)
        dist = _capsule_distance(x0, y0, p0, p1)
        # mm per px from the map's Jacobian at each pixel (forward differences of
        # one px): its Frobenius norm bounds the stretch in any direction.
        x1, y1 = apply_homography(to_plane, X + 1.0, Y)
        x2, y2 = apply_homography(to_plane, X, Y + 1.0)
        step = np.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2 + (x2 - x0) ** 2 + (y2 - y0) ** 2)
    cov = (dist < half_width).astype(np.float32)
    # A sub-sample lies within √2/2 px of its pixel centre and ramps over 1/S px,
    # so pixels whose centre is farther than 1 px from the edge are uniform.
    edge = np.abs(dist - half_width) <= step
    if edge.any():
        offs = (np.arange(S) + 0.5) / S - 0.5
        ox, oy = (a.ravel() for a in np.meshgrid(offs, offs))
        ex = X[edge][:, None] + ox[None, :]
        ey = Y[edge][:, None] + oy[None, :]
        if to_plane is None:
            sub = np.clip((half_width - _capsule_distance(ex, ey, p0, p1)) * S + 0.5, 0.0, 1.0)
        else:
            # The ramp is one sub-sample wide at the pixel's mean scale (the RMS over
            # directions, step/√2); where it crosses 0.5, the edge, is exact.
            per_px = np.sqrt(2.0) / step[edge][:, None]
            d = _capsule_distance(*apply_homography(to_plane, ex, ey), p0, p1)
            sub = np.clip((half_width - d) * per_px * S + 0.5, 0.0, 1.0)
        cov[edge] = sub.mean(axis=1)
    return cov


def apply_homography(H: NDArray[np.float64], x: NDArray[np.float64], y: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points (x, y) through the 3×3 homography ``H`` (same shapes as ``x``, ``y``)."""
    w = H[2, 0] * x + H[2, 1] * y + H[2, 2]
    return ((H[0, 0] * x + H[0, 1] * y + H[0, 2]) / w,
            (H[1, 0] * x + H[1, 1] * y + H[1, 2]) / w)


def _capsule_distance(x: NDArray[np.float64], y: NDArray[np.float64], p0: NDArray[np.float64],
                      p1: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance from points (x, y) to the segment p0–p1, px."""
    d = p1 - p0
    dd = float(d @ d)
    px, py = x - p0[0], y - p0[1]
    if dd > 0:
        t = np.clip((px * d[0] + py * d[1]) / dd, 0.0, 1.0)
        px, py = px - t * d[0], py - t * d[1]
    return np.sqrt(px * px + py * py)


def draw_capsule(
    image: NDArray[np.float32],
    p0: NDArray[np.float64],
    p1: NDArray[np.float64],
    half_width: float,
    colour: RGB,
    supersample: int,
    to_plane: NDArray[np.float64] | None = None,
) -> None:
    """Composite a capsule of ``colour`` over ``image`` in place (only its bounding box).

    With ``to_plane`` the capsule is given on the plane (mm), as in
    :func:`capsule_coverage`.
    """
    h, w = image.shape[:2]
    lo_, hi_ = np.minimum(p0, p1) - half_width, np.maximum(p0, p1) + half_width
    if to_plane is not None:
        # A homography keeps lines straight, so the image of the plane box is
        # bounded by its four corners' images.
        cx, cy = apply_homography(np.linalg.inv(to_plane),
                                  np.array([lo_[0], hi_[0], lo_[0], hi_[0]]),
                                  np.array([lo_[1], lo_[1], hi_[1], hi_[1]]))
        lo_, hi_ = np.array([cx.min(), cy.min()]), np.array([cx.max(), cy.max()])
    lo = np.floor(lo_ - 2).astype(int)
    hi = np.ceil(hi_ + 2).astype(int)
    x0, y0 = max(lo[0], 0), max(lo[1], 0)
    x1, y1 = min(hi[0], w - 1), min(hi[1], h - 1)
    if x0 > x1 or y0 > y1:
        return  # entirely outside the image
    xs = np.arange(x0, x1 + 1, dtype=float)
    ys = np.arange(y0, y1 + 1, dtype=float)
    alpha = capsule_coverage(xs, ys, p0, p1, half_width, supersample, to_plane)[..., None]
    patch = image[y0 : y1 + 1, x0 : x1 + 1]
    patch *= 1.0 - alpha
    patch += alpha * np.asarray(colour, dtype=np.float32)


def render_frame(
    points_px: dict[str, NDArray[np.float64]],
    size: tuple[int, int],
    px_per_mm: float | dict[str, float],
    style: Style | None = None,
    wires: list[tuple[NDArray, NDArray]] | None = None,
    bars: list[tuple[NDArray, NDArray]] = (),
    to_plane: NDArray[np.float64] | None = None,
) -> NDArray[np.float32]:
    """Draw one frame of the crank-slider (or, with ``wires``, another wire mechanism).

    With ``to_plane`` (the homography from image px to the mechanism's plane,
    mm) every point and segment is given on the plane, in mm, and drawn as a
    camera at that pose sees it (``px_per_mm`` is not used): see
    :func:`capsule_coverage`.

    Parameters
    ----------
    points_px : dict
        Image positions (x, y), px, of ``"A"``, ``"B"``, ``"C"``.
    size : (width, height)
        Image size, px.
    px_per_mm : float or dict
        Scale used to size links and markers, px/mm: one for the whole image,
        or one per point (a tilted camera sees near things larger).
    style : Style, optional
        Colours and sizes.
    wires : list of (start, end), optional
        Image segments, px, drawn as wires in place of the B–C wire.
    bars : list of (start, end)
        Image segments, px, drawn in the crank's colour and width.

    Returns
    -------
    ndarray, float32, shape (height, width, 3)
        RGB in [0, 255], noise-free.
    """
    style = style or Style()
    w, h = size
    img = np.empty((h, w, 3), dtype=np.float32)
    img[...] = np.asarray(style.background, dtype=np.float32)
    A, B, C = (np.asarray(points_px[k], dtype=float) for k in ("A", "B", "C"))

    def scale(*names: str) -> float:
        if to_plane is not None:
            return 1.0  # sizes stay in mm, measured on the plane
        if isinstance(px_per_mm, dict):
            return float(np.mean([px_per_mm[n] for n in names]))
        return float(px_per_mm)

    S = style.supersample
    H = to_plane
    draw_capsule(img, A, C, style.frame_half_width_mm * scale("A", "C"), style.frame_link, S, H)
    draw_capsule(img, A, B, style.crank_half_width_mm * scale("A", "B"), style.crank, S, H)
    for p, q in bars:
        draw_capsule(img, p, q, style.crank_half_width_mm * scale("A", "B"), style.crank, S, H)
    for p, q in wires if wires is not None else [(B, C)]:
        draw_capsule(img, p, q, style.wire_half_width_mm * scale("B", "C"), style.wire, S, H)
    for name, colour in style.markers.items():
        if name in points_px:
            p = np.asarray(points_px[name], dtype=float)
            draw_capsule(img, p, p, style.marker_radius_mm * scale(name), colour, S, H)
    if style.illuminant != (1.0, 1.0, 1.0):
        img *= np.asarray(style.illuminant, dtype=np.float32)
    return img


def to_uint8(
    image: NDArray[np.float32], noise_dn: float = 0.0, rng: np.random.Generator | None = None
) -> NDArray[np.uint8]:
    """Add Gaussian sensor noise (σ in digital numbers) and quantise to 8 bits."""
    out = image.copy()
    if noise_dn > 0:
        rng = rng or np.random.default_rng()
        noise = rng.standard_normal(image.shape, dtype=np.float32)
        noise *= np.float32(noise_dn)
        out += noise
    np.clip(out, 0.0, 255.0, out=out)
    np.rint(out, out=out)
    return out.astype(np.uint8)
