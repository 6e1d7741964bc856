"""Markers: which pixels belong to which marker, and where its centre is.

A colour marker is found by thresholding hue, saturation and value (OpenCV's
8-bit HSV: hue 0–179 in 2° steps); red wraps around hue 0, so hue ranges are
intervals on the hue circle. A white or black marker (a ball, a sticker, a dot
of paint) has no hue: it is found by its contrast with its surroundings, the
brightness left after a morphological top-hat (white) or black-hat (black)
larger than the marker, among pixels of little saturation.
"""

from __future__ import annotations

import colorsys
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import cv2
import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..errors import CranktrackError

#: Hue (degrees on the 0–360 circle) of colour names a user may give.
COLOUR_HUES_DEG = {
    "red": 0.0, "orange": 30.0, "yellow": 60.0, "green": 120.0, "cyan": 180.0,
    "blue": 230.0, "purple": 270.0, "magenta": 300.0,
}


#: How much brighter (darker) than its surroundings a white (black) marker is, DN.
TONE_CONTRAST_DN = 40
#: The surroundings a luminance marker is compared with: a disc wider than the marker
#: (it leaves the marker standing out; a wider background is taken away), 31 px.
_TONE_KERNEL = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (31, 31))
#: A marker too wide for that disc is found a second time on the frame halved, where
#: the same disc is 62 px across; of that pass only blobs at least this wide (px) are
#: kept, as blobs of their own. The halved pass alone moved small blobs' edges (a
#: falling paper cup 8×3 px was then lost in a frame); without it a diabolo 40 px
#: across (Tracker's Diabolo clip) was taken away as background and found in 1 of
#: 410 frames.
TONE_WIDE_PX = 24
#: The frame is looked at this many times smaller in turn (its surroundings' disc then
#: 62, 124 and 248 px across), and of each pass only blobs at least ``TONE_WIDE_PX`` ×
#: half that wide are kept: a white disc 120 px across (a ball filmed close in 1080p,
#: bench/large_markers.py) was wider than the halved pass's disc, and was found in no
#: frame.
TONE_SCALES = (2, 4, 8)
#: ...but a part found past halved is left out where a blob already found lies inside
#: it with this fraction of its area or more (:func:`find_blobs`).
WIDE_OVER = 0.25


def _kernel_rows(kernel: NDArray[np.uint8]) -> tuple[tuple[int, tuple[int, ...]], ...]:
    """A kernel symmetric about its middle (a disc), row by row: each half-width (px) its
    rows have, and the offsets of those rows from the middle row."""
    rows: dict[int, list[int]] = {}
    for i, row in enumerate(kernel):
        if row.any():
            half = int(np.flatnonzero(row).max()) - kernel.shape[1] // 2
            rows.setdefault(half, []).append(i - kernel.shape[0] // 2)
    return tuple((half, tuple(offsets)) for half, offsets in sorted(rows.items()))


#: :data:`_TONE_KERNEL` row by row (:func:`_kernel_rows`).
_KERNEL_ROWS = _kernel_rows(_TONE_KERNEL)


def _by_disc(image: NDArray[np.uint8], dilate: bool) -> NDArray[np.uint8]:
    """The erosion (``dilate``: dilation) of ``image`` by :data:`_TONE_KERNEL`, equal to
    OpenCV's ``erode`` (``dilate``) with it, pixels past the edge left out.

    The disc is the union of its rows, so each pixel takes the extreme of one-row
    erosions (one per half-width, each fast for a straight line) of the rows above and
    below. OpenCV takes a kernel of another shape point by point: on a 1280×720 frame
    (Tracker's car clip, a lost white marker's whole-frame search) an opening took
    11-15 ms this way against 6 ms (a test checks both give the same pixels)."""
    extreme = np.maximum if dilate else np.minimum
    line = cv2.dilate if dilate else cv2.erode
    h = image.shape[0]
    out = np.full_like(image, 0 if dilate else 255)
    # One buffer for the one-row erosions, taken in turn: ten fresh frame-sized arrays
    # a call made it slower than OpenCV's own (15 against 11 ms), their pages new each time.
    row = np.empty_like(image)
    for half, offsets in _KERNEL_ROWS:
        line(image, np.ones((1, 2 * half + 1), np.uint8), dst=row)
        for dy in offsets:
            # A kernel row dy below the middle reaches the image row dy below each pixel.
            if abs(dy) >= h:
                continue
            if dy >= 0:
                extreme(out[:h - dy], row[dy:], out=out[:h - dy])
            else:
                extreme(out[-dy:], row[:h + dy], out=out[-dy:])
    return out


def _opened(value: NDArray[np.uint8], brighter: bool) -> NDArray[np.uint8]:
    """The opening (``brighter``) or closing of ``value`` by :data:`_TONE_KERNEL`."""
    return _by_disc(_by_disc(value, not brighter), brighter)


def _tone_contrast(value: NDArray[np.uint8], brighter: bool, scale: int = 1
                   ) -> NDArray[np.uint8]:
    """How much brighter (``brighter``) or darker than its surroundings each pixel of a
    value image is, DN: a top-hat (black-hat) with :data:`_TONE_KERNEL`, whose
    opening (closing) is taken on the image ``scale`` times smaller and brought back
    to size."""
    if scale > 1:
        h, w = value.shape
        small = cv2.resize(value, (max(w // scale, 1), max(h // scale, 1)),
                           interpolation=cv2.INTER_AREA)
        around = cv2.resize(_opened(small, brighter), (w, h), interpolation=cv2.INTER_LINEAR)
    else:
        around = _opened(value, brighter)
    return cv2.subtract(value, around) if brighter else cv2.subtract(around, value)


def components(mask: NDArray[np.uint8]) -> tuple[int, NDArray[np.int32], NDArray[np.int32],
                                                 NDArray[np.float64]]:
    """OpenCV's ``connectedComponentsWithStats`` (8-connected), the same numbers: the
    count of labels, the label image, each label's box and area (``cv2.CC_STAT_*``
    columns) and its centroid (px). Row 0, the background, has the image's box.

    OpenCV's own statistics visit every pixel of the image with a cost of their
    own, and took 1.35 ms of a 768×576 frame's 1.6 ms of labelling (vtest.avi),
    where labels alone take 0.25 ms: a lost marker's whole-frame search labels
    such a frame once per colour. Here they are gathered over the label image in
    one compiled pass, 0.2–0.5 ms."""
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    stats, centroids = _component_stats(labels, n)
    return n, labels, stats, centroids


@njit(cache=True, nogil=True)
def _component_stats(labels: NDArray, n: int) -> tuple[NDArray, NDArray]:
    h, w = labels.shape
    stats = np.zeros((n, 5), np.int32)
    sums = np.zeros((n, 2), np.int64)  # whole numbers: the centroids come out exact
    for k in range(1, n):
        stats[k, 0], stats[k, 1] = w, h
    for i in range(h):
        for j in range(w):
            k = labels[i, j]
            if k:
                stats[k, 0] = min(stats[k, 0], j)
                stats[k, 1] = min(stats[k, 1], i)
                stats[k, 2] = max(stats[k, 2], j)  # the last column, made a width below
                stats[k, 3] = max(stats[k, 3], i)
                stats[k, 4] += 1
                sums[k, 0] += j
                sums[k, 1] += i
    centroids = np.zeros((n, 2))
    stats[0, 2], stats[0, 3], stats[0, 4] = w, h, h * w
    for k in range(1, n):
        stats[k, 2] -= stats[k, 0] - 1
        stats[k, 3] -= stats[k, 1] - 1
        centroids[k, 0] = sums[k, 0] / stats[k, 4]
        centroids[k, 1] = sums[k, 1] / stats[k, 4]
        stats[0, 4] -= stats[k, 4]
    return stats, centroids


def _wide(mask: NDArray[np.uint8], least_px: int) -> NDArray[np.uint8]:
    """The parts of a mask whose box is at least ``least_px`` on its shorter side."""
    n, labels, stats, _ = components(mask)
    keep = np.zeros(n, np.uint8)
    keep[1:] = np.minimum(stats[1:, cv2.CC_STAT_WIDTH], stats[1:, cv2.CC_STAT_HEIGHT]) \
        >= least_px
    return keep[labels] * 255


@dataclass(frozen=True)
class MarkerSpec:
    """A marker to find: its name and colour window.

    ``hue_deg`` ± ``hue_tol_deg`` on the hue circle, saturation and value at
    least ``min_saturation`` and ``min_value`` (0–1), and a blob of at least
    ``min_area_px`` pixels. ``tone`` ``"white"``, ``"black"`` or ``"grey"`` makes it
    a luminance marker instead: brighter (darker; either) than its surroundings by
    :data:`TONE_CONTRAST_DN`, with saturation at most ``min_saturation``; the hue
    is then unused.
    """

    name: str
    hue_deg: float
    hue_tol_deg: float = 30.0
    min_saturation: float = 0.35
    min_value: float = 0.25
    min_area_px: int = 6
    tone: str = ""
    #: Where the marker is when first sought (px): among several blobs of its colour the
    #: nearest is taken, as a user clicking it would (``--marker ball=white@131,208``).
    near_px: tuple[float, float] | None = None
    #: A flat disc of one colour, never a shaded ball: the crank-slider's printed
    #: markers. Such a marker is centred by the disc fit only; a blob that fits only
    #: as a ball (by its rim) is not it. Measured on OpenCV's vtest.avi (a shopping
    #: mall, no markers): with balls allowed, A, B and C were "found" on shaded
    #: clothes and signs in 97–99 % of frames, and the rim fits took 90 % of the time.
    flat: bool = False
    #: A marker with no colour of its own, followed by its picture from where it was
    #: placed (:mod:`.template`): its radius (px), given with its place
    #: (``--marker ball=template@161,53,36``). None for a colour or tone marker.
    template_radius_px: float | None = None

    def takes(self, blob: Blob) -> bool:
        """Could ``blob`` be this marker by its shape? The crank-slider's printed discs
        are disc-like; a marker the user names may be any compact blob
        (:meth:`Blob.compact`): on Tracker's CupsClips the paper cups are square-cut
        8×3 px strips, which the disc test (fill ≤ 0.95) turned away."""
        return blob.disc_like() if self.flat else blob.compact()

    @classmethod
    def from_colour(cls, name: str, colour: str) -> MarkerSpec:
        """A spec from a colour name (``red``, ``green``, …, ``white``, ``black``,
        ``grey``), a hue in degrees, or ``#RRGGBB`` (a colour of little saturation is
        white or black)."""
        key = colour.strip().lower()
        if key in COLOUR_HUES_DEG:
            return cls(name, COLOUR_HUES_DEG[key])
        if key in ("white", "black", "grey", "gray"):
            return cls(name, 0.0, min_saturation=0.35, tone=key.replace("gray", "grey"))
        if key.startswith("#"):
            try:
                r, g, b = (int(key[i:i + 2], 16) / 255.0 for i in (1, 3, 5))
                if len(key) != 7:
                    raise ValueError
            except ValueError:
                raise CranktrackError(f"marker {name}'s colour {colour.strip()!r} is not "
                                      "#RRGGBB (six hex digits)") from None
            h, sat, v = colorsys.rgb_to_hsv(r, g, b)
            if sat < 0.25:  # too grey for a hue: a luminance marker
                return cls.from_colour(name, "white" if v >= 0.5 else "black")
            return cls(name, 360.0 * h)
        try:
            hue = float(key)
        except ValueError:
            known = ", ".join(COLOUR_HUES_DEG)
            raise CranktrackError(
                f"unknown marker colour {colour!r} for {name}; use one of {known}, white, "
                "black, grey, a hue in degrees or #RRGGBB") from None
        if not 0.0 <= hue <= 360.0:
            raise CranktrackError(f"marker {name}'s hue {colour.strip()} is outside 0–360°")
        return cls(name, hue % 360.0)

    def _standing_out(self, hsv: NDArray[np.uint8], scale: int) -> NDArray[np.uint8]:
        """A luminance marker's pixels (255): of little saturation, and standing out
        from their surroundings by :data:`TONE_CONTRAST_DN` (:func:`_tone_contrast`)."""
        value = np.ascontiguousarray(hsv[..., 2])
        if self.tone == "grey":
            # Neither white nor black: standing out from its surroundings either way
            # (a grey disc on a white board, or on a dark floor).
            contrast = np.maximum(_tone_contrast(value, True, scale),
                                  _tone_contrast(value, False, scale))
        else:
            contrast = _tone_contrast(value, self.tone == "white", scale)
        grey = hsv[..., 1] <= round(self.min_saturation * 255)
        return ((contrast >= TONE_CONTRAST_DN) & grey).astype(np.uint8) * 255

    def wide_masks(self, hsv: NDArray[np.uint8]) -> list[tuple[int, NDArray[np.uint8]]]:
        """A luminance marker's pixels found on the image made smaller, once per scale of
        :data:`TONE_SCALES` (with the scale), each in parts at least
        :data:`TONE_WIDE_PX` × half the scale wide; none for a colour marker or where
        the image is narrower than that."""
        if not self.tone:
            return []
        side = min(hsv.shape[:2])
        # Past halved, only where the image is at least twice that scale's disc: in a
        # small one the disc takes in most of it, and what stands out from it is the
        # background itself (a 240×180 drawing gained a blob of it, said to move).
        return [(scale, _wide(self._standing_out(hsv, scale), TONE_WIDE_PX * scale // 2))
                for scale in TONE_SCALES if side >= TONE_WIDE_PX * scale // 2
                and (scale <= 2 or side >= 2 * _TONE_KERNEL.shape[0] * scale)]

    def mask(self, hsv: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """Pixels of this colour (255) in an OpenCV 8-bit HSV image (none for a template
        marker, which has no colour)."""
        if self.template_radius_px is not None:
            return np.zeros(hsv.shape[:2], np.uint8)
        if self.tone:
            return self._standing_out(hsv, scale=1)
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


DEFAULT_MARKERS: tuple[MarkerSpec, ...] = tuple(
    replace(MarkerSpec.from_colour(name, colour), flat=True)
    for name, colour in (("A", "green"), ("B", "red"), ("C", "blue")))


#: What a marker is, said after its colour (``B=green:blob``): a printed flat disc,
#: or any compact blob of its colour (a ball, an LED, a strip of tape, a sticker).
SHAPES = ("disc", "blob")


def _template_spec(item: str, name: str, at: str, said: str, where: str) -> MarkerSpec:
    """A template marker from the parts of ``--marker NAME=template@X,Y,R``
    (:func:`parse_markers`)."""
    usage = (f"--marker {item!r}: a template marker is placed by its centre and radius in "
             "pixels, e.g. ball=template@161,53,36")
    if not at or said:
        raise CranktrackError(usage)
    try:
        x, y, r = (float(v) for v in where.split(","))
    except ValueError:
        raise CranktrackError(usage) from None
    if not (np.isfinite(x) and np.isfinite(y) and np.isfinite(r)) or r < 2.0:
        raise CranktrackError(f"--marker {item!r}: the place must be finite pixels and the "
                              "radius at least 2 px")
    return MarkerSpec(name, 0.0, near_px=(x, y), template_radius_px=r)


def parse_markers(items: list[str]) -> tuple[MarkerSpec, ...]:
    """Markers from ``NAME=COLOUR[:SHAPE][@X,Y]`` items (see
    :meth:`MarkerSpec.from_colour`).

    ``NAME=template@X,Y,R`` is a marker with no colour of its own (a steel ball),
    followed by its picture within R px of the place X,Y (px) in the first frame
    tracked (:mod:`.template`).

    Naming only the crank-slider's A, B or C changes their colours and keeps the
    others at their defaults; naming any other marker tracks exactly the named
    ones, so a ball or a cart is not searched for A, B and C as well. ``C=none``
    says the slider carries no marker: A and B are tracked alone (a crank on its
    pivot, an arm that turns), and θ is then measured from the plane's x axis.
    ``SHAPE`` (:data:`SHAPES`) says what the marker is: A, B and C are printed discs
    (``disc``, :attr:`MarkerSpec.flat`) unless said to be a ``blob`` (an LED or a
    ball on the crank); any other marker is a blob unless said to be a disc.
    """
    given: dict[str, MarkerSpec] = {}
    shapes: dict[str, str] = {}
    without: set[str] = set()
    for item in items:
        name, sep, colour = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise CranktrackError(f"--marker {item!r} is not NAME=COLOUR, e.g. B=red or "
                                  "ball=white@131,208")
        colour, at, where = colour.partition("@")
        colour, said, shape = colour.partition(":")
        if not said:  # said after the place instead: B=green@40,60:blob
            where, said, shape = where.partition(":")
        if colour.strip().lower() == "template":
            spec = _template_spec(item, name, at, said, where)
            if name in given:
                raise CranktrackError(f"marker {name} is given twice")
            given[name] = spec
            continue
        if colour.strip().lower() == "none":
            if at or said:
                raise CranktrackError(f"--marker {item!r}: a marker that is none has no shape "
                                      "or place; write C=none")
            if name != "C":
                raise CranktrackError(f"--marker {item!r}: only C, the slider's marker, may be "
                                      "none; the kinematics need the pivot A and the crank's B")
            without.add(name)
            continue
        if said:
            shape = shape.strip().lower()
            if shape not in SHAPES:
                raise CranktrackError(f"--marker {item!r}: the shape after : is disc (a "
                                      "printed flat disc) or blob (a ball, an LED, tape)")
            shapes[name] = shape
        spec = MarkerSpec.from_colour(name, colour)
        if at:
            try:
                x, y = (float(v) for v in where.split(","))
            except ValueError:
                raise CranktrackError(f"--marker {item!r}: the place after @ is X,Y in pixels, "
                                      "e.g. @131,208") from None
            if not (np.isfinite(x) and np.isfinite(y)):
                raise CranktrackError(f"--marker {item!r}: the place must be finite pixels")
            spec = replace(spec, near_px=(x, y))
        if name in given:
            raise CranktrackError(f"marker {name} is given twice")
        given[name] = spec
    defaults = {s.name for s in DEFAULT_MARKERS}
    if without and "C" in given:
        raise CranktrackError("marker C is given both a colour and none")
    if without and not set(given) <= defaults:
        raise CranktrackError("C=none is for the crank-slider's markers; with markers of "
                              "other names only the named ones are tracked anyway")
    if (given or without) and set(given) <= defaults:
        # Recoloured, still the crank-slider's flat discs unless said to be blobs (less
        # any said to be none).
        return tuple(replace(given[s.name], flat=shapes.get(s.name) != "blob"
                             and given[s.name].template_radius_px is None)
                     if s.name in given else s
                     for s in DEFAULT_MARKERS if s.name not in without)
    return tuple(replace(spec, flat=shapes.get(name) == "disc")
                 for name, spec in given.items()) or DEFAULT_MARKERS


#: The shorter side (px) under which a blob's box does not tell a disc from a square
#: or a strip. Yupi's rover pivot, a disc 25 px across, was first seen in a dim frame
#: as a core 3×2 px: under one invisible ±1 DN pattern (of six) that core was taken
#: for a strip, and the pivot was lost in every frame after.
SHAPELESS_PX = 4.0


def _disc_like(fill: NDArray | float, aspect: NDArray | float) -> NDArray | bool:
    """:meth:`Blob.disc_like` of fills and aspects, one or many."""
    return (0.45 <= fill) & (fill <= 0.95) & (0.4 <= aspect) & (aspect <= 2.5)


@dataclass(frozen=True)
class Blob:
    """A connected region of a marker's colour: mask centroid (px), area (px²),
    fill (area ÷ bounding-box area; π/4 for a disc) and bounding-box aspect ratio."""

    x: float
    y: float
    area: float
    fill: float
    aspect: float
    #: The largest disc inside a blob of another shape (a ball with a stalk): the
    #: disc is given, and the blob it was cut from was not a disc (:func:`find_blobs`).
    cored: bool = False

    @property
    def radius(self) -> float:
        """Radius of a disc of the same area, px."""
        return float(np.sqrt(self.area / np.pi))

    def disc_like(self) -> bool:
        """Roughly a disc (partly covered or blurred discs still pass)."""
        return bool(_disc_like(self.fill, self.aspect))

    def _half_side(self, longer: bool) -> float:
        """Half a side of the blob's bounding box, px (from its area, fill and aspect)."""
        stretch = max(self.aspect, 1.0 / self.aspect)
        return 0.5 * float(np.sqrt(self.area / self.fill * (stretch if longer else 1 / stretch)))

    @property
    def half_length(self) -> float:
        """Half the longer side of the blob's bounding box, px."""
        return self._half_side(True)

    @property
    def half_width(self) -> float:
        """Half the shorter side of the blob's bounding box, px."""
        return self._half_side(False)

    def elongated(self) -> bool:
        """Not a disc to fit a disc to: filling its box like a square, or longer one way
        than 1.6:1 and still filling most of its box (a strip of tape; a ball with a
        stalk of its colour fills 0.6 of its box, and is a disc with something
        attached). A disc fitted to a strip slides along it: on 8×3.5 px strips it
        was off by 0.4 px along the strip. (A streak's thresholded blob can look
        round: its faint ends fall below the threshold; the coverage's moments
        tell, :attr:`.Centre.length_px`.)

        A blob under :data:`SHAPELESS_PX` across its shorter side says nothing by its
        box: a disc 3 px across fills it as a square does."""
        if 2.0 * self.half_width < SHAPELESS_PX:
            return False
        return self.fill > 0.92 or (not 1 / 1.6 <= self.aspect <= 1.6 and self.fill >= 0.8)

    def solid(self) -> bool:
        """Filling its box as a disc, an ellipse or a stadium does (≥ 0.65), not as a
        ball with a stalk, or a cross, does (nor cut from such a blob)."""
        return self.fill >= 0.65 and not self.cored

    def compact(self) -> bool:
        """A compact blob of any shape people make markers in: a disc, a square (fill
        up to 1), a strip of tape or a motion-blurred streak up to 3:1."""
        return 0.45 <= self.fill and 1 / 3 <= self.aspect <= 3.0


def find_blobs(hsv: NDArray[np.uint8], spec: MarkerSpec, x0: int = 0, y0: int = 0
               ) -> list[Blob]:
    """Blobs of ``spec``'s colour in an HSV image (or patch whose top-left is x0, y0).

    A blob that is not disc-like but holds a disc that fills most of it (a ball on
    a stalk of its own colour, a bead on its string) is given as that disc: the
    largest circle inside it, by the distance transform (centre to the pixel,
    radius to a pixel or so), for the refinement to take from there. A luminance
    marker's blobs too wide for its surroundings' disc (:meth:`MarkerSpec.wide_masks`)
    are added as blobs of their own, each scale's: merged into the first mask, a white
    sign's blob took in the air conditioners beside it and was too big to be the sign.
    """
    blobs = _blobs(spec.mask(hsv), spec, x0, y0)
    for scale, wide in spec.wide_masks(hsv):
        found = _blobs(wide, spec, x0, y0)
        if scale > 2:
            # A part this wide around a blob already found, a quarter of its area or
            # more, is that blob with what lies beside it: Tracker's diabolo (40 px)
            # and its sticks were taken as one, and it was found in 82 % of the frames,
            # not 96 %. (A thin ring left at a wide disc's rim by a finer pass is not.)
            found = [b for b in found if not any(
                math.hypot(b.x - a.x, b.y - a.y) < b.radius and a.area >= WIDE_OVER * b.area
                for a in blobs)]
        blobs += found
    return blobs


def _blobs(mask: NDArray[np.uint8], spec: MarkerSpec, x0: int, y0: int) -> list[Blob]:
    """The blobs of one mask (:func:`find_blobs`)."""
    # Labelling costs 0.7 ms on a 640×480 frame even where the colour is nowhere, and
    # a lost marker's colour is looked for in whole frames: only the box around the
    # colour's pixels is labelled. A pixel of margin where the image goes on keeps a
    # blob's distance map (:func:`_core`) the whole image's: with it, all 164,802
    # blobs of OpenCV's sample clips (every 7th frame, three saturation floors) are
    # as before; without it, some on box.mp4 were not.
    bx, by, bw, bh = cv2.boundingRect(mask)
    if bw == 0 or bh == 0:
        return []
    h, w = mask.shape
    bx0, by0 = max(bx - 1, 0), max(by - 1, 0)
    mask = mask[by0:min(by + bh + 1, h), bx0:min(bx + bw + 1, w)]
    x0, y0 = x0 + bx0, y0 + by0
    n, labels, stats, centroids = components(mask)
    blobs, merged = [], set()
    if spec.flat and 2 < n <= REJOIN_MOST and _near_pairs(stats[1:]):
        blobs, merged = _rejoined(mask, labels, spec, x0, y0)
    # A busy real frame has a thousand pieces of a colour: their shapes are judged
    # together, and a Blob is made only of those big enough to be a marker.
    area = stats[:, cv2.CC_STAT_AREA].astype(float)
    w, h = stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT]
    fill, aspect = area / (w * h).astype(float), w / h.astype(float)
    disc = _disc_like(fill, aspect)
    # The largest disc a w×h box holds has a radius of about min(w, h)/2 (+1 as
    # _core measures it): where that cannot fill CORE_FRACTION of the blob, it
    # has no core (most blobs of a busy real frame) and needs no distance map.
    side = np.minimum(w, h)
    cored = ~disc & (np.pi * (0.5 * side + 1.5) ** 2 >= CORE_FRACTION * area)
    # Nor has a blob 2 px across or less, clear of the mask's edge: none of its
    # pixels is more than 1 px from one outside it (radius 1.5), under _core's least
    # (at the edge the distance map takes the outside as far, so there it may).
    H, W = labels.shape
    x, y = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    clear = (x > 0) & (y > 0) & (x + w < W) & (y + h < H)
    cored &= ~((side <= 2) & clear)
    if cored.any():
        # Nor has a blob none of whose pixels has all its neighbours in it: each then lies
        # within 1.4 px of one outside (radius 1.9), so _core would give the blob back.
        # Most pieces of a busy frame are such: on OpenCV's vtest.avi a lost marker's
        # whole-frame search measured 264 of them, a third of its time.
        inner = np.zeros(n, bool)
        inner[labels[cv2.erode(mask, np.ones((3, 3), np.uint8)) > 0]] = True
        cored &= inner
    for k in np.flatnonzero(area >= spec.min_area_px):
        if k == 0 or k in merged:
            continue
        blob = Blob(float(centroids[k][0]) + x0, float(centroids[k][1]) + y0, float(area[k]),
                    float(fill[k]), float(aspect[k]))
        if cored[k]:
            blob = _core(blob, labels, k, stats[k], x0, y0)
        blobs.append(blob)
    return blobs


#: Gaps up to this wide (px) within a marker's colour are bridged when the pieces
#: make a round blob together (:func:`_rejoined`).
REJOIN_PX = 5
#: ...round: its box within this aspect either way, and filled as a disc fills it.
REJOIN_ASPECT = 1.3
REJOIN_FILL = (0.65, 0.9)
#: ...and only for the crank-slider's printed discs, which its wire crosses, in a
#: mask of at most this many pieces: a busy real frame has thousands of blobs of any
#: colour (OpenCV's vtest.avi, grass), where joining them cost more than tracking
#: (tracking against decoding 1.42 → 0.81 there).
REJOIN_MOST = 64


def _near_pairs(boxes: NDArray) -> bool:
    """Do any two of these boxes (x, y, w, h, …) lie within :data:`REJOIN_PX` of each
    other and make a round box together? (Most masks have none, and are not closed.)"""
    x0, y0 = boxes[:, 0], boxes[:, 1]
    x1, y1 = x0 + boxes[:, 2], y0 + boxes[:, 3]
    gap_x = np.maximum(x0[:, None], x0[None, :]) - np.minimum(x1[:, None], x1[None, :])
    gap_y = np.maximum(y0[:, None], y0[None, :]) - np.minimum(y1[:, None], y1[None, :])
    wide = np.maximum(x1[:, None], x1[None, :]) - np.minimum(x0[:, None], x0[None, :])
    tall = np.maximum(y1[:, None], y1[None, :]) - np.minimum(y0[:, None], y0[None, :])
    near = (gap_x <= REJOIN_PX) & (gap_y <= REJOIN_PX) \
        & (wide <= REJOIN_ASPECT * tall) & (tall <= REJOIN_ASPECT * wide)
    np.fill_diagonal(near, False)
    return bool(near.any())


def _rejoined(mask: NDArray[np.uint8], labels: NDArray, spec: MarkerSpec, x0: int, y0: int
              ) -> tuple[list[Blob], set[int]]:
    """Blobs of one of the crank-slider's discs that a thin line across them cut in
    pieces, whole again, and the labels of those pieces.

    The SMA wire tied at the crank's tip crosses the pivot's disc when the crank
    is near 180°, and cuts its colour in two (a second renderer's SMA bed,
    bench/sma_bed_apart.py): the larger piece was taken for the marker, 7.7 px
    for a 10.4 px disc, and the marker was lost. Pieces are joined only where the
    mask closed over :data:`REJOIN_PX` makes one round blob of them: two markers
    side by side make a long one, and stay two."""
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (REJOIN_PX, REJOIN_PX))
    closed = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)
    m, joined, stats, _ = components(closed)
    inside = labels > 0
    pairs = np.unique(labels[inside].astype(np.int64) * m + joined[inside])
    pieces = np.bincount(pairs % m, minlength=m)
    out, merged = [], set()
    for j in np.flatnonzero(pieces >= 2):
        w, h = stats[j, cv2.CC_STAT_WIDTH], stats[j, cv2.CC_STAT_HEIGHT]
        area = float(stats[j, cv2.CC_STAT_AREA])
        fill, aspect = area / float(w * h), float(w) / float(h)
        if not (1 / REJOIN_ASPECT <= aspect <= REJOIN_ASPECT
                and REJOIN_FILL[0] <= fill <= REJOIN_FILL[1]) or area < spec.min_area_px:
            continue
        own = pairs[pairs % m == j] // m
        merged.update(int(k) for k in own)
        # The centroid of the colour's own pixels, not of the bridge.
        ys, xs = np.nonzero(np.isin(labels, own))
        out.append(Blob(float(xs.mean()) + x0, float(ys.mean()) + y0, area, fill, aspect))
    return out, merged


#: A blob whose largest inner disc covers at least this fraction of it is taken
#: as that disc with something attached (a stalk), not as some other shape.
CORE_FRACTION = 0.4


def _core(blob: Blob, labels: NDArray, k: int, box: NDArray, x0: int, y0: int) -> Blob:
    """The largest disc inside blob ``k`` if it fills most of it, else the blob."""
    bx, by, bw, bh = (int(v) for v in box[:4])
    # The distance map of the blob's own box, with a pixel of margin where the image
    # goes on (at the image's edge the map treats the outside as the whole frame's
    # does): another blob cannot touch it (8-connected), so its nearest outside
    # pixel is as in the whole frame's map, which on a busy 640×480 frame took
    # 0.3 s of a 2.3 s run.
    h, w = labels.shape
    x0m, y0m = max(bx - 1, 0), max(by - 1, 0)
    x1m, y1m = min(bx + bw + 1, w), min(by + bh + 1, h)
    inside = (labels[y0m:y1m, x0m:x1m] == k).astype(np.uint8)
    d = cv2.distanceTransform(inside, cv2.DIST_L2, 5)[by - y0m:by - y0m + bh,
                                                      bx - x0m:bx - x0m + bw]
    i, j = np.unravel_index(int(np.argmax(d)), d.shape)
    # The distance is to the nearest pixel outside, so the inner disc's radius is
    # about half a pixel more.
    radius = float(d[i, j]) + 0.5
    if radius < 2.0 or np.pi * radius**2 < CORE_FRACTION * blob.area:
        return blob
    return Blob(float(bx + j + x0), float(by + i + y0), float(np.pi * radius**2),
                float(np.pi / 4), 1.0, cored=True)


#: The blob areas taken for a marker of known size, as multiples of its area.
AREA_GATE = (0.3, 3.0)


def choose_blob(blobs: list[Blob], expected_area: float | None = None,
                near: tuple[float, float] | None = None,
                sizes: tuple[float, float] = AREA_GATE,
                shape: Callable[[Blob], bool] = Blob.disc_like) -> tuple[Blob | None, str]:
    """Pick the marker among candidate blobs; returns ``(blob, status)``.

    Blobs must pass ``shape`` (disc-like by default; :meth:`MarkerSpec.takes` for
    a marker's own) and, once the marker's size is known, within 0.3–3× its area.
    Among those, the nearest to ``near`` wins, else the largest. ``status`` is
    ``"ok"``, ``"not_found"`` (no blob of the colour) or ``"rejected"`` (blobs of
    the colour, none of a marker's size and shape).
    """
    if not blobs:
        return None, "not_found"
    good = [b for b in blobs if shape(b)]
    if expected_area:
        good = [b for b in good
                if sizes[0] * expected_area <= b.area <= sizes[1] * expected_area]
    if not good:
        return None, "rejected"
    if near is not None:
        return min(good, key=lambda b: (b.x - near[0]) ** 2 + (b.y - near[1]) ** 2), "ok"
    return max(good, key=lambda b: b.area), "ok"


#: A frame whose median is darker than this (DN) is not white-balanced.
DARK_FRAME_DN = 40.0


def white_balance_gains(rgb: NDArray[np.uint8]) -> NDArray[np.float32]:
    """Per-channel gains that make the frame's median colour grey.

    The board and links fill most of a frame and are near-neutral, so a
    colour cast of the light shows in the median; dividing it out restores
    the hues the default colour windows expect. Sub-sampled for speed.

    A dark frame has no such board: its median is the sensor's noise, and the
    gains it gives (6× on one channel on a black table) turn every hue. Below a
    median of :data:`DARK_FRAME_DN` the frame is left as it is, and gains are
    bounded to 0.5–2 always.
    """
    med = np.median(rgb[::4, ::4].reshape(-1, 3), axis=0).astype(np.float32)
    if float(med.mean()) < DARK_FRAME_DN:
        return np.ones(3, np.float32)
    med = np.maximum(med, 1.0)
    return np.clip(med.mean() / med, 0.5, 2.0).astype(np.float32)


def balanced_hsv(rgb: NDArray[np.uint8], gains: NDArray[np.float32] | None) -> NDArray[np.uint8]:
    """HSV of ``rgb`` after per-channel white-balance ``gains``."""
    img = np.ascontiguousarray(rgb)
    if gains is not None:
        img = cv2.transform(img, np.diag(gains.astype(np.float64)))
    return cv2.cvtColor(img, cv2.COLOR_RGB2HSV)


def place_reach(radius: float) -> float:
    """How far (px) from where the user said a marker is (``@X,Y``) a blob of ``radius``
    px may lie to be taken for it there: its diameter and 8 px. A user gives the place
    from ``inspect`` or a click, within a few pixels. At 4 radii and 20 px, a knuckle of
    the hand holding Tracker's ball (radius 7.8 px), 43 px from the place, was taken for
    the ball a frame before the ball got there, with an invisible ±1 DN pattern added;
    the ball was then lost."""
    return 2.0 * radius + 8.0


def acquire(hsv: NDArray[np.uint8], spec: MarkerSpec, expected_area: float | None = None,
            near: tuple[float, float] | None = None,
            gates: tuple[tuple[float, float], ...] = (AREA_GATE,),
            find: Callable[[MarkerSpec], list[Blob]] | None = None
            ) -> tuple[Blob | None, str, list[Blob]]:
    """Full-frame search for ``spec``'s marker, over a ladder of saturation floors.

    A marker touching a faintly tinted background can merge with it at the
    user's floor and fail the shape test; at a higher floor it stands alone.
    All candidates from all floors compete in :func:`choose_blob`. Also
    returns the *rivals*: other blobs of the same colour, shape and size
    (within 2× the chosen one's area) elsewhere in the frame, so the caller
    can say that the choice was a guess. ``find(spec)`` gives the blobs of a spec in
    ``hsv`` (:func:`find_blobs` by default; a caller may keep them for the frame).
    """
    find = find or (lambda s: find_blobs(hsv, s))
    blobs: list[Blob] = []
    for extra in ((0.0,) if spec.tone else (0.0, 0.15, 0.3)):
        floor = min(spec.min_saturation + extra, 0.9)
        blobs += find(replace(spec, min_saturation=floor))
    for sizes in gates:  # the next, wider gate only when nothing passed the one before
        blob, status = choose_blob(blobs, expected_area, near, sizes, spec.takes)
        if blob is not None:
            break
    return blob, status, [] if blob is None else _rivals(blob, blobs, spec)


def _rivals(blob: Blob, blobs: list[Blob], spec: MarkerSpec) -> list[Blob]:
    """The blobs like ``blob`` (``spec.takes`` them, within 2× its area) more than 3 of its
    radii away, one per place: a blob within 2 radii of one already taken is the
    same one seen at another saturation floor. The places taken are kept in a grid
    of cells 2 radii wide, so only neighbouring cells are compared: with each taken
    place compared with every blob, a lost yellow marker's whole-frame searches in
    OpenCV's vtest.avi (thousands of blobs of the grass) took 8 of its 8.6 s."""
    r = blob.radius
    reach2, far2 = (2.0 * r) ** 2, (3.0 * r) ** 2
    cell = max(2.0 * r, 1e-6)
    taken: dict[tuple[int, int], list[Blob]] = {}
    rivals: list[Blob] = []
    for b in blobs:
        if (b.x - blob.x) ** 2 + (b.y - blob.y) ** 2 <= far2 \
                or not 0.5 * blob.area <= b.area <= 2.0 * blob.area or not spec.takes(b):
            continue
        i, j = int(b.x // cell), int(b.y // cell)
        if any((b.x - q.x) ** 2 + (b.y - q.y) ** 2 < reach2
               for di in (-1, 0, 1) for dj in (-1, 0, 1) for q in taken.get((i + di, j + dj), ())):
            continue
        rivals.append(b)
        taken.setdefault((i, j), []).append(b)
    return rivals


def learn_spec(spec: MarkerSpec, hsv: NDArray[np.uint8], centre: tuple[float, float],
               radius: float, x0: int, y0: int) -> MarkerSpec:
    """A spec re-centred on the hue actually seen in the marker's middle.

    Lighting shifts hues; the learned window is centred on the circular
    median hue of the pixels within 0.6 of the radius that are saturated enough
    to be the marker's colour, ±15° or three times their spread, whichever is
    wider, but never wider than the window asked for: an orange road cone with
    a red reflector and grey tape across its middle (OpenCV's vtest.avi) learned
    ±140°, took in the grass, and was found in a third of the frames it was in
    view. The saturation and value floors stay, so blurred edges still count.
    ``hsv`` is an OpenCV 8-bit HSV patch whose top-left pixel is at (x0, y0).
    """
    if spec.tone:
        return spec  # a luminance marker has no hue to learn
    h, w = hsv.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    inner = (xx + x0 - centre[0]) ** 2 + (yy + y0 - centre[1]) ** 2 <= (0.6 * radius) ** 2
    inner &= hsv[..., 1] >= round(spec.min_saturation * 255)
    if inner.sum() < 3:
        return spec
    hue = np.radians(hsv[..., 0][inner].astype(float) * 2.0)
    mean = np.arctan2(np.sin(hue).mean(), np.cos(hue).mean())
    spread = np.degrees(np.abs(np.angle(np.exp(1j * (hue - mean)))))
    tol = max(15.0, 3.0 * float(np.median(spread)) * 1.4826)
    return replace(spec, hue_deg=float(np.degrees(mean) % 360.0),
                   hue_tol_deg=min(tol, max(spec.hue_tol_deg, 15.0)))
