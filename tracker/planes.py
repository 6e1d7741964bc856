"""The decoder's pictures as :class:`.video.Frame` holds them: 8-bit 4:2:0 planes in a
known matrix wherever the file allows (the tracker's colour model has 2×2 cells), else
RGB, turned upright as the file says.

Cameras and phones store more than one layout: 10- and 12-bit samples (a phone's
HDR), 4:2:2 (MJPEG webcams, ProRes), BT.601, BT.709 and BT.2020 matrices, and a
display rotation. ``bench/formats.py`` measures each against discs drawn at known
places.
"""

from __future__ import annotations

import re

import av
import numpy as np
from numpy.typing import NDArray

#: FFmpeg colour-space codes and the YUV → RGB matrix (its ITU-R BT number) each names:
#: unspecified (which FFmpeg also converts as BT.601), BT.470BG and SMPTE 170M are
#: BT.601; 1 is BT.709 (HD video: phones, most cameras); 9 is BT.2020 (a phone's HDR).
_MATRICES = {2: 601, 5: 601, 6: 601, 1: 709, 9: 2020}


def frame_pixels(frame: av.VideoFrame, turns: int = 0
                  ) -> tuple[NDArray[np.uint8], str, bool, bool, int]:
    """The decoder's planes when they can be converted region by region, else RGB,
    turned ``turns`` quarter turns counter-clockwise (upright, :func:`upright_turns`);
    whether the chroma is stored at full resolution (:attr:`.video.Frame.full_chroma`);
    whether 4:2:0 planes are in full range (:attr:`.video.Frame.full_range`), and their
    matrix (:attr:`.video.Frame.matrix`)."""
    full = all(c.width == frame.width and c.height == frame.height
               for c in frame.format.components)
    frame = _cells_of_four(_eight_bit(_unpacked(frame)))
    # Planes laid one under another as Frame keeps them need a height that is a
    # multiple of 4 and an even width, upright and as stored (854×480 is kept; frames
    # of other sizes are converted whole).
    across = 4 if turns % 2 else 2
    if (frame.format.name in ("yuv420p", "yuvj420p") and frame.width % across == 0
            and frame.height % 4 == 0 and frame.colorspace in _MATRICES):
        # FFmpeg's range codes: 0 unspecified, 1 limited (MPEG), 2 full (JPEG);
        # "yuvj420p" is the older way of saying full.
        wide = frame.format.name == "yuvj420p" or frame.color_range == 2
        return (_turned_i420(frame.to_ndarray(), turns), "i420", full, wide,
                _MATRICES[frame.colorspace])
    rgb = frame.to_ndarray(format="rgb24")
    return ((np.ascontiguousarray(np.rot90(rgb, turns)) if turns else rgb), "rgb", full, False,
            601)


#: Planar YUV of more than 8 bits a sample, little-endian as decoders give it: the
#: 8-bit format of the same chroma layout, and the bits.
_DEEP_YUV = re.compile(r"(yuv4[24][024]p)(9|10|12|14|16)le")


def _eight_bit(frame: av.VideoFrame) -> av.VideoFrame:
    """A planar YUV frame of more than 8 bits a sample (10-bit HEVC, as phones film
    HDR; 10-bit 4:2:2 from video cameras) as the same planes at 8 bits, each code
    rounded to its nearest 8-bit one; any other frame as it is.

    FFmpeg's own conversion to RGB of such a frame places its chroma about half a
    pixel to the left of where its conversion of the same planes at 8 bits does:
    discs drawn at whole pixels came out 0.45 px off in x at 4:2:0 and 0.41 px at
    4:2:2; read at 8 bits, 0.01 and 0.035 px, as 8-bit video of those layouts."""
    deep = _DEEP_YUV.fullmatch(frame.format.name)
    if deep is None:
        return frame
    shift = int(deep.group(2)) - 8
    out = av.VideoFrame(frame.width, frame.height, deep.group(1))
    for k in range(len(out.planes)):
        codes = plane_samples(frame, k).astype(np.uint32)
        plane_samples(out, k)[...] = np.minimum((codes + (1 << (shift - 1))) >> shift, 255)
    out.colorspace, out.color_range = frame.colorspace, frame.color_range
    return out


#: 8-bit YUV stored other than plane by plane: where each sample lies in a row of the
#: packed plane (Y, U, V: first sample and step, in bytes), and the planar format of the
#: same chroma layout. USB webcams deliver YUYV (``yuyv422``); some capture cards and
#: hardware decoders UYVY or NV12 (Y, then U and V interleaved at 4:2:0).
_PACKED = {
    "yuyv422": (((0, 2), (1, 4), (3, 4)), "yuv422p"),
    "uyvy422": (((1, 2), (0, 4), (2, 4)), "yuv422p"),
    "yvyu422": (((0, 2), (3, 4), (1, 4)), "yuv422p"),
}
_SEMI_PLANAR = {"nv12": (0, 1), "nv21": (1, 0)}


def _unpacked(frame: av.VideoFrame) -> av.VideoFrame:
    """An 8-bit YUV frame stored packed (YUYV, UYVY) or semi-planar (NV12, NV21) as the
    same samples plane by plane (4:2:2 or 4:2:0), so that they are read as planar video
    is; any other frame as it is.

    FFmpeg's own RGB conversion of YUYV interpolates its chroma as it does 4:2:2's: a
    disc drawn at whole pixels was found 0.06-0.07 px off in x, and in NV12 0.02-0.04 px
    (:func:`_cells_of_four`)."""
    name = frame.format.name
    if name in _PACKED and frame.width % 2 == 0:
        places, planar = _PACKED[name]
        rows = _rows(frame, 0, 2 * frame.width, frame.height)
        out = av.VideoFrame(frame.width, frame.height, planar)
        for k, (first, step) in enumerate(places):
            plane_samples(out, k)[...] = rows[:, first::step]
    elif name in _SEMI_PLANAR and frame.width % 2 == 0 and frame.height % 2 == 0:
        out = av.VideoFrame(frame.width, frame.height, "yuv420p")
        plane_samples(out, 0)[...] = _rows(frame, 0, frame.width, frame.height)
        both = _rows(frame, 1, frame.width, frame.height // 2)
        for k, first in zip((1, 2), _SEMI_PLANAR[name], strict=True):
            plane_samples(out, k)[...] = both[:, first::2]
    else:
        return frame
    out.colorspace, out.color_range = frame.colorspace, frame.color_range
    return out


def _rows(frame: av.VideoFrame, k: int, width: int, height: int) -> NDArray[np.uint8]:
    """The first ``height`` rows of plane ``k`` of an 8-bit frame, ``width`` bytes each:
    a packed or interleaved plane holds more bytes a row than :func:`plane_samples`
    takes from its width in samples (YUYV two a pixel, NV12's chroma two a cell)."""
    plane = frame.planes[k]
    return np.frombuffer(plane, np.uint8).reshape(-1, plane.line_size)[:height, :width]


def _cells_of_four(frame: av.VideoFrame) -> av.VideoFrame:
    """An 8-bit 4:2:2 frame (an MJPEG webcam's, a video camera's) as 4:2:0: each chroma
    sample the mean of the two above each other, so that it covers its 2×2 cell as
    4:2:0 video's does (and as JPEG places it); any other frame as it is.

    FFmpeg's own RGB conversion of 4:2:2 interpolates the chroma about a quarter of a
    pixel to the left: a disc drawn at whole pixels was found 0.07-0.09 px off in x,
    to one side on even columns and to the other on odd ones, against 0.01-0.02 px at
    4:2:0. The tracker's colour model has 2×2 cells anyway (:func:`.disc.fit_disc_cells`)."""
    if frame.format.name not in ("yuv422p", "yuvj422p") or frame.height % 2:
        return frame
    out = av.VideoFrame(frame.width, frame.height, frame.format.name.replace("422", "420"))
    plane_samples(out, 0)[...] = plane_samples(frame, 0)
    for k in (1, 2):  # each pair of chroma rows, their rounded half-sum
        rows = plane_samples(frame, k).astype(np.uint16)
        plane_samples(out, k)[...] = (rows[0::2] + rows[1::2] + 1) >> 1
    out.colorspace, out.color_range = frame.colorspace, frame.color_range
    return out


def _turned_i420(pixels: NDArray[np.uint8], turns: int) -> NDArray[np.uint8]:
    """4:2:0 planes laid out as :class:`.video.Frame` holds them (Y, then U and V), each
    turned ``turns`` quarter turns counter-clockwise. A 2×2 cell's chroma sample
    stays with its cell: the planes turn alike."""
    if not turns % 4:
        return pixels
    w = pixels.shape[1]
    h = pixels.shape[0] * 2 // 3
    q = h // 4
    planes = (pixels[:h], pixels[h:h + q].reshape(h // 2, w // 2),
              pixels[h + q:].reshape(h // 2, w // 2))
    turned = [np.rot90(plane, turns) for plane in planes]
    return np.concatenate([t.ravel() for t in turned]).reshape(-1, turned[0].shape[1])


def upright_turns(rotation_deg: float | None) -> int:
    """Quarter turns counter-clockwise (0-3) that show a picture upright, from the
    display rotation its video file stores (PyAV's ``VideoFrame.rotation``, degrees
    counter-clockwise): what players and OpenCV's reader apply. A phone filming in
    portrait stores its pictures on their side with such a rotation. An angle that is
    not a quarter turn (none seen from a camera) is left as stored.

    >>> upright_turns(90), upright_turns(-90), upright_turns(-180), upright_turns(None)
    (1, 3, 2, 0)
    """
    if rotation_deg is None or not np.isfinite(rotation_deg):
        return 0
    turns = float(rotation_deg) / 90.0
    return round(turns) % 4 if abs(turns - round(turns)) < 1e-6 else 0


def plane_samples(frame: av.VideoFrame, k: int) -> NDArray:
    """Plane ``k`` of a planar YUV frame as a writable array of its samples (uint8, or
    uint16 for more than 8 bits), without the row padding."""
    plane = frame.planes[k]
    dtype = np.uint16 if frame.format.components[k].bits > 8 else np.uint8
    rows = np.frombuffer(plane, dtype).reshape(-1, plane.line_size // np.dtype(dtype).itemsize)
    return rows[:plane.height, :plane.width]
