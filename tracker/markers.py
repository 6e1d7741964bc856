"""Colour markers: which pixels belong to which marker, and where its centre is.

This first detector thresholds hue, saturation and value (OpenCV's 8-bit HSV:
hue 0–179 in 2° steps), keeps the largest blob of each colour and takes the
centroid of its mask. Red wraps around hue 0, so hue ranges are intervals on
the hue circle.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from ..errors import CranktrackError

#: Hue (degrees on the 0–360 circle) of colour names a user may give.
COLOUR_HUES_DEG = {
    "red": 0.0, "orange": 30.0, "yellow": 60.0, "green": 120.0, "cyan": 180.0,
    "blue": 230.0, "purple": 270.0, "magenta": 300.0,
}


@dataclass(frozen=True)
class MarkerSpec:
    """A marker to find: its name and colour window.

    ``hue_deg`` ± ``hue_tol_deg`` on the hue circle, saturation and value at
    least ``min_saturation`` and ``min_value`` (0–1), and a blob of at least
    ``min_area_px`` pixels.
    """

    name: str
    hue_deg: float
    hue_tol_deg: float = 30.0
    min_saturation: float = 0.35
    min_value: float = 0.25
    min_area_px: int = 6

    @classmethod
    def from_colour(cls, name: str, colour: str) -> MarkerSpec:
        """A spec from a colour name (``red``, ``green``, …) or a hue in degrees."""
        key = colour.strip().lower()
        if key in COLOUR_HUES_DEG:
            return cls(name, COLOUR_HUES_DEG[key])
        try:
            hue = float(key)
        except ValueError:
            known = ", ".join(COLOUR_HUES_DEG)
            raise CranktrackError(
                f"unknown marker colour {colour!r} for {name}; use one of {known} or a hue "
                "in degrees") from None
        if not 0.0 <= hue <= 360.0:
            raise CranktrackError(f"marker {name}'s hue {colour.strip()} is outside 0–360°")
        return cls(name, hue % 360.0)

    def mask(self, hsv: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """Pixels of this colour (255) in an OpenCV 8-bit HSV image."""
        s_min = round(self.min_saturation * 255)
        v_min = round(self.min_value * 255)
        lo = (self.hue_deg - self.hue_tol_deg) / 2.0  # OpenCV hue units (2°)
        hi = (self.hue_deg + self.hue_tol_deg) / 2.0
        ranges = []
        for a, b in ((lo, hi), (lo - 180, hi - 180), (lo + 180, hi + 180)):
            a, b = max(a, 0.0), min(b, 179.0)
            if a <= b:
                ranges.append((int(np.ceil(a)), int(np.floor(b))))
        mask = np.zeros(hsv.shape[:2], np.uint8)
        for a, b in ranges:
            mask |= cv2.inRange(hsv, (a, s_min, v_min), (b, 255, 255))
        return mask


DEFAULT_MARKERS: tuple[MarkerSpec, ...] = (
    MarkerSpec.from_colour("A", "green"),
    MarkerSpec.from_colour("B", "red"),
    MarkerSpec.from_colour("C", "blue"),
)


@dataclass(frozen=True)
class Blob:
    """A connected region of a marker's colour: mask centroid (px), area (px²),
    fill (area ÷ bounding-box area; π/4 for a disc) and bounding-box aspect ratio."""

    x: float
    y: float
    area: float
    fill: float
    aspect: float

    @property
    def radius(self) -> float:
        """Radius of a disc of the same area, px."""
        return float(np.sqrt(self.area / np.pi))

    def disc_like(self) -> bool:
        """Roughly a disc (partly covered or blurred discs still pass)."""
        return 0.45 <= self.fill <= 0.95 and 0.4 <= self.aspect <= 2.5


def find_blobs(hsv: NDArray[np.uint8], spec: MarkerSpec, x0: int = 0, y0: int = 0
               ) -> list[Blob]:
    """Blobs of ``spec``'s colour in an HSV image (or patch whose top-left is x0, y0)."""
    mask = spec.mask(hsv)
    n, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    blobs = []
    for k in range(1, n):
        area = float(stats[k, cv2.CC_STAT_AREA])
        if area < spec.min_area_px:
            continue
        w, h = stats[k, cv2.CC_STAT_WIDTH], stats[k, cv2.CC_STAT_HEIGHT]
        blobs.append(Blob(float(centroids[k][0]) + x0, float(centroids[k][1]) + y0, area,
                          area / float(w * h), float(w) / float(h)))
    return blobs


def choose_blob(blobs: list[Blob], expected_area: float | None = None,
                near: tuple[float, float] | None = None) -> tuple[Blob | None, str]:
    """Pick the marker among candidate blobs; returns ``(blob, status)``.

    Blobs must be disc-like and, once the marker's size is known, within
    0.3–3× its area. Among those, the nearest to ``near`` wins, else the
    largest. ``status`` is ``"ok"``, ``"not_found"`` (no blob of the colour)
    or ``"rejected"`` (blobs of the colour, none of a marker's size and shape).
    """
    if not blobs:
        return None, "not_found"
    good = [b for b in blobs if b.disc_like()]
    if expected_area:
        good = [b for b in good if 0.3 * expected_area <= b.area <= 3.0 * expected_area]
    if not good:
        return None, "rejected"
    if near is not None:
        return min(good, key=lambda b: (b.x - near[0]) ** 2 + (b.y - near[1]) ** 2), "ok"
    return max(good, key=lambda b: b.area), "ok"


def white_balance_gains(rgb: NDArray[np.uint8]) -> NDArray[np.float32]:
    """Per-channel gains that make the frame's median colour grey.

    The board and links fill most of a frame and are near-neutral, so a
    colour cast of the light shows in the median; dividing it out restores
    the hues the default colour windows expect. Sub-sampled for speed.
    """
    med = np.median(rgb[::4, ::4].reshape(-1, 3), axis=0).astype(np.float32)
    med = np.maximum(med, 1.0)
    return (med.mean() / med).astype(np.float32)


def balanced_hsv(rgb: NDArray[np.uint8], gains: NDArray[np.float32] | None) -> NDArray[np.uint8]:
    """HSV of ``rgb`` after per-channel white-balance ``gains``."""
    img = np.ascontiguousarray(rgb)
    if gains is not None:
        img = cv2.transform(img, np.diag(gains.astype(np.float64)))
    return cv2.cvtColor(img, cv2.COLOR_RGB2HSV)


def acquire(hsv: NDArray[np.uint8], spec: MarkerSpec, expected_area: float | None = None,
            near: tuple[float, float] | None = None
            ) -> tuple[Blob | None, str, list[Blob]]:
    """Full-frame search for ``spec``'s marker, over a ladder of saturation floors.

    A marker touching a faintly tinted background can merge with it at the
    user's floor and fail the shape test; at a higher floor it stands alone.
    All candidates from all floors compete in :func:`choose_blob`. Also
    returns the *rivals*: other blobs of the same colour, shape and size
    (within 2× the chosen one's area) elsewhere in the frame, so the caller
    can say that the choice was a guess.
    """
    blobs: list[Blob] = []
    for extra in (0.0, 0.15, 0.3):
        floor = min(spec.min_saturation + extra, 0.9)
        blobs += find_blobs(hsv, MarkerSpec(spec.name, spec.hue_deg, spec.hue_tol_deg, floor,
                                            spec.min_value, spec.min_area_px))
    blob, status = choose_blob(blobs, expected_area, near)
    rivals: list[Blob] = []
    if blob is not None:
        for b in blobs:
            far = np.hypot(b.x - blob.x, b.y - blob.y) > 3 * blob.radius
            alike = b.disc_like() and 0.5 * blob.area <= b.area <= 2.0 * blob.area
            seen = any(np.hypot(b.x - r.x, b.y - r.y) < 2 * blob.radius for r in rivals)
            if far and alike and not seen:
                rivals.append(b)
    return blob, status, rivals


def learn_spec(spec: MarkerSpec, hsv: NDArray[np.uint8], centre: tuple[float, float],
               radius: float, x0: int, y0: int) -> MarkerSpec:
    """A spec re-centred on the hue actually seen in the marker's middle.

    Lighting shifts hues; the learned window is centred on the circular
    median hue of the pixels within 0.6 of the radius, ±15° or three times
    their spread, whichever is wider. The saturation and value floors stay,
    so blurred edges still count. ``hsv`` is an OpenCV 8-bit HSV patch whose
    top-left pixel is at (x0, y0).
    """
    h, w = hsv.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    inner = (xx + x0 - centre[0]) ** 2 + (yy + y0 - centre[1]) ** 2 <= (0.6 * radius) ** 2
    if inner.sum() < 3:
        return spec
    hue = np.radians(hsv[..., 0][inner].astype(float) * 2.0)
    mean = np.arctan2(np.sin(hue).mean(), np.cos(hue).mean())
    spread = np.degrees(np.abs(np.angle(np.exp(1j * (hue - mean)))))
    return MarkerSpec(spec.name, float(np.degrees(mean) % 360.0),
                      max(15.0, 3.0 * float(np.median(spread)) * 1.4826),
                      spec.min_saturation, spec.min_value, spec.min_area_px)
