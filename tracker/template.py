"""A marker with no colour of its own, followed by how it looks: template matching.

A steel ball falling past a tape measure (a student's 1000 fps free-fall clip) is
darker than its ground at its rim, a little brighter inside and bright where it
mirrors the lamps. No colour or tone finds it whole. What stays the same from frame
to frame is its picture, so the user places it once (``--marker
ball=template@X,Y,R``: its centre and radius, px) and its pixels within R − 1 px
of that place become its template. In each later frame the template is matched
around the marker's predicted place by normalised cross-correlation (OpenCV's
``TM_CCOEFF_NORMED``, with the template's disc as the mask, so the ground the
ball passes over is left out and the match is blind to the frame's brightness
and contrast). The best match's centre is taken to a fraction of a pixel by a
parabola through the scores on either side, on each axis. What places it is
therefore what it shows inside its outline (highlights, shading, print): a plain
disc of one colour has nothing there (:attr:`Template.plain`), and is a colour or
tone marker's work.

The template is never updated: a template taken again from each fix carries
that fix's error into every later one, and the fixes walk. The match therefore
holds while the marker looks as it first did: turning, seen from another side or
partly hidden, it is lost, and the run says so (``not_found``, ``partly_covered``
or ``rejected``: :func:`.track._locate_by_template`).

The centre is the point the user placed, carried along: a click 2 px off the
ball's middle gives a track 2 px off it in every frame. Motion, speed and
acceleration are untouched by that offset.

1-σ (px per axis) is the Cramér–Rao bound of a shift between two pictures,
σ² = s² / Σ (gain · ∂T/∂x)², with s the RMS of what the template, scaled and
offset to the frame, leaves unexplained (noise, and whatever has changed in
its look), and ∂T/∂x the template's gradient; the larger axis's is given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

#: How far inside the given radius the template's disc ends (px). Its rim, partly
#: the ground behind it, is left out with the ground: on a drawn steel ball falling
#: across a bright bar, a disc 2 px past the rim put the fixes 0.5 px off while the
#: bar lay in that ring, against 0.04 px without it.
INSIDE_PX = 1.0
#: A picture whose spread (its grey levels' standard deviation) is under this many
#: times its noise holds nothing to follow (:attr:`Template.plain`): a plain grey disc
#: drawn with 1.5 DN of noise had 1.2, the test's drawn steel ball 16, the free-fall
#: clip's ball 44.
PLAIN_CONTRAST = 3.0
#: A match scoring this much under the marker's usual (the running mean of the matches
#: taken) is taken for the marker partly hidden, or for something else
#: (:func:`.track._locate_by_template`). On the free-fall clip the ball's score falls
#: from 1 to 0.81 over 200 frames, by at most 0.008 in a frame.
SCORE_DROP = 0.1
#: A match below this normalised correlation is not the marker. On the free-fall
#: clip the ball's matches fall from 1 to 0.81 as it drops 700 px under the lamps,
#: and the likest other place in its first frame scores 0.63 (the run's later checks
#: judge matches above this floor: :func:`.track._locate_by_template`).
LEAST_SCORE = 0.5


@dataclass(frozen=True)
class Template:
    """A marker's picture (luminance, DN, float32) and the disc of it that is matched.

    ``anchor`` is where the marker's centre lies in ``picture`` (x, y px from its
    top-left pixel's centre); ``radius`` the radius the user gave (px)."""

    picture: NDArray[np.float32]
    mask: NDArray[np.float32]
    anchor: tuple[float, float]
    radius: float
    #: Where its centre was in the frame it was taken from (px).
    taken_at: tuple[float, float]
    #: The smaller of Σ (∂T/∂x)² and Σ (∂T/∂y)² over the mask (DN²): how sharply the
    #: picture places a shift on its weaker axis (:func:`_sigma`).
    energy: float
    #: The picture's noise (DN, :func:`noise_dn`).
    noise: float
    #: The standard deviation of its grey levels over the mask (DN): what it shows.
    spread: float
    #: The likest other place in the frame it was taken from (x, y px, score): how
    #: like the marker something else in the scene looks (:func:`likest_other`).
    rival: tuple[float, float, float] = (np.nan, np.nan, -1.0)

    @property
    def contrast(self) -> float:
        """How many times its noise the picture's spread is."""
        return self.spread / self.noise if self.noise > 0.0 else math.inf

    @property
    def plain(self) -> bool:
        """Does the picture hold little more than its noise (its spread under
        :data:`PLAIN_CONTRAST` times the noise), so that there is nothing to follow?"""
        return self.contrast < PLAIN_CONTRAST

    @property
    def unlike(self) -> float:
        """How unlike its picture a later match of the marker is expected to be, from
        the noise alone (1 − the correlation of two noisy copies): the noise's share
        of the picture's variance."""
        return min(self.noise**2 / self.spread**2, 1.0) if self.spread > 0.0 else 1.0

    @property
    def sigma(self) -> float:
        """The 1-σ (px) of the place the picture was taken about, against the fixes
        that match it later: its own noise over its gradient energy."""
        return self.noise / math.sqrt(self.energy) if self.energy > 0.0 else math.inf

    @property
    def half(self) -> int:
        """Half the template's side (px): it is 2 · half + 1 square."""
        return self.picture.shape[0] // 2


@dataclass(frozen=True)
class Match:
    """Where a template was found: centre (px), per-axis 1-σ (px), the normalised
    correlation of the match (−1…1) and the RMS of what it leaves unexplained (DN).
    ``bordered``: the best place lies on the border of the places tried, so a better
    one may lie past it (and the centre is read to the whole pixel on that axis)."""

    x: float
    y: float
    sigma: float
    score: float
    rms_residual: float
    bordered: bool = False


def template_half(radius: float) -> int:
    """Half the side (px) of the square that holds the template of a marker of ``radius`` px."""
    return math.ceil(radius - INSIDE_PX)


def take_template(luma: NDArray, x0: int, y0: int, centre: tuple[float, float],
                  radius: float) -> Template:
    """The template of a marker centred at ``centre`` (px, in the frame) with
    ``radius`` (px), from ``luma``: the frame's luminance (DN) from column ``x0``
    and row ``y0``, which must hold the whole square (:func:`template_half`).

    Raises ValueError if it does not."""
    half = template_half(radius)
    ix, iy = round(centre[0]), round(centre[1])
    top, left = iy - half - y0, ix - half - x0
    if top < 0 or left < 0 or top + 2 * half + 1 > luma.shape[0] \
            or left + 2 * half + 1 > luma.shape[1]:
        raise ValueError("the template's square does not lie on the pixels given")
    picture = np.ascontiguousarray(luma[top:top + 2 * half + 1, left:left + 2 * half + 1],
                                   dtype=np.float32)
    anchor = (centre[0] - (ix - half), centre[1] - (iy - half))
    yy, xx = np.mgrid[:2 * half + 1, :2 * half + 1]
    inside = np.hypot(xx - anchor[0], yy - anchor[1]) <= radius - INSIDE_PX
    gy, gx = np.gradient(picture.astype(np.float64))
    energy = min(float(np.sum(gx[inside]**2)), float(np.sum(gy[inside]**2)))
    mask = inside.astype(np.float32)
    return Template(picture, mask, anchor, float(radius), (float(centre[0]), float(centre[1])),
                    energy, noise_dn(picture, mask), float(np.std(picture[inside])))


def fits_on(centre: tuple[float, float], radius: float, size: tuple[int, int]) -> bool:
    """Does the template of a marker at ``centre`` with ``radius`` (px) lie wholly on a
    frame of ``size`` (width, height px)?"""
    half = template_half(radius)
    ix, iy = round(centre[0]), round(centre[1])
    return half <= ix < size[0] - half and half <= iy < size[1] - half


def nearly_as_like(template: Template, score: float) -> bool:
    """Does a match of ``score`` come within :data:`SCORE_DROP` of what the marker itself
    is expected to score, its noise alone taken away (:attr:`Template.unlike`)?"""
    return score >= 1.0 - template.unlike - SCORE_DROP


def likest_other(luma: NDArray, template: Template) -> tuple[float, float, float]:
    """The best match of ``template`` in ``luma`` (the whole frame it was taken from, DN)
    more than its own width from where it was taken: (x, y, score), its centre in px;
    score −1 where there is no other place."""
    side = template.picture.shape[0]
    frame = np.ascontiguousarray(luma, dtype=np.float32)
    if frame.shape[0] < side or frame.shape[1] < side:
        return (np.nan, np.nan, -1.0)
    scores = cv2.matchTemplate(frame, template.picture, cv2.TM_CCOEFF_NORMED,
                               mask=template.mask)
    scores = np.nan_to_num(scores, nan=-1.0, posinf=-1.0, neginf=-1.0)
    # Its own place, and the places whose template overlaps it by half or more.
    col = round(template.taken_at[0] - template.anchor[0])
    row = round(template.taken_at[1] - template.anchor[1])
    scores[max(row - side, 0):row + side + 1, max(col - side, 0):col + side + 1] = -1.0
    row, col = np.unravel_index(int(np.argmax(scores)), scores.shape)
    return (float(col + template.anchor[0]), float(row + template.anchor[1]),
            float(scores[row, col]))


def noise_dn(picture: NDArray, mask: NDArray) -> float:
    """The noise (1-σ, DN) of ``picture`` within ``mask``, by Immerkær's estimate: the
    mean absolute response to a filter that cancels any plane and any quadratic
    shading, over the pixels whose 3×3 neighbours all lie in the mask (so the
    marker's outline does not count). Texture finer than that counts as noise.
    (J. Immerkær, "Fast noise variance estimation", 1996.)"""
    kernel = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float64)
    response = cv2.filter2D(np.asarray(picture, np.float64), -1, kernel,
                            borderType=cv2.BORDER_REPLICATE)
    inner = cv2.erode(np.asarray(mask, np.uint8), np.ones((3, 3), np.uint8)) > 0
    if not inner.any():
        return math.inf
    return float(math.sqrt(math.pi / 2.0) * np.mean(np.abs(response[inner])) / 6.0)


def _vertex(before: float, at: float, after: float) -> float:
    """Where a parabola through three scores one pixel apart peaks, relative to the
    middle one (px, within ±0.5 when the middle one is the largest)."""
    curve = before - 2.0 * at + after
    if not curve < 0.0:  # flat or not a peak: keep the whole pixel
        return 0.0
    return float(np.clip(0.5 * (before - after) / curve, -0.5, 0.5))


def _sigma(template: Template, window: NDArray[np.float32], col: int, row: int
           ) -> tuple[float, float]:
    """The per-axis 1-σ (px) of a match whose template lies at column ``col`` and row
    ``row`` of ``window``, and the RMS (DN) of what the template, scaled and offset to
    the window by least squares over its mask, leaves there."""
    side = template.picture.shape[0]
    seen = window[row:row + side, col:col + side]
    inside = template.mask > 0
    t = template.picture[inside].astype(np.float64)
    s = seen[inside].astype(np.float64)
    design = np.column_stack([t, np.ones_like(t)])
    (gain, offset), *_ = np.linalg.lstsq(design, s, rcond=None)
    residual = s - gain * t - offset
    # Two parameters are taken from the pixels (gain and offset) before the scatter.
    rms = float(np.sqrt(np.sum(residual**2) / max(t.size - 2, 1)))
    energy = template.energy * gain**2
    sigma = rms / math.sqrt(energy) if energy > 0.0 else math.inf
    return sigma, rms


def match_template(luma: NDArray, x0: int, y0: int, template: Template
                   ) -> Match | None:
    """The best place of ``template`` in ``luma``, the frame's luminance (DN) from
    column ``x0`` and row ``y0`` (px); None where the pixels are narrower than the
    template plus one pixel each way, or no place scores :data:`LEAST_SCORE`.

    Examples
    --------
    A textured patch taken about (30.5, 25.0), found again after the picture has moved
    2 px left and 3 px down, so at (28.5, 28.0). On a texture of pixel-sized grain the
    parabola through the scores reads the peak to about a hundredth of a pixel:

    >>> import numpy as np
    >>> scene = np.random.default_rng(1).normal(100.0, 20.0, (60, 80))
    >>> template = take_template(scene, 0, 0, (30.5, 25.0), 8.0)
    >>> found = match_template(np.roll(scene, (3, -2), axis=(0, 1)), 0, 0, template)
    >>> round(float(found.x), 3), round(float(found.y), 3), round(found.score, 3)
    (28.488, 28.004, 1.0)
    """
    side = template.picture.shape[0]
    window = np.ascontiguousarray(luma, dtype=np.float32)
    if window.shape[0] < side + 2 or window.shape[1] < side + 2:
        return None
    scores = cv2.matchTemplate(window, template.picture, cv2.TM_CCOEFF_NORMED,
                               mask=template.mask)
    # A flat window (a black frame) gives 0/0: no match there.
    scores = np.nan_to_num(scores, nan=-1.0, posinf=-1.0, neginf=-1.0)
    row, col = np.unravel_index(int(np.argmax(scores)), scores.shape)
    best = float(scores[row, col])
    if best < LEAST_SCORE:
        return None
    h, w = scores.shape
    dx = _vertex(scores[row, col - 1], best, scores[row, col + 1]) if 0 < col < w - 1 else 0.0
    dy = _vertex(scores[row - 1, col], best, scores[row + 1, col]) if 0 < row < h - 1 else 0.0
    sigma, rms = _sigma(template, window, int(col), int(row))
    return Match(x0 + col + dx + template.anchor[0], y0 + row + dy + template.anchor[1],
                 sigma, best, rms, not (0 < col < w - 1 and 0 < row < h - 1))


def search_box(template: Template, guess: tuple[float, float], reach: float,
               size: tuple[int, int]) -> tuple[int, int, int, int] | None:
    """The pixels (x0, y0, x1, y1) to match ``template`` in for a marker expected at
    ``guess`` (px), up to ``reach`` px away each way, cut to a frame of ``size``
    (width, height px); None where too little of it lies on the frame."""
    half = template.half
    w, h = size
    x0 = max(math.floor(guess[0] - reach) - half - 1, 0)
    y0 = max(math.floor(guess[1] - reach) - half - 1, 0)
    x1 = min(math.ceil(guess[0] + reach) + half + 2, w)
    y1 = min(math.ceil(guess[1] + reach) + half + 2, h)
    if x1 - x0 < 2 * half + 3 or y1 - y0 < 2 * half + 3:
        return None
    return x0, y0, x1, y1


@dataclass(frozen=True)
class Placement:
    """What a template marker placed in one frame would follow (``cranktrack inspect
    --marker NAME=template@X,Y,R``): its picture (how far it stands above its noise is
    :attr:`Template.contrast`), the likest other place in that frame (x, y px, score),
    and its best match over the whole of a later frame (None: no place scores
    :data:`LEAST_SCORE`, or no later frame)."""

    template: Template
    rival: tuple[float, float, float]
    later: Match | None


def judge_placement(luma: NDArray, centre: tuple[float, float], radius: float,
                    later: NDArray | None = None) -> Placement:
    """:class:`Placement` of a marker centred at ``centre`` with ``radius`` (px) in a
    whole frame's luminance ``luma`` (DN), and its match in ``later``'s (DN).

    Raises ValueError where its picture reaches past the frame."""
    if not fits_on(centre, radius, (luma.shape[1], luma.shape[0])):
        raise ValueError("the template's square does not lie on the frame")
    template = take_template(luma, 0, 0, centre, radius)
    found = None if later is None else match_template(later, 0, 0, template)
    return Placement(template, likest_other(luma, template), found)
