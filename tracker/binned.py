"""A frame seen at half its resolution, each 2×2 block of pixels one pixel: for markers
filmed close.

A marker's fits cost as its area (its coverage, the disc fit, the wire's search): a
marker 120 px across in 1080p H.264 took twice as long to follow as the frame took to
decode (``bench/large_markers.py``). On a 4:2:0 frame each block is one chroma cell,
whose one colour its four pixels share, so a marker found by its colour, seen block by
block, loses nothing but the rounding of its pixels. :func:`.refine.refine` fits such
markers here and maps the result back (:func:`to_bins`, :func:`from_bins`). Not where
every pixel has its own colour, nor for a white or black marker (its luminance is per
pixel): on lossless RGB discs of radius 60 px fitted block by block were 0.007 px off
in x and y (0.008-0.010 px RMS), against 0.002 px RMS fitted pixel by pixel with their
luminance edge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .video import Frame, yuv_to_rgb


def to_bins(v: float) -> float:
    """A frame's pixel coordinate (px) as the binned frame's: block k spans pixels 2k
    and 2k + 1, so its centre is at 2k + ½."""
    return (v - 0.5) / 2.0


def from_bins(u: float) -> float:
    """A binned frame's coordinate as the frame's (px): the inverse of :func:`to_bins`."""
    return 2.0 * u + 0.5


@dataclass(frozen=True)
class BinnedFrame:
    """``frame`` with each 2×2 block of pixels (from even columns and rows) one pixel:
    its colour the mean of theirs. It has what the fits read of a frame: :attr:`size`
    and :meth:`region`. Its chroma is not per pixel of the frame, so the fits do not
    read the marker's luminance edge on it."""

    frame: Frame
    full_chroma: bool = False
    layout: str = "binned"

    @property
    def unit_px(self) -> float:
        """How many of the frame's px one of its pixels spans."""
        return 2.0

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in blocks."""
        w, h = self.frame.size
        return w // 2, h // 2

    def region(self, x0: int, y0: int, x1: int, y1: int) -> NDArray[np.uint8]:
        """RGB of blocks x0…x1−1, y0…y1−1 (inside the binned frame), rounded to DN."""
        f = self.frame
        if f.layout == "i420" and "rgb" not in f.__dict__:
            return _i420_blocks(*f.planes(), x0, y0, x1, y1, f.levels)
        rgb = f.region(2 * x0, 2 * y0, 2 * x1, 2 * y1).astype(np.uint16)
        h, w = y1 - y0, x1 - x0
        sums = rgb.reshape(h, 2, w, 2, 3).sum(axis=(1, 3))
        return ((sums + 2) // 4).astype(np.uint8)


@njit(cache=True, nogil=True)
def _i420_blocks(Y: NDArray, U: NDArray, V: NDArray, x0: int, y0: int, x1: int, y1: int,
                 levels: tuple) -> NDArray:
    """RGB of the blocks x0…x1−1, y0…y1−1 of 4:2:0 planes: each block's mean luma with
    its chroma cell's U and V, converted as :meth:`.video.Frame.region` converts
    pixels."""
    out = np.empty((y1 - y0, x1 - x0, 3), np.uint8)
    for i in range(y0, y1):
        for j in range(x0, x1):
            luma = 0.25 * (np.float64(Y[2 * i, 2 * j]) + Y[2 * i, 2 * j + 1]
                           + Y[2 * i + 1, 2 * j] + Y[2 * i + 1, 2 * j + 1])
            r, g, b = yuv_to_rgb(luma, U[i, j], V[i, j], levels)
            out[i - y0, j - x0, 0] = np.uint8(min(max(r + 0.5, 0.0), 255.0))
            out[i - y0, j - x0, 1] = np.uint8(min(max(g + 0.5, 0.0), 255.0))
            out[i - y0, j - x0, 2] = np.uint8(min(max(b + 0.5, 0.0), 255.0))
    return out
