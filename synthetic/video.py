"""Writing renders as video files with exact presentation timestamps (PyAV)."""

from __future__ import annotations

import os
from fractions import Fraction
from pathlib import Path
from types import TracebackType

import av
import numpy as np
from numpy.typing import NDArray

#: Ticks per second of the stream time base: fine enough that any frame time
#: given in ms or as k/fps for common rates lands within 1/(2·TICKS) s.
TICKS = 90_000


class VideoWriter:
    """Write RGB frames to an ``.mp4`` with given presentation times.

    ``lossless=False`` writes H.264 (yuv420p, ``crf``) as an ordinary camera
    would; ``lossless=True`` writes bit-exact RGB H.264 (libx264rgb, qp 0)
    for accuracy tests. The file appears under its final name only when the
    writer closes cleanly (written to a temporary name, then renamed).
    """

    def __init__(self, path: str | os.PathLike, width: int, height: int, fps: float,
                 lossless: bool = False, crf: int = 20) -> None:
        self.path = Path(path)
        self._tmp = self.path.with_name(f".{self.path.stem}.partial{self.path.suffix}")
        # The index (moov) first, as cameras that stream do: a cut file still plays.
        self._container = av.open(str(self._tmp), mode="w", format="mp4",
                                  options={"movflags": "faststart"})
        rate = Fraction(fps).limit_denominator(1001)
        if lossless:
            self._stream = self._container.add_stream("libx264rgb", rate=rate)
            self._stream.pix_fmt = "rgb24"
            self._stream.options = {"qp": "0", "preset": "ultrafast"}
        else:
            self._stream = self._container.add_stream("libx264", rate=rate)
            self._stream.pix_fmt = "yuv420p"
            # Without macroblock-tree rate control: with it, libx264 (as PyAV calls it)
            # coded the same frames of some scenes (a still one with fresh noise in every
            # frame, the SMA bed of bench/sma_bed_apart.py) differently from run to run,
            # so such a render, and every figure measured on it, could not be made again.
            self._stream.options = {"crf": str(crf), "preset": "fast", "x264-params": "mbtree=0"}
        self._stream.width, self._stream.height = width, height
        self._stream.codec_context.time_base = Fraction(1, TICKS)
        self._last_pts = -1

    def write(self, rgb: NDArray[np.uint8], t_s: float) -> None:
        """Append one frame shown at time ``t_s`` (s, strictly increasing)."""
        pts = round(t_s * TICKS)
        if pts <= self._last_pts:
            raise ValueError(f"frame time {t_s} s is not after the previous frame")
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
        frame.pts, frame.time_base = pts, Fraction(1, TICKS)
        self._last_pts = pts
        for packet in self._stream.encode(frame):
            self._container.mux(packet)

    def close(self) -> None:
        """Flush the encoder and move the file into place."""
        for packet in self._stream.encode():
            self._container.mux(packet)
        self._container.close()
        os.replace(self._tmp, self.path)

    def abort(self) -> None:
        """Drop a partial file."""
        try:
            self._container.close()
        finally:
            self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
