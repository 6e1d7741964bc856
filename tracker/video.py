"""Reading frames one at a time, with each frame's time from the container.

Video files are read with PyAV (anything FFmpeg reads); a folder of numbered
images is read in natural order at a frame rate the user gives. Frames are
streamed, so memory does not grow with the length of the video. Times come
from the presentation timestamps, never from ``index / fps``; what the
timestamps say about the recording (variable rate, duplicated or dropped
frames) is summarised by :func:`timing_report`.
"""

from __future__ import annotations

import heapq
import os
import queue
import re
import threading
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import av
import cv2
import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..errors import CranktrackError

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")

#: A pixel aspect within this of 1 is taken as square: encoders round their ratios
#: (0.5 % is 0.3° of a crank angle at 45°, at most).
SQUARE_ENOUGH = 0.005

#: Pictures held back to put timestamps stored in decoding order back in display
#: order (3 were needed by a webcam H.264 file; H.264 allows up to 16 in theory).
REORDER_DEPTH = 8

#: Frames smaller than this (px) are decoded on one thread. The tracker reads each frame
#: beside the decoder, on the other core; a frame this small takes one core a fraction
#: of the time the tracker spends on it (the pendulum clip, 640×352: 0.2 ms against
#: 0.5 ms), and FFmpeg's own threads only take CPU from the tracker: tracking that clip
#: took 0.23-0.27 s with them, 0.19 s without; yupi's rover (700×480) 0.40-0.43 s, 0.37 s.
#: Larger frames keep FFmpeg's threads: a 1280×720 render took 0.35 s with them, 0.40 s
#: without (bench/README.md, stop 50).
ONE_DECODER_THREAD_PX = 500_000


#: FFmpeg colour-space codes and the YUV → RGB matrix (its ITU-R BT number) each names:
#: unspecified (which FFmpeg also converts as BT.601), BT.470BG and SMPTE 170M are
#: BT.601; 1 is BT.709 (HD video: phones, most cameras); 9 is BT.2020 (a phone's HDR).
_MATRICES = {2: 601, 5: 601, 6: 601, 1: 709, 9: 2020}


#: About how many pixels :meth:`Frame.light` takes the median of.
LIGHT_SAMPLES = 2000


@dataclass(frozen=True)
class Frame:
    """One decoded frame: its index in display order, time (s) and pixels.

    ``pixels`` is RGB (h, w, 3), or, for 4:2:0 video (``layout == "i420"``), the
    decoder's own planes (Y, then U and V at half size; shape (3h/2, w));
    ``full_range`` says their levels span 0–255 (JPEG levels, as phones and webcams
    that write ``yuvj420p`` store them) rather than 16–235, and ``matrix`` which
    BT recommendation's YUV → RGB matrix they are in (601, 709 or 2020). The tracker
    reads small regions on most frames, so converting them alone (:meth:`region`)
    skips most of the colour conversion a whole RGB frame costs; :attr:`rgb` converts
    the whole frame when it is needed (a full-frame search). Both use the same
    conversion (:func:`_i420_to_rgb`), so a region is exactly that part of :attr:`rgb`.

    ``full_chroma`` says whether every pixel was stored with its own colour
    (RGB, 4:4:4, PNG/TIFF/BMP images) rather than sharing it with its
    neighbours (4:2:0 or 4:2:2 video, JPEG images): the tracker reads the
    marker's edge in luminance too only then.
    """

    index: int
    t_s: float
    pixels: NDArray[np.uint8]
    layout: str = "rgb"
    full_chroma: bool = True
    full_range: bool = False
    matrix: int = 601

    @property
    def _levels(self) -> tuple[float, ...]:
        return _LEVELS[self.matrix, self.full_range]

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in px."""
        h, w = self.pixels.shape[:2]
        return (w, h * 2 // 3) if self.layout == "i420" else (w, h)

    @cached_property
    def rgb(self) -> NDArray[np.uint8]:
        """The whole frame as RGB (h, w, 3)."""
        if self.layout == "i420":
            w, h = self.size
            return _i420_to_rgb(*self._planes(), 0, 0, w, h, self._levels)
        return self.pixels

    @cached_property
    def light(self) -> NDArray[np.float64]:
        """How much light the frame holds: the median R, G and B of about
        :data:`LIGHT_SAMPLES` pixels on an even grid, DN. A camera's exposure or white
        balance or a lamp's flicker moves them; a marker crossing the frame does not.
        A prefetching reader (:meth:`FrameSource.frames`) reads it in its own thread."""
        w, h = self.size
        step = 2 * max(1, round(0.5 * np.sqrt(w * h / LIGHT_SAMPLES)))  # even: whole cells
        if self.layout == "i420":
            return _i420_light(*self._planes(), step, self._levels)
        sample = self.pixels[::step, ::step].reshape(-1, 3)
        return np.median(sample, axis=0).astype(np.float64)

    def region(self, x0: int, y0: int, x1: int, y1: int) -> NDArray[np.uint8]:
        """RGB pixels of columns x0…x1−1 and rows y0…y1−1 (inside the frame)."""
        if self.layout != "i420" or "rgb" in self.__dict__:
            return self.rgb[y0:y1, x0:x1]
        # A marker's fits read nested regions of one frame (its window, a wider one for
        # a soft disc, its middle): on yupi's rover clip 916 of 2,223 lay inside one
        # converted before. Those are cut from it (a copy: callers own their pixels).
        converted = self.__dict__.setdefault("_regions", [])
        for (a, b, c, d), rgb in converted:
            if a <= x0 and b <= y0 and x1 <= c and y1 <= d:
                return rgb[y0 - b:y1 - b, x0 - a:x1 - a].copy()
        rgb = _i420_to_rgb(*self._planes(), x0, y0, x1, y1, self._levels)
        converted.append(((x0, y0, x1, y1), rgb))
        return rgb.copy()

    def median_rgb(self, x0: int, y0: int, x1: int, y1: int) -> NDArray[np.float64]:
        """The median R, G and B (DN) of :meth:`region` (x0, y0, x1, y1), as
        ``np.median(region, axis=(0, 1))`` gives them."""
        return _channel_medians(self.region(x0, y0, x1, y1))

    def cropped(self, x0: int, y0: int, x1: int, y1: int) -> Frame:
        """The frame cut to columns x0…x1−1 and rows y0…y1−1, with its own layout.

        A 4:2:0 frame stays 4:2:0 (no colour conversion), so the cut must keep
        its chroma cells whole: x0, y0 and the width even, the height a
        multiple of 4 (:meth:`.track.Roi.inside` makes them so).
        """
        if self.layout != "i420":
            return Frame(self.index, self.t_s, np.ascontiguousarray(self.pixels[y0:y1, x0:x1]),
                         self.layout, self.full_chroma)
        if x0 % 2 or y0 % 2 or (x1 - x0) % 2 or (y1 - y0) % 4:
            raise ValueError("a 4:2:0 frame is cut at even columns and rows, with a height "
                             "that is a multiple of 4")
        Y, U, V = self._planes()
        u = U[y0 // 2:y1 // 2, x0 // 2:x1 // 2]
        v = V[y0 // 2:y1 // 2, x0 // 2:x1 // 2]
        planes = np.concatenate([Y[y0:y1, x0:x1].ravel(), u.ravel(), v.ravel()])
        return Frame(self.index, self.t_s, planes.reshape(-1, x1 - x0), self.layout,
                     self.full_chroma, self.full_range, self.matrix)

    def _planes(self) -> tuple[NDArray, NDArray, NDArray]:
        w, h = self.size
        q = h // 4
        return (self.pixels[:h], self.pixels[h:h + q].reshape(h // 2, w // 2),
                self.pixels[h + q:].reshape(h // 2, w // 2))


#: YUV → RGB by (matrix, full range): luma gain, black level, and the chroma terms (R
#: from V, G from U and V, B from U), in video range (16–235) and in JPEG's full range
#: (ITU-T T.871). With Kr, Kb of the matrix (0.299, 0.114 for BT.601; 0.2126, 0.0722
#: for BT.709; 0.2627, 0.0593 for BT.2020) they are 2(1 − Kr), 2Kb(1 − Kb)/Kg,
#: 2Kr(1 − Kr)/Kg and 2(1 − Kb), times 255/224 in video range.
_LEVELS = {
    (601, False): (1.164383, 16.0, 1.596027, 0.391762, 0.812968, 2.017232),
    (601, True): (1.0, 0.0, 1.402, 0.344136, 0.714136, 1.772),
    (709, False): (1.164383, 16.0, 1.792741, 0.213249, 0.532909, 2.112402),
    (709, True): (1.0, 0.0, 1.5748, 0.187324, 0.468124, 1.8556),
    (2020, False): (1.164383, 16.0, 1.678674, 0.187326, 0.650424, 2.141772),
    (2020, True): (1.0, 0.0, 1.4746, 0.164553, 0.571353, 1.8814),
}


@njit(cache=True, nogil=True, inline="always")
def _yuv_to_rgb(y: int, u: int, v: int, levels: tuple) -> tuple[float, float, float]:
    """One pixel's BT.601 Y, U, V codes → R, G, B (DN, unrounded, unclamped) in
    ``levels`` (one of :data:`_LEVELS`)."""
    gain, black, rv, gu, gv, bu = levels
    luma = gain * (y - black)
    cb, cr = u - 128.0, v - 128.0
    return luma + rv * cr, luma - gu * cb - gv * cr, luma + bu * cb


@njit(cache=True, nogil=True)
def _i420_to_rgb(Y: NDArray, U: NDArray, V: NDArray, x0: int, y0: int, x1: int, y1: int,
                 levels: tuple = _LEVELS[601, False]) -> NDArray:
    """YUV 4:2:0 → RGB for a region, with one of :data:`_LEVELS` (a matrix, in limited
    (16–235) or full range (0–255)).

    Each chroma sample covers its 2×2 luma cell, as in FFmpeg's fast RGB
    path that the tracker was designed and measured on (the standard BT.601
    coefficients here differ from its fixed-point ones by up to 3 DN; in full
    range they come out 0 to +2 DN above FFmpeg's, on yupi's rover clip).
    Bilinear chroma upsampling was tried: on the H.264 reference render it
    moved the centre errors by −10 to +30 % and made the fit's residual so
    smooth that the reported σ fell to a third of the error.
    """
    out = np.empty((y1 - y0, x1 - x0, 3), np.uint8)
    for i in range(y0, y1):
        for j in range(x0, x1):
            r, g, b = _yuv_to_rgb(Y[i, j], U[i // 2, j // 2], V[i // 2, j // 2], levels)
            # Rounded by adding ½ and truncating the clamped value: 3.5× faster on a
            # whole 640×480 frame than round() (a whole frame for every full-frame
            # search), and the same bytes (a sum of these products is never exactly
            # half an integer).
            r, g, b = r + 0.5, g + 0.5, b + 0.5
            out[i - y0, j - x0, 0] = np.uint8(min(max(r, 0.0), 255.0))
            out[i - y0, j - x0, 1] = np.uint8(min(max(g, 0.0), 255.0))
            out[i - y0, j - x0, 2] = np.uint8(min(max(b, 0.0), 255.0))
    return out


@njit(cache=True, nogil=True)
def _i420_light(Y: NDArray, U: NDArray, V: NDArray, step: int, levels: tuple) -> NDArray:
    """:meth:`Frame.light` of 4:2:0 planes: the median R, G and B of the pixels at every
    ``step``-th row and column (even), converted as :func:`_i420_to_rgb` converts them
    (unrounded). Compiled: on a 1080p frame beside the decoder's threads the same in
    numpy took 0.4 ms."""
    rows, cols = (Y.shape[0] + step - 1) // step, (Y.shape[1] + step - 1) // step
    r, g, b = np.empty(rows * cols), np.empty(rows * cols), np.empty(rows * cols)
    n = 0
    for i in range(0, Y.shape[0], step):
        for j in range(0, Y.shape[1], step):
            r[n], g[n], b[n] = _yuv_to_rgb(Y[i, j], U[i // 2, j // 2], V[i // 2, j // 2],
                                           levels)
            n += 1
    out = np.empty(3)
    out[0], out[1], out[2] = np.median(r[:n]), np.median(g[:n]), np.median(b[:n])
    return np.minimum(np.maximum(out, 0.0), 255.0)


@njit(cache=True, nogil=True)
def _channel_medians(rgb: NDArray) -> NDArray:
    """Per channel, the median of an (h, w, 3) array (float64; the mean of the middle
    two for an even count). Compiled: ``np.median`` along an axis costs ~20 µs of
    overhead, and it runs for every marker found in every frame."""
    n = rgb.shape[0] * rgb.shape[1]
    out = np.empty(3)
    values = np.empty(n)
    for c in range(3):
        k = 0
        for i in range(rgb.shape[0]):
            for j in range(rgb.shape[1]):
                values[k] = rgb[i, j, c]
                k += 1
        out[c] = np.median(values)
    return out


def _frame_pixels(frame: av.VideoFrame, turns: int = 0
                  ) -> tuple[NDArray[np.uint8], str, bool, bool, int]:
    """The decoder's planes when they can be converted region by region, else RGB,
    turned ``turns`` quarter turns counter-clockwise (upright, :func:`upright_turns`);
    whether the chroma is stored at full resolution (:attr:`Frame.full_chroma`);
    whether 4:2:0 planes are in full range (:attr:`Frame.full_range`), and their
    matrix (:attr:`Frame.matrix`)."""
    full = all(c.width == frame.width and c.height == frame.height
               for c in frame.format.components)
    frame = _cells_of_four(_eight_bit(frame))
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
    for src, dst in zip(frame.planes, out.planes, strict=True):
        codes = np.frombuffer(src, np.uint16).reshape(-1, src.line_size // 2)
        into = np.frombuffer(dst, np.uint8).reshape(-1, dst.line_size)
        h, w = dst.height, dst.width
        into[:h, :w] = np.minimum((codes[:h, :w].astype(np.uint32) + (1 << (shift - 1)))
                                  >> shift, 255)
    out.colorspace, out.color_range = frame.colorspace, frame.color_range
    return out


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
    for k, (src, dst) in enumerate(zip(frame.planes, out.planes, strict=True)):
        rows = np.frombuffer(src, np.uint8).reshape(-1, src.line_size)[:src.height, :src.width]
        into = np.frombuffer(dst, np.uint8).reshape(-1, dst.line_size)
        if k == 0:
            into[:dst.height, :dst.width] = rows
        else:  # rounded half-sum of each pair of rows
            pair = rows[0::2].astype(np.uint16) + rows[1::2]
            into[:dst.height, :dst.width] = (pair + 1) >> 1
    out.colorspace, out.color_range = frame.colorspace, frame.color_range
    return out


def _turned_i420(pixels: NDArray[np.uint8], turns: int) -> NDArray[np.uint8]:
    """4:2:0 planes laid out as :class:`Frame` holds them (Y, then U and V), each
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


def _the_video(container: av.container.InputContainer) -> av.VideoStream:
    """The video stream players show: FFmpeg's choice of the best one, not a cover
    picture or a preview that comes first in the file (a clip with its cover picture as
    stream 0 was tracked as one still frame)."""
    return container.streams.best("video")


#: Where a phone's camera writes the rate its frames were taken at, when it stores them
#: to play at another (Android: slow motion and time-lapse).
_TAKEN_FPS_TAGS = ("com.android.capture.fps",)


def _said_taken_fps(container: av.container.InputContainer, stream: av.VideoStream
                    ) -> float | None:
    """The rate (frames per second) the file says its frames were taken at, if it says."""
    for tags in (container.metadata, stream.metadata):
        for key in _TAKEN_FPS_TAGS:
            try:
                value = float(tags.get(key, "nan"))
            except ValueError:
                continue
            if np.isfinite(value) and value > 0:
                return value
    return None


def taking_scale(plays_fps: float | None, given_fps: float | None, said_fps: float | None
                 ) -> tuple[float, str | None]:
    """Seconds of the taking per second of a video's own clock, and what to tell the user.

    ``plays_fps`` is the rate the file plays its frames at; ``given_fps`` the rate the
    user says they were taken at (``--fps``), ``said_fps`` the rate the file says
    (:data:`_TAKEN_FPS_TAGS`). A phone's slow motion, taken at 240 frames a second and
    stored to play at 30, moves 8 times too slowly on the file's clock, and every speed
    measured on it is 8 times too small. Rates within 0.5 % of each other are the same
    (29.97 and 30: NTSC's rate and its name).

    >>> taking_scale(30.0, None, 240.0)[0], taking_scale(30.0, 120.0, 240.0)[0]
    (0.125, 0.25)
    >>> taking_scale(29.97, 30.0, None)
    (1.0, None)

    Raises
    ------
    CranktrackError
        A rate is given for a video that has none of its own.
    """
    taken = given_fps or said_fps
    if taken is None or (plays_fps and abs(taken / plays_fps - 1.0) <= 0.005):
        return 1.0, None
    if not plays_fps:
        raise CranktrackError(f"--fps {taken:g} cannot be applied: the video gives no frame "
                              "rate of its own to scale its times from")
    if given_fps:
        why = f"taken at {given_fps:g} frames a second (--fps)"
    else:
        why = (f"the file says its frames were taken at {said_fps:g} a second (slow motion "
               f"or time-lapse); give --fps {plays_fps:g} to keep its own times")
    return plays_fps / taken, (
        f"the video plays its frames at {plays_fps:g} a second; its times are scaled by "
        f"{plays_fps / taken:.4g} to those of the taking, {why}")


#: Frames :func:`field_order` looks at: two seconds at 30 frames a second.
FIELD_ORDER_FRAMES = 60


def field_order(path: Path, most: int = FIELD_ORDER_FRAMES) -> str | None:
    """What the first ``most`` frames of a video flagged interlaced show, by FFmpeg's
    ``idet`` (it compares each frame's lines with its fields taken either way): "tff"
    or "bff" (the top or bottom field taken first), "progressive" (both fields one
    instant: progressive segmented frames, which some cameras write flagged
    interlaced), or None where nothing moved enough to tell."""
    votes = {"tff": 0, "bff": 0, "progressive": 0}
    with av.open(str(path), metadata_errors="replace") as container:
        stream = _the_video(container)
        graph = av.filter.Graph()
        source = graph.add_buffer(template=stream)
        detect = graph.add("idet")
        sink = graph.add("buffersink")
        source.link_to(detect)
        detect.link_to(sink)
        graph.configure()
        try:
            for k, frame in enumerate(container.decode(stream)):
                if k == most:
                    break
                graph.push(frame)
                while True:
                    try:
                        said = graph.pull().metadata.get("lavfi.idet.multiple.current_frame")
                    except (av.BlockingIOError, av.EOFError):
                        break
                    if said in votes:
                        votes[said] += 1
        except av.FFmpegError:
            pass  # a damaged file: what was seen up to there
    best = max(votes, key=votes.get)
    return best if votes[best] > 0 else None


def _interlacing(path: Path, flagged: bool) -> tuple[str, str | None]:
    """For a video whose first picture is ``flagged`` interlaced: which field to take
    first ("tff", "bff", "auto": as the file says) or "progressive", from what its
    pictures show (:func:`field_order`), and what to tell the user where that is not
    what the file says."""
    if not flagged:
        return "auto", None
    shown = field_order(path)
    if shown == "progressive":
        return shown, ("the file says its frames are interlaced, but in its first frames "
                       "both fields show one instant (progressive segmented frames): they "
                       "are tracked whole")
    if shown is None:
        return "auto", ("the file says its frames are interlaced; too little moves in its "
                        f"first {FIELD_ORDER_FRAMES} frames to check which field was taken "
                        "first, so the file's word is taken")
    return shown, None


def _first_picture(container: av.container.InputContainer, stream: av.VideoStream
                   ) -> tuple[float | None, bool]:
    """The display rotation (degrees counter-clockwise, None where none is stored) of
    the stream's first picture, and whether it is interlaced (False where no picture
    can be decoded)."""
    try:
        for packet in container.demux(stream):
            for frame in packet.decode():
                return frame.rotation, bool(frame.interlaced_frame)
    except av.FFmpegError:
        pass
    return None, False


class _Fields:
    """An interlaced video's fields as frames of their own, at twice its frame rate:
    FFmpeg's ``bwdif`` deinterlacer (motion-adaptive; each field's missing lines taken
    from its neighbours in space and time), as players show such video. Read as
    stored, a frame holds two fields taken half a frame apart: a disc moving 4 px a
    field was found 2 px off where it was at the frame's time, with a σ of 0.15 px."""

    def __init__(self, stream: av.VideoStream, first: str = "auto") -> None:
        self._graph = av.filter.Graph()
        source = self._graph.add_buffer(template=stream)
        # send_field: one frame per field; deint=interlaced: frames flagged progressive
        # (a clip that mixes them) pass as they are; parity: which field came first.
        bwdif = self._graph.add("bwdif", f"mode=send_field:parity={first}:deint=interlaced")
        sink = self._graph.add("buffersink")
        source.link_to(bwdif)
        bwdif.link_to(sink)
        self._graph.configure()
        # The luma of the last stored frames: a field is told by the lines kept from one.
        self._stored: deque[NDArray] = deque(maxlen=3)

    def split(self, frames: list) -> list[av.VideoFrame]:
        """The fields that ``frames`` (decoded pictures; ``[None]`` at the end) complete."""
        out = []
        for frame in frames:
            if frame is not None:
                self._stored.append(_plane(frame, 0).copy())
            self._graph.push(frame)
            while True:
                try:
                    out.append(self._sited(self._graph.pull()))
                except (av.BlockingIOError, av.EOFError):
                    break
        return out

    def _sited(self, field: av.VideoFrame) -> av.VideoFrame:
        """A 4:2:0 field with its colour moved to where a frame's 2×2 cells hold it.

        Interlaced 4:2:0 codes each field's colour from the field's own lines, so a
        chroma line of the top field lies half a frame line below the two lines whose
        cell it fills as a frame, and one of the bottom field half a line above: a disc
        came out 0.45 px off in y, up in top fields and down in bottom ones. The field
        is told by the lines ``bwdif`` kept as they were; the colour is moved by a
        quarter of a chroma line (linear interpolation). A field whose kept lines match
        both (a still picture) is left as it is: there the two fields' errors cancel."""
        if not field.format.name.startswith(("yuv420p", "yuvj420p")):
            return field
        luma = _plane(field, 0)
        kept = {parity for stored in self._stored for parity in (0, 1)
                if np.array_equal(luma[parity::2], stored[parity::2])}
        if len(kept) != 1:
            return field
        step = -1 if kept.pop() == 0 else 1  # the neighbour a quarter line takes from
        field.make_writable()
        for k in (1, 2):
            chroma = _plane(field, k)
            c = chroma.astype(np.float32)
            neighbour = np.roll(c, -step, axis=0)
            neighbour[0 if step < 0 else -1] = c[0 if step < 0 else -1]  # the edge line
            chroma[...] = np.rint(0.75 * c + 0.25 * neighbour).astype(chroma.dtype)
        return field


def _plane(frame: av.VideoFrame, k: int) -> NDArray:
    """Plane ``k`` of a planar YUV frame as a writable array of its samples (uint8, or
    uint16 for more than 8 bits), without the row padding."""
    plane = frame.planes[k]
    dtype = np.uint16 if frame.format.components[k].bits > 8 else np.uint8
    rows = np.frombuffer(plane, dtype).reshape(-1, plane.line_size // np.dtype(dtype).itemsize)
    return rows[:plane.height, :plane.width]


@dataclass
class FrameSource:
    """An opened video file or image folder.

    Iterate :meth:`frames` once. Problems met while decoding (a corrupt
    packet that was skipped) are appended to ``problems`` as sentences.
    """

    path: Path
    kind: str  # "video" or "images"
    width: int
    height: int
    nominal_fps: float | None
    expected_frames: int | None
    codec: str
    problems: list[str] = field(default_factory=list)
    duration_s: float | None = None  # the container's, to tell a truncated file
    #: Quarter turns counter-clockwise that bring the stored pictures upright (a phone's
    #: portrait video is stored on its side with a display rotation, :func:`upright_turns`);
    #: ``width`` and ``height`` are the upright frame's.
    quarter_turns: int = 0
    #: How many times as wide as high a pixel is shown (the sample aspect ratio of the
    #: upright frame; DV and HDV camcorders store 16:15, 4:3 and the like). Positions
    #: stay in stored pixels; lengths take this into account (:mod:`.calibration`).
    pixel_aspect: float = 1.0
    #: The video is interlaced: each stored frame holds two fields taken half a frame
    #: apart, and each field is read as a frame of its own (:class:`_Fields`), at
    #: twice the stored rate (``nominal_fps`` and ``expected_frames`` are the fields').
    fields: bool = False
    #: Which field of an interlaced frame was taken first, as its pictures show it
    #: (:func:`field_order`): "tff" (top), "bff" (bottom), or "auto" (as the file says).
    first_field: str = "auto"
    #: Seconds of the taking per second of the file's own clock: 1/8 for a phone's slow
    #: motion taken at 240 frames a second and stored to play at 30 (:func:`taking_scale`).
    time_scale: float = 1.0
    #: Bits a sample of a folder's pictures hold (8, or 10-16 in 16-bit files), from
    #: the first (:func:`sample_bits`); they are read scaled from that depth to 8 bits.
    sample_bits: int = 8
    _images: list[Path] = field(default_factory=list, repr=False)

    def frames(self, prefetch: int = 0) -> Iterator[Frame]:
        """Yield frames in display order (see ``REORDER_DEPTH``).

        With ``prefetch > 0`` a background thread decodes up to that many
        frames ahead, so decoding overlaps whatever the caller does with each
        frame (FFmpeg and OpenCV release the GIL while they work), and reads
        each frame's :attr:`Frame.light` there too. Memory stays bounded by the queue.
        """
        inner = self._image_frames() if self.kind == "images" else self._video_frames()
        if prefetch <= 0:
            yield from inner
            return
        yield from _prefetched(inner, prefetch)

    def _video_frames(self) -> Iterator[Frame]:
        skipped: list[int] = []  # frame index after which a corrupt packet was dropped
        index = 0
        missing_pts = False
        reordered = 0
        # The decoder hands pictures over in display order, but a container that
        # stores B-frames without composition offsets (pts = dts, as some webcam and
        # phone muxers write) leaves each picture with another one's timestamp. The
        # times are right as a set, so each picture takes the earliest time among
        # it and the next REORDER_DEPTH pictures; in a well-made file that is its own.
        pending: deque[tuple] = deque()
        times: list[float] = []
        first_t, last_t = float("nan"), float("nan")

        def take(frame: av.VideoFrame) -> bool:
            """Hold a decoded picture with its time; whether it had none of its own."""
            t = frame.time
            if t is not None:
                t_s = float(t) * self.time_scale
            else:
                n = index + len(pending)
                t_s = n / self.nominal_fps if self.nominal_fps else float(n)
            pending.append((t_s, _frame_pixels(frame, self.quarter_turns)))
            heapq.heappush(times, t_s)
            return t is None

        def emit() -> Frame:
            nonlocal index, reordered, first_t, last_t
            own, pixels = pending.popleft()
            t = heapq.heappop(times)
            reordered += t != own
            first_t = t if index == 0 else first_t
            last_t = t
            index += 1
            return Frame(index - 1, t, *pixels)

        with av.open(str(self.path), metadata_errors="replace") as container:
            stream = _the_video(container)
            stream.thread_type = "AUTO"  # frame-threaded decoding; order is kept
            if self.width * self.height < ONE_DECODER_THREAD_PX:
                stream.codec_context.thread_count = 1
            fields = _Fields(stream, self.first_field) if self.fields else None
            packets = container.demux(stream)
            while True:
                try:
                    packet = next(packets)
                except StopIteration:
                    break
                except av.FFmpegError as e:
                    self.problems.append(f"reading stopped after frame {index + len(pending) - 1}"
                                         f": the file is damaged from there on ({e.strerror})")
                    break
                try:
                    decoded = packet.decode()
                except av.FFmpegError:
                    skipped.append(index + len(pending) - 1)
                    continue
                for frame in decoded if fields is None else fields.split(decoded):
                    missing_pts |= take(frame)
                    if len(pending) > REORDER_DEPTH:
                        yield emit()
            for frame in [] if fields is None else fields.split([None]):  # the last fields
                missing_pts |= take(frame)
            while pending:
                yield emit()
        if skipped:
            where = ", ".join(str(k) for k in sorted(set(skipped))[:10])
            self.problems.append(f"{len(skipped)} corrupt packet(s) were skipped (after frame(s) "
                                 f"{where}{', …' if len(set(skipped)) > 10 else ''}); the "
                                 "frames they held are missing from the tracks")
        if missing_pts:
            self.problems.append("the container has no timestamps for some frames; those use "
                                 "index / nominal fps")
        if reordered:
            self.problems.append(
                f"the container's timestamps are in decoding order, not display order "
                f"({reordered} of {index} frames carried another frame's time): each frame "
                "was given the times in display order")
        if self.expected_frames and index + len(set(skipped)) < self.expected_frames:
            # The container's duration runs to the end of the last picture's interval.
            # A file cut short keeps its header's frame count, but FFmpeg may take its
            # duration from the pictures left (OpenCV's vtest.avi cut to 2 MB: 795
            # frames listed at 10 fps, a "duration" of 19.6 s): the listed frames must
            # fit in the duration for the pictures to be a sparse file's.
            step = 1.0 / self.nominal_fps if self.nominal_fps else 0.0
            listed_s = self.expected_frames * step
            if self.duration_s and last_t - first_t >= self.duration_s - 3.0 * step - 1e-6 \
                    and listed_s <= self.duration_s + 3.0 * step + 1e-6:
                self.problems.append(
                    f"the container lists {self.expected_frames} frames but holds {index} "
                    f"pictures, spread over its whole {self.duration_s:.3g} s (not cut short):"
                    " a listed frame without a picture of its own repeats the one before, and "
                    "each picture keeps its own time, so any gap shows in the timing")
            else:
                self.problems.append(
                    f"the video ends after frame {index - 1} although its index lists "
                    f"{self.expected_frames} frames: it is truncated or damaged; the tracks "
                    "up to there are kept")

    def _image_frames(self) -> Iterator[Frame]:
        fps = self.nominal_fps or 1.0
        for index, p in enumerate(self._images):
            rgb = read_picture(p, self.sample_bits)
            if rgb is None:
                self.problems.append(f"{p.name} could not be read as an image and was skipped")
                continue
            if rgb.shape[1::-1] != (self.width, self.height):
                # A picture of another size is not a frame of this clip: its pixels
                # would put the markers somewhere else in the plane.
                self.problems.append(
                    f"{p.name} is {rgb.shape[1]}×{rgb.shape[0]} px, not {self.width}×"
                    f"{self.height} like the folder's first picture, and was skipped")
                continue
            # JPEG stores colour at half resolution (almost always): no luminance edges.
            yield Frame(index, index / fps, rgb,
                        full_chroma=p.suffix.lower() not in (".jpg", ".jpeg"))


#: How pictures are read: 16-bit samples kept (OpenCV's plain colour reading divides
#: them by 256), as three channels, turned upright as their EXIF says.
_PICTURE_FLAGS = cv2.IMREAD_ANYDEPTH | cv2.IMREAD_COLOR


def sample_bits(raw: NDArray) -> int:
    """The bits a sample of a picture read with :data:`_PICTURE_FLAGS` holds:
    8 for 8-bit files; for 16-bit ones the least of 10, 12, 14 and 16 that holds its
    brightest sample. Scientific and high-speed cameras write 10- or 12-bit samples in
    16-bit TIFF and PNG; read as 16 bits (OpenCV's 8-bit reading divides by 256),
    a 12-bit picture's white is 16 DN of 255, and nothing in it was found.

    >>> import numpy as np
    >>> sample_bits(np.array([[3800]], np.uint16)), sample_bits(np.array([[9]], np.uint8))
    (12, 8)
    """
    if raw.dtype != np.uint16:
        return 8
    top = int(raw.max())
    return next(b for b in (10, 12, 14, 16) if top < 1 << b)


def read_picture(path: Path, bits: int = 8) -> NDArray[np.uint8] | None:
    """A picture file as 8-bit RGB (h, w, 3), its samples scaled from ``bits`` bits
    (:func:`sample_bits`) and rounded, a brighter one clipped (grey pictures as three
    equal channels, turned as their EXIF says). None where OpenCV cannot read it."""
    raw = cv2.imread(str(path), _PICTURE_FLAGS)
    if raw is None or raw.dtype not in (np.uint8, np.uint16):
        return None
    if raw.dtype == np.uint16:
        shift = bits - 8
        raw = np.minimum((raw.astype(np.uint32) + (1 << (shift - 1) if shift else 0)) >> shift,
                         255).astype(np.uint8)
    return cv2.cvtColor(raw, cv2.COLOR_BGR2RGB)


def _prefetched(frames: Iterator[Frame], depth: int) -> Iterator[Frame]:
    """Run ``frames`` in a daemon thread, handing over through a bounded queue."""
    q: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()
    done = object()

    def work() -> None:
        try:
            for f in frames:
                # The tracker reads every frame's light; read here, it overlaps the
                # tracking of the frame before (compiled without the GIL).
                f.light  # noqa: B018
                while not stop.is_set():
                    try:
                        q.put(f, timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
            q.put(done)
        except BaseException as e:  # hand decoder errors to the consumer
            q.put(e)

    thread = threading.Thread(target=work, name="cranktrack-decode", daemon=True)
    thread.start()
    try:
        while True:
            item = q.get()
            if item is done:
                return
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:
        stop.set()
        thread.join(timeout=5)


def _natural_key(p: Path) -> list:
    return [int(s) if s.isdigit() else s.lower() for s in re.split(r"(\d+)", p.name)]


def _numbering(p: Path) -> str:
    """A picture's name in lower case with each run of digits as ``#``: the pictures of
    one numbered sequence share it (``frame#.png``)."""
    return re.sub(r"\d+", "#", p.name.lower())


def numbered_pictures(folder: Path) -> tuple[list[Path], list[Path]]:
    """The frames of a folder of pictures, in natural order, and the other pictures in it.

    The frames are the pictures numbered alike (:func:`_numbering`); a picture named
    otherwise (a thumbnail, ``inspect``'s PNG of one of the frames) is left out: taken
    as a frame, it would put a wrong picture, or one of another size, in the clip.
    Where no two pictures are numbered alike, all are frames, in name order. Two
    numbered sequences in one folder (two cameras' pictures) are refused, since
    interleaved by name they would make no clip.

    Raises
    ------
    CranktrackError
        The folder holds more than one numbered sequence.
    """
    pictures = sorted((q for q in folder.iterdir() if q.suffix.lower() in IMAGE_SUFFIXES),
                      key=_natural_key)
    groups: dict[str, list[Path]] = {}
    for q in pictures:
        groups.setdefault(_numbering(q), []).append(q)
    sequences = [g for key, g in groups.items() if "#" in key and len(g) >= 2]
    if not sequences:
        return pictures, []
    if len(sequences) > 1:
        listed = ", ".join(f"{g[0].name} … ({len(g)} pictures)" for g in sequences[:3])
        raise CranktrackError(
            f"{folder} holds {len(sequences)} numbered sequences of pictures ({listed}); "
            "put each in a folder of its own")
    frames = sequences[0]
    taken = set(frames)
    return frames, [q for q in pictures if q not in taken]


def sequence_of(picture: Path) -> int | None:
    """How many pictures in ``picture``'s folder are numbered like it
    (:func:`_numbering`), itself included, where it is one of such a sequence (two or
    more); None for a video file or a picture on its own."""
    if picture.suffix.lower() not in IMAGE_SUFFIXES or not picture.is_file():
        return None
    key = _numbering(picture)
    if "#" not in key:
        return None
    n = sum(1 for q in picture.parent.iterdir()
            if q.suffix.lower() in IMAGE_SUFFIXES and _numbering(q) == key)
    return n if n >= 2 else None


def open_frames(path: str | os.PathLike, fps: float | None = None,
                one_picture: bool = False) -> FrameSource:
    """Open a video file or a folder of numbered images.

    Parameters
    ----------
    path : path-like
        A video file FFmpeg can read, or a folder of images
        (:func:`numbered_pictures` says which of them are its frames).
    fps : float, optional
        The rate the frames were taken at (frames per second): an image folder's (which
        carries no timestamps), or a video's where it plays them at another rate (slow
        motion, time-lapse): its own timestamps are then scaled to it
        (:func:`taking_scale`).
    one_picture : bool
        Open a single picture that is one of a numbered sequence (:func:`sequence_of`)
        as a clip of one frame, as ``inspect`` does. Without it that is refused:
        tracked alone, one frame of a clip gives no motion.

    Raises
    ------
    CranktrackError
        The path is missing, empty, or not a readable video or image folder.
    """
    p = Path(path)
    if not p.exists():
        raise CranktrackError(f"{p} does not exist; check the path")
    if p.is_dir():
        images, left_out = numbered_pictures(p)
        if not images:
            raise CranktrackError(
                f"{p} is a folder with no images in it; give a video file or a folder of "
                f"numbered {'/'.join(s[1:] for s in IMAGE_SUFFIXES)} images")
        if fps is None:
            raise CranktrackError(
                f"{p} is a folder of images, which carry no timestamps; give its frame rate "
                "with --fps")
        first = cv2.imread(str(images[0]), _PICTURE_FLAGS)
        if first is None:
            raise CranktrackError(f"{images[0]} is not an image OpenCV can read")
        h, w = first.shape[:2]
        bits = sample_bits(first)
        source = FrameSource(p, "images", w, h, float(fps), len(images), "images",
                             sample_bits=bits, _images=images)
        if bits > 8:
            source.problems.append(
                f"the pictures are 16-bit files holding {bits}-bit samples (the first's "
                f"brightest is {int(first.max())}); they are read scaled from {bits} bits "
                "to 8")
        if left_out:
            shown = ", ".join(q.name for q in left_out[:3]) + (", …" if len(left_out) > 3
                                                               else "")
            source.problems.append(
                f"{len(left_out)} other picture(s) in the folder are not numbered like its "
                f"{len(images)} frames and were left out ({shown})")
        return source
    if not one_picture and (sequence := sequence_of(p)) is not None:
        raise CranktrackError(
            f"{p.name} is one of {sequence} numbered pictures in {p.parent}; to use them "
            "as a clip, give the folder and its frame rate (--fps)")
    if p.stat().st_size == 0:
        raise CranktrackError(f"{p} is empty (0 bytes); it is not a video")
    try:
        # A damaged metadata tag (not valid UTF-8) must not stop the frames being read.
        with av.open(str(p), metadata_errors="replace") as container:
            if not container.streams.video:
                raise CranktrackError(f"{p} has no video stream")
            s = _the_video(container)
            rate = float(s.average_rate) if s.average_rate else None
            if s.duration and s.time_base:
                duration = float(s.duration * s.time_base)
            else:
                duration = container.duration / av.time_base if container.duration else None
            codec = s.codec_context
            if codec is None or not codec.width or not codec.height:
                # A damaged stream header: FFmpeg opens the file but knows no decoder or size.
                raise CranktrackError(f"{p} has a damaged video stream header (no decoder or "
                                      "frame size in it); it cannot be read")
            scale, taken = taking_scale(rate, fps, _said_taken_fps(container, s))
            rotation, interlaced = _first_picture(container, s)
            turns = upright_turns(rotation)
            w, h = (codec.height, codec.width) if turns % 2 else (codec.width, codec.height)
            sar = s.sample_aspect_ratio or codec.sample_aspect_ratio
            aspect = float(sar) if sar and sar > 0 else 1.0
            aspect = 1.0 / aspect if turns % 2 else aspect
            first_field, order_note = _interlacing(p, interlaced)
            interlaced = interlaced and first_field != "progressive"
            per_frame = 2 if interlaced else 1  # an interlaced frame's fields are frames
            source = FrameSource(p, "video", w, h, rate and per_frame * rate / scale,
                                 (s.frames or 0) * per_frame or None, codec.name,
                                 duration_s=duration and duration * scale, quarter_turns=turns,
                                 pixel_aspect=aspect, fields=interlaced, time_scale=scale,
                                 first_field=first_field if interlaced else "auto")
            if order_note:
                source.problems.append(order_note)
            if taken is not None:
                source.problems.append(taken)
            if len(container.streams.video) > 1:
                source.problems.append(
                    f"the file holds {len(container.streams.video)} video streams; the one "
                    f"tracked is stream {s.index} ({codec.name}, {codec.width}×{codec.height}),"
                    " the one players show (a cover picture or a preview is not it)")
            if interlaced:
                source.problems.append(
                    f"the video is interlaced: each of its frames holds two fields taken "
                    f"{500 * scale / rate if rate else float('nan'):.3g} ms apart; each field "
                    f"is tracked as a frame of its own, "
                    f"{2 * rate / scale if rate else float('nan'):g} a second, its missing "
                    "lines filled in as players fill them (FFmpeg's bwdif)")
            if abs(aspect - 1.0) > SQUARE_ENOUGH:
                source.problems.append(
                    f"the file says its pixels are shown {aspect:.4g} times as wide as high "
                    f"(sample aspect ratio {sar.numerator}:{sar.denominator}, as DV and HDV "
                    "camcorders store them): tracks.csv stays in its stored pixels, and "
                    "lengths, angles and speeds are made with the pixels that wide")
            if turns:
                turn = ("a quarter turn counter-clockwise", "half a turn",
                        "a quarter turn clockwise")[turns - 1]
                source.problems.append(
                    f"the file says to show its pictures turned {turn} (a phone stores them "
                    f"as its sensor saw them); they are tracked so, upright as players show "
                    f"them, {w}×{h} px")
            return source
    except av.FFmpegError as e:
        raise CranktrackError(
            f"{p} is not a video FFmpeg can read ({e.strerror}); if it is a recording that "
            "was cut short, its index may be missing (MP4 writes it last)") from e


def timing_report(t_s: NDArray[np.float64], nominal_fps: float | None = None) -> dict:
    """What the frame times say about the recording.

    Returns a JSON-ready dict: median frame interval and rate, whether the
    rate is variable (intervals spread by more than 1 % and by more than two
    steps of the timestamps' own resolution, so that a constant rate stored
    in whole milliseconds — 33, 33, 34 ms — is not called variable), the
    number of duplicated timestamps, of non-increasing steps, and of gaps
    longer than 1.5 median intervals with the frames they are estimated to
    have dropped.
    """
    t = np.asarray(t_s, dtype=float)
    out: dict = {"frames": int(t.size), "nominal_fps": nominal_fps}
    if t.size < 2:
        return out
    dt = np.diff(t)
    positive = dt[dt > 0]
    med = float(np.median(positive)) if positive.size else float("nan")
    gaps = dt > 1.5 * med
    # The resolution: the smallest step between the distinct lengths of the
    # intervals near the median (a gap's length says nothing about it).
    distinct = np.unique(np.round(positive[np.abs(positive - med) < 0.25 * med], 9))
    resolution = float(np.min(np.diff(distinct))) if distinct.size > 1 else 0.0
    spread = float(positive.max() - positive.min()) if positive.size else 0.0
    out.update(
        duration_s=float(t[-1] - t[0]),
        median_interval_s=med,
        median_fps=1.0 / med if med > 0 else None,
        variable_rate=bool(spread > max(0.01 * med, 2.0 * resolution + 1e-9)),
        timestamp_resolution_s=resolution,
        duplicated_timestamps=int(np.sum(dt == 0)),
        backward_steps=int(np.sum(dt < 0)),
        gaps=int(gaps.sum()),
        dropped_frames_estimate=int(np.sum(np.rint(dt[gaps] / med) - 1)),
    )
    return out
