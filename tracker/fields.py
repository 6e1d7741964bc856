"""Interlaced video: each stored frame holds two fields taken half a frame apart.

:func:`field_order` reads from the pictures which field came first (or that both are
one instant), and :class:`Fields` makes each field a frame of its own, as players
show such video. :func:`.video.open_frames` uses both for a file whose frames say
they are interlaced.
"""

from __future__ import annotations

from collections import deque
from pathlib import Path

import av
import numpy as np
from numpy.typing import NDArray

from .planes import plane_samples

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
        stream = container.streams.best("video")  # the stream open_frames reads
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


def interlacing(path: Path, flagged: bool) -> tuple[str, str | None]:
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


class Fields:
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
                self._stored.append(plane_samples(frame, 0).copy())
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
        luma = plane_samples(field, 0)
        kept = {parity for stored in self._stored for parity in (0, 1)
                if np.array_equal(luma[parity::2], stored[parity::2])}
        if len(kept) != 1:
            return field
        step = -1 if kept.pop() == 0 else 1  # the neighbour a quarter line takes from
        field.make_writable()
        for k in (1, 2):
            chroma = plane_samples(field, k)
            c = chroma.astype(np.float32)
            neighbour = np.roll(c, -step, axis=0)
            neighbour[0 if step < 0 else -1] = c[0 if step < 0 else -1]  # the edge line
            chroma[...] = np.rint(0.75 * c + 0.25 * neighbour).astype(chroma.dtype)
        return field
