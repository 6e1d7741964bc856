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
import math
import os
import queue
import threading
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property
from pathlib import Path

import av
import cv2
import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..errors import CranktrackError
from .fields import Fields, interlacing
from .pictures import (
    IMAGE_SUFFIXES,
    PICTURE_FLAGS,
    holds_colour,
    numbered_pictures,
    picture_channels,
    picture_rgb,
    read_picture,
    sample_bits,
    sequence_of,
)
from .planes import frame_pixels, upright_turns

#: A pixel aspect within this of 1 is not said (it is still used): encoders round their
#: ratios, and 0.5 % is at most 0.15° of a crank angle.
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
    def levels(self) -> tuple[float, ...]:
        """The YUV → RGB terms of its matrix and range (one of :data:`_LEVELS`)."""
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
            return _i420_to_rgb(*self.planes(), 0, 0, w, h, self.levels)
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
            return _i420_light(*self.planes(), step, self.levels)
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
        rgb = _i420_to_rgb(*self.planes(), x0, y0, x1, y1, self.levels)
        converted.append(((x0, y0, x1, y1), rgb))
        return rgb.copy()

    def luma(self, x0: int, y0: int, x1: int, y1: int) -> NDArray[np.float32]:
        """The luminance (DN) of columns x0…x1−1 and rows y0…y1−1 (inside the frame): a
        4:2:0 frame's own Y plane, with no colour conversion; otherwise BT.601's
        weighting of R, G and B (OpenCV's RGB → grey)."""
        if self.layout == "i420":
            return self.planes()[0][y0:y1, x0:x1].astype(np.float32)
        return cv2.cvtColor(np.ascontiguousarray(self.pixels[y0:y1, x0:x1]),
                            cv2.COLOR_RGB2GRAY).astype(np.float32)

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
        Y, U, V = self.planes()
        u = U[y0 // 2:y1 // 2, x0 // 2:x1 // 2]
        v = V[y0 // 2:y1 // 2, x0 // 2:x1 // 2]
        planes = np.concatenate([Y[y0:y1, x0:x1].ravel(), u.ravel(), v.ravel()])
        return Frame(self.index, self.t_s, planes.reshape(-1, x1 - x0), self.layout,
                     self.full_chroma, self.full_range, self.matrix)

    def planes(self) -> tuple[NDArray, NDArray, NDArray]:
        """A 4:2:0 frame's Y, U and V planes (U and V at half size), as views."""
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
def yuv_to_rgb(y: float, u: int, v: int, levels: tuple) -> tuple[float, float, float]:
    """One pixel's Y, U, V codes → R, G, B (DN, unrounded, unclamped) in ``levels`` (one
    of :data:`_LEVELS`). ``y`` may be a mean of several pixels' (:mod:`.binned`)."""
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
            r, g, b = yuv_to_rgb(Y[i, j], U[i // 2, j // 2], V[i // 2, j // 2], levels)
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
            r[n], g[n], b[n] = yuv_to_rgb(Y[i, j], U[i // 2, j // 2], V[i // 2, j // 2],
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
    measured on it is 8 times too small. Rates within 5 % of each other are the same: a
    phone's variable-rate clip of 30 frames a second may average a little under 30, and
    slow motion and time-lapse differ by 2 times and more.

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
    if taken is None or (plays_fps and abs(taken / plays_fps - 1.0) <= 0.05):
        return 1.0, None
    if not plays_fps:
        if given_fps is None:
            return 1.0, None  # nothing to scale from: the file's own times
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


#: Pixel formats of brightness alone (FFmpeg's names begin so): monochrome cameras'.
GREY_FORMATS = ("gray", "ya8", "ya16", "monob", "monow")


def colourless_note(source: FrameSource) -> str | None:
    """The sentence that says ``source``'s pictures hold no colour (stored without it,
    or its first picture all grey), or None. Said by ``inspect``, and by ``track`` where
    markers found by hue are asked for: not to a user who named white or black ones."""
    if source.stores_colour and source.colour:
        return None
    what = (f"is stored without colour ({source.pixel_format}, as monochrome cameras "
            "record)" if not source.stores_colour
            else "holds no colour in its first picture (every pixel grey)")
    return (f"the {'folder' if source.kind == 'images' else 'video'} {what}: markers are "
            "found by hue, except white, black and grey ones; name those (--marker "
            "NAME=white@X,Y), as `cranktrack inspect` lists them, or follow a marker by its "
            "picture (--marker NAME=template@X,Y,RADIUS)")


#: A start of the file's clock this far from 0 (s) is said: FFmpeg's MPEG-PS muxer starts
#: at 0.54 s and its MPEG-TS muxer at 1.4 s, where `--start 0.5` would be missed. Less
#: (an encoder's delay of a frame or two, a phone's edit list) is taken from the times
#: without a word.
CLOCK_START_SAID = 0.1


def _clock_start(container: av.container.InputContainer, stream: av.VideoStream
                 ) -> Fraction:
    """The file's clock at the start of its video, s: the video stream's start time, else
    the container's, else 0. Not the container's first: that is the earliest of all its
    streams', and an audio track that starts before the first picture (an AAC
    encoder's delay) would move every frame's time."""
    if stream.start_time is not None and stream.time_base:
        return stream.start_time * stream.time_base
    if container.start_time is not None:
        return Fraction(container.start_time, av.time_base)
    return Fraction(0)


def _first_picture(container: av.container.InputContainer, stream: av.VideoStream
                   ) -> tuple[float | None, bool, str, bool]:
    """The display rotation (degrees counter-clockwise, None where none is stored) of
    the stream's first picture, whether it is interlaced, its pixel format, and whether
    it holds colour (:func:`.pictures.holds_colour`); (None, False, "", True) where no
    picture can be decoded."""
    try:
        for packet in container.demux(stream):
            for frame in packet.decode():
                return (frame.rotation, bool(frame.interlaced_frame), frame.format.name,
                        holds_colour(frame.to_ndarray(format="rgb24")))
    except av.FFmpegError:
        pass
    return None, False, "", True


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
    #: portrait video is stored on its side with a display rotation, :func:`.planes.upright_turns`);
    #: ``width`` and ``height`` are the upright frame's.
    quarter_turns: int = 0
    #: How many times as wide as high a pixel is shown (the sample aspect ratio of the
    #: upright frame; DV and HDV camcorders store 16:15, 4:3 and the like). Positions
    #: stay in stored pixels; lengths take this into account (:mod:`.calibration`).
    pixel_aspect: float = 1.0
    #: The video is interlaced: each stored frame holds two fields taken half a frame
    #: apart, and each field is read as a frame of its own (:class:`.fields.Fields`), at
    #: twice the stored rate (``nominal_fps`` and ``expected_frames`` are the fields').
    fields: bool = False
    #: Which field of an interlaced frame was taken first, as its pictures show it
    #: (:func:`.fields.field_order`): "tff" (top), "bff" (bottom), or "auto" (as the file says).
    first_field: str = "auto"
    #: Seconds of the taking per second of the file's own clock: 1/8 for a phone's slow
    #: motion taken at 240 frames a second and stored to play at 30 (:func:`taking_scale`).
    time_scale: float = 1.0
    #: The file's clock at the start of its video (s of the file's clock; :func:`_clock_start`).
    #: MPEG program and transport streams (a DVD camera's .mpg, a camcorder's .MTS or
    #: .m2t) start theirs at half a second or more. Frame times are counted from it, the
    #: first picture at about 0, as players show them. Exact, so that a frame's time from
    #: it is its timestamp's to the last bit (a frame on ``--end`` is in).
    clock_start: Fraction = Fraction(0)
    #: The decoder's pixel format ("yuv420p", "gray", …; a folder's: "gray" for pictures
    #: of one channel, else "").
    pixel_format: str = ""
    #: The first picture holds colour: not every pixel of it grey while the picture
    #: shows something (:func:`.pictures.holds_colour`).
    colour: bool = True
    #: Bits a sample of a folder's pictures hold (8, or 10-16 in 16-bit files), from
    #: the first (:func:`.pictures.sample_bits`); they are read scaled from that depth to 8 bits.
    sample_bits: int = 8
    _images: list[Path] = field(default_factory=list, repr=False)

    @property
    def stores_colour(self) -> bool:
        """Can the pictures hold colour at all? Not where they are stored as brightness
        alone (a monochrome camera's ``gray``, ``gray16le``, …)."""
        return not self.pixel_format.startswith(GREY_FORMATS)

    @property
    def shown_frames(self) -> int | None:
        """Frames players show, as far as the container says: its listed count, or
        fewer where an edit list hides pictures it still lists (:meth:`_outside_the_edit`:
        the listed frames then outrun the duration at the stated rate by more than a
        rate's rounding). For a progress bar's total; None if the count is unknown."""
        if not self.expected_frames or not self.duration_s or not self.nominal_fps:
            return self.expected_frames
        fit = self.duration_s * self.nominal_fps
        if self.expected_frames <= 1.01 * fit + 2:
            return self.expected_frames
        return math.ceil(fit - 1e-6)

    @property
    def clock_start_s(self) -> float:
        """The file's clock at the start of its video, s (:attr:`clock_start`)."""
        return float(self.clock_start)

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
        resized: list[tuple[int, tuple[int, int]]] = []  # frames not of the video's size
        trimmed = 0  # pictures listed outside what the file shows (:meth:`_outside_the_edit`)

        def sized(frame: Frame) -> Iterator[Frame]:
            """The frame, unless it is not the video's size: a recording that changed its
            size part way, or two joined (its pixels would put the markers elsewhere)."""
            if frame.size == (self.width, self.height):
                yield frame
            else:
                resized.append((frame.index, frame.size))

        def take(frame: av.VideoFrame) -> bool:
            """Hold a decoded picture with its time; whether it had none of its own."""
            t = None if frame.pts is None or not frame.time_base else \
                frame.pts * frame.time_base - self.clock_start
            if t is not None:
                t_s = float(t) * self.time_scale
            else:
                n = index + len(pending)
                t_s = n / self.nominal_fps if self.nominal_fps else float(n)
            pending.append((t_s, frame_pixels(frame, self.quarter_turns)))
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
            fields = Fields(stream, self.first_field) if self.fields else None
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
                trimmed += self._outside_the_edit(packet)
                try:
                    decoded = packet.decode()
                except av.FFmpegError:
                    skipped.append(index + len(pending) - 1)
                    continue
                for frame in decoded if fields is None else fields.split(decoded):
                    missing_pts |= take(frame)
                    if len(pending) > REORDER_DEPTH:
                        yield from sized(emit())
            for frame in [] if fields is None else fields.split([None]):  # the last fields
                missing_pts |= take(frame)
            while pending:
                yield from sized(emit())
        if resized:
            (first, (w, h)), last = resized[0], resized[-1][0]
            self.problems.append(
                f"{len(resized)} frame(s), from frame {first} to {last}, are {w}×{h} px or "
                f"another size, not {self.width}×{self.height} like the video's first (the "
                "recording changed its size part way, or two were joined): they were skipped; "
                "cut that part into a file of its own to track it")
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
        per_picture = 2 if self.fields else 1
        if self.expected_frames \
                and index + len(set(skipped)) + per_picture * trimmed < self.expected_frames:
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

    def _outside_the_edit(self, packet: av.Packet) -> bool:
        """Does ``packet`` hold a picture the file does not show: one stamped before its
        clock's start or at or after its duration's end? A clip trimmed in a phone's
        gallery or by a stream copy keeps the pictures it cut, with an edit list that
        hides them; FFmpeg decodes and drops them, players never show them, and the
        container still counts them (a pendulum clip of bartekpacia/pendulum: 2057
        listed, 212 before its start and one after its end, 1844 shown)."""
        if packet.pts is None or not packet.time_base or not packet.size:
            return False
        t = float(packet.pts * packet.time_base - self.clock_start) * self.time_scale
        return t < 0.0 or (self.duration_s is not None and t >= self.duration_s)

    def _image_frames(self) -> Iterator[Frame]:
        fps = self.nominal_fps or 1.0
        for index, p in enumerate(self._images):
            rgb = read_picture(p, self.sample_bits)
            if rgb is None:
                self.problems.append(f"{p.name} could not be read as an 8- or 16-bit picture "
                                     "and was skipped")
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


def open_frames(path: str | os.PathLike, fps: float | None = None,
                one_picture: bool = False) -> FrameSource:
    """Open a video file or a folder of numbered images.

    Parameters
    ----------
    path : path-like
        A video file FFmpeg can read, or a folder of images
        (:func:`.pictures.numbered_pictures` says which of them are its frames).
    fps : float, optional
        The rate the frames were taken at (frames per second): an image folder's (which
        carries no timestamps), or a video's where it plays them at another rate (slow
        motion, time-lapse): its own timestamps are then scaled to it
        (:func:`taking_scale`).
    one_picture : bool
        Open a single picture that is one of a numbered sequence (:func:`.pictures.sequence_of`)
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
        return _open_folder(p, fps)
    if not one_picture and (sequence := sequence_of(p)) is not None:
        raise CranktrackError(
            f"{p.name} is one of {sequence} numbered pictures in {p.parent}; to use them "
            "as a clip, give the folder and its frame rate (--fps)")
    if p.stat().st_size == 0:
        raise CranktrackError(f"{p} is empty (0 bytes); it is not a video")
    return _open_video(p, fps)


def _open_folder(p: Path, fps: float | None) -> FrameSource:
    """A folder of numbered pictures as a clip (:func:`open_frames`)."""
    images, left_out = numbered_pictures(p)
    if not images:
        raise CranktrackError(
            f"{p} is a folder with no images in it; give a video file or a folder of "
            f"numbered {'/'.join(s[1:] for s in IMAGE_SUFFIXES)} images")
    if fps is None:
        raise CranktrackError(
            f"{p} is a folder of images, which carry no timestamps; give its frame rate "
            "with --fps")
    first = cv2.imread(str(images[0]), PICTURE_FLAGS)
    if first is None:
        raise CranktrackError(f"{images[0]} is not an image OpenCV can read")
    h, w = first.shape[:2]
    bits = sample_bits(first)
    rgb = picture_rgb(first, bits)  # None for samples of another type (float)
    source = FrameSource(p, "images", w, h, float(fps), len(images), "images",
                         sample_bits=bits, _images=images,
                         pixel_format="gray" if picture_channels(images[0]) in (1, 2)
                         else "",
                         colour=rgb is None or holds_colour(rgb))
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


def _open_video(p: Path, fps: float | None) -> FrameSource:
    """A video file as a clip (:func:`open_frames`): what its container, its stream and
    its first picture say of it."""
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
            rotation, interlaced, pixel_format, colour = _first_picture(container, s)
            turns = upright_turns(rotation)
            w, h = (codec.height, codec.width) if turns % 2 else (codec.width, codec.height)
            sar = s.sample_aspect_ratio or codec.sample_aspect_ratio
            aspect = float(sar) if sar and sar > 0 else 1.0
            aspect = 1.0 / aspect if turns % 2 else aspect
            first_field, order_note = interlacing(p, interlaced)
            interlaced = interlaced and first_field != "progressive"
            per_frame = 2 if interlaced else 1  # an interlaced frame's fields are frames
            source = FrameSource(p, "video", w, h, rate and per_frame * rate / scale,
                                 (s.frames or 0) * per_frame or None, codec.name,
                                 duration_s=duration and duration * scale, quarter_turns=turns,
                                 pixel_aspect=aspect, fields=interlaced, time_scale=scale,
                                 first_field=first_field if interlaced else "auto",
                                 clock_start=_clock_start(container, s),
                                 pixel_format=pixel_format, colour=colour)
            if abs(source.clock_start_s) >= CLOCK_START_SAID:
                source.problems.append(
                    f"the file's clock starts at {source.clock_start_s:.4g} s, not 0; frame "
                    "times, --start, --end and --at are counted from its start, as players "
                    "show them")
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
