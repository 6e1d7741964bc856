"""Folders of numbered pictures: which files are a folder's frames, and how a picture
is read (8-bit RGB from 8- or 16-bit files, grey or colour, turned as its EXIF says).

A folder is a clip when a camera or a tool wrote its frames one file each; it has no
clock of its own (the user gives ``--fps``). :func:`.video.open_frames` reads it.
"""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from ..errors import CranktrackError

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


#: How pictures are read: 16-bit samples kept (OpenCV's plain colour reading divides
#: them by 256), as three channels, turned upright as their EXIF says.
PICTURE_FLAGS = cv2.IMREAD_ANYDEPTH | cv2.IMREAD_COLOR


def sample_bits(raw: NDArray) -> int:
    """The bits a sample of a picture read with :data:`PICTURE_FLAGS` holds:
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
    return picture_rgb(cv2.imread(str(path), PICTURE_FLAGS), bits)


def picture_rgb(raw: NDArray | None, bits: int = 8) -> NDArray[np.uint8] | None:
    """A picture as OpenCV read it with :data:`PICTURE_FLAGS` (BGR, 8 or 16 bits), as
    :func:`read_picture` gives it; None for none, or for samples of another type."""
    if raw is None or raw.dtype not in (np.uint8, np.uint16):
        return None
    if raw.dtype == np.uint16:
        shift = bits - 8
        raw = np.minimum((raw.astype(np.uint32) + (1 << (shift - 1) if shift else 0)) >> shift,
                         255).astype(np.uint8)
    return cv2.cvtColor(raw, cv2.COLOR_BGR2RGB)


def picture_channels(path: Path) -> int:
    """How many channels a picture file stores: 1 for grey (a monochrome camera's), 2
    for grey with alpha, 3 or 4 for colour; 0 where OpenCV cannot read it."""
    raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    return 0 if raw is None else 1 if raw.ndim == 2 else raw.shape[2]


#: A picture holds no colour when at most this fraction of its pixels have channels
#: more than :data:`GREY_DN` apart: a monochrome camera's, coded as colour video (its
#: chroma planes flat at their middle), converted back to RGB within a DN.
GREY_FRACTION = 1e-3
GREY_DN = 2
#: ...and it shows something: its brightness spreads over at least this (DN, standard
#: deviation). A black or blank picture says nothing of the camera's colour.
SHOWS_DN = 2.0
#: About how many pixels :func:`holds_colour` looks at.
GREY_SAMPLES = 40_000


def holds_colour(rgb: NDArray[np.uint8]) -> bool:
    """Does an RGB picture (h, w, 3) hold colour? False only where it shows something
    and nearly every pixel of it is grey (:data:`GREY_FRACTION`).

    >>> import numpy as np
    >>> ramp = np.repeat(np.arange(0, 250, 5, dtype=np.uint8)[None, :, None], 3, axis=2)
    >>> holds_colour(ramp), holds_colour(ramp[..., ::-1] // [1, 1, 2]), holds_colour(0 * ramp)
    (False, True, True)
    """
    # Every k-th row and column, about GREY_SAMPLES pixels: on a 1080p picture all of
    # them took 113 ms, more than opening the video did.
    k = max(1, int(np.sqrt(rgb.shape[0] * rgb.shape[1] / GREY_SAMPLES)))
    rgb = rgb[::k, ::k]
    grey = rgb.mean(axis=2)
    if grey.std() < SHOWS_DN:
        return True
    spread = rgb.max(axis=2).astype(np.int16) - rgb.min(axis=2)
    return bool(np.mean(spread > GREY_DN) > GREY_FRACTION)


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
