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

from cranktrack.errors import CranktrackError

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
            return cls(name, float(key) % 360.0)
        except ValueError:
            known = ", ".join(COLOUR_HUES_DEG)
            raise CranktrackError(
                f"unknown marker colour {colour!r} for {name}; use one of {known} or a hue "
                "in degrees") from None

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
class Detection:
    """A marker centre (px), its per-axis 1-σ uncertainty (px) and blob area (px²).

    A marker not found has NaN position and ``ok = False``.
    """

    x: float
    y: float
    sigma: float
    area: float
    ok: bool

    @classmethod
    def missing(cls) -> Detection:
        return cls(np.nan, np.nan, np.nan, 0.0, False)


def mask_centroid_sigma(area_px: float) -> float:
    """Per-axis 1-σ of a binary-mask centroid of a disc of ``area_px`` pixels.

    Each of the ≈2πr edge pixels is in or out of the mask at random with
    variance ≈ 1/6, at an offset ≈ r·cos φ from the centre, so
    σ² ≈ (2πr · r²/2 · 1/6) / (πr²)² = 1 / (6πr).
    """
    r = np.sqrt(max(area_px, 1.0) / np.pi)
    return float(np.sqrt(1.0 / (6.0 * np.pi * r)))


def detect(hsv: NDArray[np.uint8], spec: MarkerSpec) -> Detection:
    """Largest blob of ``spec``'s colour and its mask centroid (px)."""
    mask = spec.mask(hsv)
    n, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 1:
        return Detection.missing()
    areas = stats[1:, cv2.CC_STAT_AREA]
    k = int(np.argmax(areas))
    if areas[k] < spec.min_area_px:
        return Detection.missing()
    cx, cy = centroids[k + 1]
    return Detection(float(cx), float(cy), mask_centroid_sigma(areas[k]), float(areas[k]), True)


def detect_all(rgb: NDArray[np.uint8], specs: tuple[MarkerSpec, ...]) -> dict[str, Detection]:
    """Detect every marker in one RGB frame."""
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    return {spec.name: detect(hsv, spec) for spec in specs}
