"""A marker's sub-pixel centre with a 1-σ uncertainty: which fit, on which patch.

Each fit works on the marker's coverage image (:mod:`.coverage`):

- :func:`.centre.weighted_centroid`: the α-weighted centroid inside a circular
  window re-centred on the estimate a few times; a rough start at acquisition.
- :func:`.disc.fit_disc`: least squares of a blurred-disc model
  ``α = b + a·Φ((r − d)/s)`` by Gauss–Newton; σ from the residual and the
  Jacobian. On a decoder's 4:2:0 planes it is refitted on the chroma cells
  (:func:`.disc.fit_disc_cells`).
- :func:`.edges.fit_edges`: where every pixel has its own colour, the luminance
  of the edge's clean sectors is added (most of the information is there).
- :func:`.outline.fit_outline`: the circle through the rim, for a shaded ball.
- :func:`.centre.blob_centroid`: the centroid of the coverage of a marker that is
  not a disc (a strip, a square, a motion-blurred streak), by :func:`refine_blob`.

:func:`refine` chooses among the first four for one marker in one frame.
``bench/accuracy.py`` measures them against ``truth.csv`` and the
Cramér–Rao bound; ``bench/README.md`` says which won.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from .binned import BinnedFrame, from_bins, to_bins
from .centre import Centre, blob_centroid, core_peak, weighted_centroid
from .coverage import local_coverage
from .disc import correlated_sigma, fit_disc, fit_disc_cells, line_across
from .edges import fit_edges
from .outline import fit_outline, rim_coverage
from .video import Frame


def patch_around(image: Frame | BinnedFrame | NDArray, cx: float, cy: float, half: float
           ) -> tuple[NDArray[np.uint8], int, int]:
    """The pixels within ``half`` px of (cx, cy), clipped to the image, and the
    patch's top-left pixel. ``image`` is a frame (converted to RGB only
    there), a frame seen block by block, or an array (RGB, HSV). Around a point off
    the image the patch is empty (a coverage centroid pulled by a wide bright area
    walked off a frame of OpenCV's vtest.avi)."""
    framed = isinstance(image, Frame | BinnedFrame)
    w, h = image.size if framed else (image.shape[1], image.shape[0])
    x0, y0 = min(max(int(cx - half), 0), w), min(max(int(cy - half), 0), h)
    x1, y1 = max(min(int(cx + half) + 1, w), x0), max(min(int(cy + half) + 1, h), y0)
    if framed:
        return image.region(x0, y0, x1, y1), x0, y0
    return image[y0:y1, x0:x1], x0, y0


#: An edge this wide (px, the disc model's Gaussian blur) or wider is soft: out of
#: focus, not the pixel's averaging or the codec's chroma (under 1.5 px).
SOFT_EDGE_PX = 3.0
#: ...on a disc with a plateau, its radius at least this many edge widths: a blob
#: whose fit is all edge (a small sign, blurred) is no soft disc, and a wider window
#: only takes in its neighbours.
SOFT_PLATEAU = 1.5
#: How many edge widths past its rim a soft-edged disc's coverage window reaches.
SOFT_REACH = 2.0
#: ...at most this many times the radius asked for.
SOFT_MAX = 3.0


#: A marker found by its colour, of this radius (px) or more, in a frame whose pixels
#: share their colour (4:2:0, 4:2:2, JPEG) is fitted on the frame seen block by block
#: (:mod:`.binned`, :func:`_refine_binned`). In 1080p H.264 (bench/large_markers.py)
#: discs of radius 30 px were followed at decoding speed, 60 px at half of it; seen
#: block by block, 60 px at 0.88 of it, with errors 0.026-0.030 px RMS against
#: 0.028-0.031 pixel by pixel.
LARGE_RADIUS_PX = 32.0


def refine(image: Frame | BinnedFrame | NDArray[np.uint8], guess: tuple[float, float],
           radius: float,
           marker: NDArray | None = None, init: tuple[float, ...] | None = None,
           edges: bool | None = None, luminance: bool = False, rim: bool | None = None,
           wire: bool = False, hold_shape: bool = False,
           wire_line: tuple[tuple[float, float], tuple[float, float]] | None = None,
           stretch: tuple[float, float, float] | None = None
           ) -> tuple[Centre, NDArray | None]:
    """Sub-pixel centre of a marker near ``guess`` (see the module's docstring).

    Chroma unmixing against a ring background, then a blurred-disc fit. A
    rough guess (an acquisition: no ``init``) is first improved by a
    weighted centroid and the ring re-centred there; a prediction from the
    previous frames (with ``init``, that frame's fitted shape) goes straight
    to the fit. ``marker`` is the learned marker chroma (None at
    acquisition). ``edges`` adds the luminance of the edge's clean sectors
    (:func:`.edges.fit_edges`); by default it does so for frames with
    full-resolution chroma (:attr:`Frame.full_chroma`), not for arrays. On
    the decoder's own 4:2:0 planes the centre and σ are refitted at the
    chroma's resolution instead (:func:`.disc.fit_disc_cells`).
    ``luminance`` unmixes brightness instead of chroma (a white or black marker:
    luminance is stored at full resolution, so no chroma-cell refit).
    With ``rim`` True the centre is the circle through the marker's rim
    instead (:func:`.outline.fit_outline`: a shaded ball, a bead on its
    string); with ``rim`` None (not yet known which the marker is) that circle
    is taken where the disc fit fails; with False never (a flat marker whose
    disc fit fails is partly hidden, and its rim would be half the cover's
    edge).
    ``wire``: a thin dark line across the disc (a wire, a thread) is left out of the
    fit (:func:`.disc.line_across`), as on the crank-slider's printed discs, which
    its wire crosses; off for other markers, whose own stripes (a cone's tape) are
    theirs.
    ``hold_shape`` keeps the radius and edge width at ``init``'s (:func:`.disc.fit_disc`).
    ``wire_line``: the crank-slider's wire's ends, B and C (px); a followed printed disc
    it crosses (A), or one of its ends out of focus (edge :data:`BAND_EDGE_PX` or
    more), is fitted without the band the wire and its shadow darken
    (:func:`wire_band`), at the wire's ends with its shape held where that band is
    widest (:func:`_held_beside_band`).
    A marker of :data:`LARGE_RADIUS_PX` or more, found by its colour in a frame whose
    pixels share their colour, is fitted on the frame seen block by block
    (:func:`_refine_binned`), where its σ lets neighbouring blocks share errors
    (:func:`.disc.correlated_sigma`).
    ``stretch``: a printed disc seen by a camera not square to its plane is an ellipse,
    whose metric (:func:`.disc.stretch_of`, from :mod:`.foreshortening`) the disc fits,
    the dark-line search, the chroma-cell refit and the luminance edge
    (:func:`.edges.fit_edges`) take. The rim's circle (a ball's) stays round.
    Returns the centre and the chroma seen in its middle.
    """
    if radius >= LARGE_RADIUS_PX and isinstance(image, Frame) and not image.full_chroma \
            and not luminance:
        return _refine_binned(image, guess, radius, marker, init, edges, luminance, rim,
                              wire, hold_shape, wire_line, stretch)
    if rim is True and init is not None:
        # Following a ball: its rim has a coverage of its own, so the disc fit's is
        # not made at all; its centre is taken at its learned radius, ``radius``
        # (:data:`.outline.HOLD_BAND`).
        return _rim(image, guess, radius, marker, luminance, hold=radius)
    unit = _unit_px(image)
    patch, x0, y0 = patch_around(image, guess[0], guess[1], radius + 9)
    alpha, seen = local_coverage(patch, x0, y0, guess, radius, marker, luminance, unit,
                                 by_edge=True)
    c = None
    if init is None:
        c = weighted_centroid(alpha, x0, y0, guess, radius, noise_alpha=0.05)
        if not c.ok:
            return c, seen
        guess = (c.x, c.y)
        alpha, seen = local_coverage(patch, x0, y0, guess, radius, marker, luminance, unit,
                                     by_edge=True)
    if rim is True:
        return _rim(image, guess, radius, marker, luminance)
    if edges is None:
        # On 4:2:0 H.264 a moving marker's luminance edge is off by 2–3× what the
        # fit's residual says (bench/luminance.py): only full-chroma frames use it.
        edges = isinstance(image, Frame) and image.full_chroma
    # On the decoder's 4:2:0 planes the centre is refitted on the chroma cells
    # below, so the pixel fit need only be close (its shape and residual are for
    # the checks): 0.02 px instead of 0.001 saves an iteration or two.
    cells = (not edges and not luminance and isinstance(image, Frame)
             and image.layout == "i420")
    tol = 0.02 if cells else 1e-3
    hold = hold_shape and init is not None
    band = None
    if wire and wire_line is not None and init is not None and len(init) >= 4 \
            and _off_line(guess, wire_line) <= radius \
            and (init[3] >= BAND_EDGE_PX or not _at_wire_end(guess, wire_line, radius)):
        band = wire_band(alpha.shape, x0, y0, wire_line, init[3], radius)
        whole, alpha = alpha, np.where(band, np.nan, alpha)
        hold = hold or _held_beside_band(guess, wire_line, init[3], radius)
    fit = fit_disc(alpha, x0, y0, guess, radius, init=init, tol_px=tol, hold_shape=hold,
                   stretch=stretch)
    for _ in range(3):
        # The background ring must be centred on the marker; a guess more than
        # half a pixel off (a prediction when the motion changes) is redone.
        if not fit.ok or np.hypot(fit.x - guess[0], fit.y - guess[1]) <= 0.5:
            break
        guess = (fit.x, fit.y)
        patch, x0, y0 = patch_around(image, guess[0], guess[1], radius + 9)
        alpha, seen = local_coverage(patch, x0, y0, guess, radius, marker, luminance, unit,
                                     by_edge=True)
        if band is not None:
            band = wire_band(alpha.shape, x0, y0, wire_line, init[3], radius)
            whole, alpha = alpha, np.where(band, np.nan, alpha)
        fit = fit_disc(alpha, x0, y0, guess, radius, init=fit.params, tol_px=tol,
                       hold_shape=hold, stretch=stretch)
    if fit.ok and not hold and not wire:
        # Not for the crank-slider's printed discs: on clips with no markers, soft patches
        # of their colours were then taken for them more often, and on its bed filmed out
        # of focus θ stayed off by 0.46° (bench/README.md, stop 49; the run says so).
        fit, alpha, patch, x0, y0, radius = _soft_refit(image, fit, alpha, patch, x0, y0,
                                                        radius,
                                                        seen if marker is None else marker,
                                                        luminance, tol, unit, stretch)
    if band is not None and fit.ok:
        # The checks of a whole marker compare its visible area with its usual, which
        # counts the wire's band too (as for a line found across it, below).
        fit = replace(fit, area=fit.area + _band_area(whole, band, x0, y0, guess, radius))
    fitted = alpha
    hidden, start = (_line_across(alpha, x0, y0, fit, init, stretch) if wire and band is None
                     else (None, fit.params))
    if hidden is not None:
        # A wire or thread across the disc: fitted again without its pixels.
        clear = np.where(hidden, np.nan, alpha)
        again = fit_disc(clear, x0, y0, guess, radius, init=start, tol_px=tol,
                         hold_shape=hold, stretch=stretch)
        if again.ok:
            # The marker's visible area is all its coverage, the line's pixels too:
            # the checks for a covered marker compare it with its usual.
            fit, fitted = replace(again, area=fit.area), clear
    if fit.ok and edges:
        fit = fit_edges(patch, fitted, x0, y0, fit, radius, stretch=stretch) or fit
    elif fit.ok and cells:
        # The decoder's own 4:2:0 planes: the chroma is refitted where it was stored.
        fit = fit_disc_cells(fitted, x0, y0, fit, stretch)
    elif fit.ok and isinstance(image, BinnedFrame):
        fit = correlated_sigma(fitted, x0, y0, guess, radius, fit, hold, stretch)
    if fit.ok:
        return replace(fit, peak=core_peak(alpha, x0, y0, fit)), seen
    if rim is None:
        # Perhaps not a flat disc (a shaded ball, a bead on its string): its rim.
        outline, _ = _rim(image, guess, radius, marker, luminance)
        if outline.ok:
            return outline, seen
    if c is None:
        return fit, seen
    return Centre(c.x, c.y, c.sigma, c.radius, True), seen


def _unit_px(image: Frame | BinnedFrame | NDArray) -> float:
    """How many frame px one of ``image``'s pixels spans: 2 on a frame seen block by
    block (:mod:`.binned`), whose coverage keeps its background ring where it is in px."""
    return image.unit_px if isinstance(image, BinnedFrame) else 1.0


def _refine_binned(frame: Frame, guess: tuple[float, float], radius: float,
                   marker: NDArray | None, init: tuple[float, ...] | None, edges: bool | None,
                   luminance: bool, rim: bool | None, wire: bool, hold_shape: bool,
                   wire_line: tuple[tuple[float, float], tuple[float, float]] | None,
                   stretch: tuple[float, float, float] | None = None
                   ) -> tuple[Centre, NDArray | None]:
    """:func:`refine` of a large marker on ``frame`` seen block by block
    (:class:`.binned.BinnedFrame`), everything in px mapped there and back: the centre,
    σ, radius and shape (centre, radius, edge width; gain and offset are coverage),
    and the visible area (px²)."""

    def point_in(p: tuple[float, float]) -> tuple[float, float]:
        return to_bins(p[0]), to_bins(p[1])

    def shape_in(p: tuple[float, ...]) -> tuple[float, ...]:
        if len(p) < 6:  # (radius, edge, gain, offset) alone
            return (p[0] / 2, p[1] / 2, *p[2:])
        return (to_bins(p[0]), to_bins(p[1]), p[2] / 2, p[3] / 2, *p[4:])

    centre, seen = refine(BinnedFrame(frame), point_in(guess), radius / 2, marker,
                          None if init is None else shape_in(tuple(init)), edges, luminance,
                          rim, wire, hold_shape,
                          None if wire_line is None else (point_in(wire_line[0]),
                                                          point_in(wire_line[1])), stretch)
    p = centre.params
    return replace(centre, x=from_bins(centre.x), y=from_bins(centre.y),
                   sigma=2 * centre.sigma, radius=2 * centre.radius, area=4 * centre.area,
                   length_px=2 * centre.length_px, width_px=2 * centre.width_px,
                   params=None if p is None else (from_bins(p[0]), from_bins(p[1]),
                                                  2 * p[2], 2 * p[3], *p[4:])), seen


#: A printed disc the wire crosses is fitted without a band along it (:func:`wire_band`);
#: at the wire's ends, B and C, only when its edge is blurred over this many px or more
#: (out of focus; 1.2-1.5 in focus on H.264). In focus, B and C are fitted without the
#: wire's pixels found as a dark line (:func:`_line_across`): with the band, B moved
#: further off on the second renderer's bed (θ 0.0864 / 0.0572° -> 0.0870 / 0.0677°).
#: On A the dark line found is not enough: where the wire swept across A's rim it moved
#: A by 0.2-0.3 px across the wire, and θ's error on that bed was 0.207 / 0.166° RMS;
#: with the band, 0.106 / 0.098° (bench/README.md, stop 53).
BAND_EDGE_PX = 1.8
#: ...as wide as the wire's shadow spreads: this many edge widths either side, and
#: WIRE_HALF_PX for the wire itself.
BAND_EDGES = 1.5
WIRE_HALF_PX = 1.0
#: ...but at most this fraction of the disc's radius either side.
BAND_MOST = 0.5
#: At B and C a disc whose band would be this many times as wide as it may be is fitted
#: with its shape held (:func:`_held_beside_band`).
HOLD_OVER = 1.2
#: ...and only with an edge this wide (px): well out of focus (2 px and more is,
#: :data:`.marker_state.OUT_OF_FOCUS_EDGE_PX`), not a small disc in focus.
HOLD_EDGE_PX = 3.0


def wire_band_half_px(edge_px: float, radius: float) -> float:
    """Half the width (px) of the wire's band across a printed disc whose edge is blurred
    over ``edge_px`` (px), of ``radius`` px: :data:`WIRE_HALF_PX` + :data:`BAND_EDGES`
    edge widths, at most :data:`BAND_MOST` of the radius."""
    return min(WIRE_HALF_PX + BAND_EDGES * edge_px, BAND_MOST * radius)


def _held_beside_band(guess: tuple[float, float],
                      line: tuple[tuple[float, float], tuple[float, float]], edge_px: float,
                      radius: float) -> bool:
    """Is a printed disc at ``guess`` (px), at one end of the wire ``line`` (B's or C's,
    within ``radius`` of the end), blurred so far (edge ``edge_px``) that its band would
    be :data:`HOLD_OVER` times as wide as :data:`BAND_MOST` of the radius lets it be,
    with an edge of :data:`HOLD_EDGE_PX` or more, fitted with its radius and edge held
    at its last fit's? Half a strip and more of one side is then left out, and the
    fit's edge and gain trade off over what is left: on the second renderer's SMA bed
    4 px out of focus, C came out at an edge of 6.4 px and a gain of 1.9 (4.4 and 1.4
    the frame before) and was refused in 13 of its first 15 frames.

    Held wherever a band is left out, A's fits with the wire across it and B's in
    focus, where a frame's edge reached the band's threshold, came out worse; held from
    the band's cap itself (1.0), C drawn 3 px out of focus was 0.14 px off, against
    0.12 with the band along the whole line; and held on the project's own 480×270
    render (discs of 5.6 px, edges 1.6–1.8 px, whose band is capped by the small
    radius), C moved 0.04 px toward B (bench/README.md, stop 52)."""
    wanted = WIRE_HALF_PX + BAND_EDGES * edge_px
    return bool(_at_wire_end(guess, line, radius) and wanted >= HOLD_OVER * BAND_MOST * radius
                and edge_px >= HOLD_EDGE_PX)


def _at_wire_end(guess: tuple[float, float],
                 line: tuple[tuple[float, float], tuple[float, float]], radius: float) -> bool:
    """Is a disc at ``guess`` (px) one of the wire's ends, B or C (``line``): within
    ``radius`` of one?"""
    return min(math.hypot(guess[0] - p[0], guess[1] - p[1]) for p in line) <= radius


def _across(x: NDArray | float, y: NDArray | float,
            line: tuple[tuple[float, float], tuple[float, float]]) -> NDArray | float:
    """Distance (px) of points ``x, y`` from the line through the two points of ``line``
    (from its first point where the two coincide)."""
    (ax, ay), (bx, by) = line
    norm = float(np.hypot(bx - ax, by - ay))
    if norm < 1e-6:
        return np.hypot(x - ax, y - ay)
    return np.abs((x - ax) * (by - ay) - (y - ay) * (bx - ax)) / norm


def _off_line(point: tuple[float, float],
              line: tuple[tuple[float, float], tuple[float, float]]) -> float:
    """Distance (px) from ``point`` to the line through the two points of ``line``."""
    return float(_across(point[0], point[1], line))


def wire_band(shape: tuple[int, ...], x0: int, y0: int,
               line: tuple[tuple[float, float], tuple[float, float]], edge_px: float,
               radius: float) -> NDArray:
    """Pixels of a patch (``shape``, top-left ``x0, y0``) within the wire's blurred shadow:
    those within :data:`WIRE_HALF_PX` + :data:`BAND_EDGES` edge widths, at most
    :data:`BAND_MOST` of the disc's ``radius``, of the wire, which runs from B to C
    (``line``, px) and ends at both: tied at the crank's tip, its end at the slider.
    At B and C the band is half a strip, on the side the wire leaves by, with a round
    end: the shadow darkens that side only. A band along the whole line, as at first,
    left out as much of the other side, whose edge then pulled the fit away from the
    wire: on the second renderer's SMA bed 4 px out of focus B sat 0.44 px off along
    the wire, 0.36 with the half band (bench/README.md, stop 52); across A it leaves
    out what the wire darkens, as before."""
    (bx, by), (cx, cy) = line
    if np.hypot(cx - bx, cy - by) < 1e-6:
        return np.zeros(shape[:2], bool)
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    x, y = xx + x0, yy + y0
    # Distance to the segment: beyond either end, to that end.
    dist = np.where((x - bx) * (cx - bx) + (y - by) * (cy - by) < 0.0, np.hypot(x - bx, y - by),
                    _across(x, y, line))
    dist = np.where((x - cx) * (bx - cx) + (y - cy) * (by - cy) < 0.0, np.hypot(x - cx, y - cy),
                    dist)
    return dist <= wire_band_half_px(edge_px, radius)


def _band_area(alpha: NDArray, band: NDArray, x0: int, y0: int,
               guess: tuple[float, float], radius: float) -> float:
    """Σα (px²) of the band's pixels that a disc fit around ``guess`` would have taken in
    (within ``radius`` + 3 px, as :func:`.disc.fit_disc`)."""
    yy, xx = np.mgrid[0:alpha.shape[0], 0:alpha.shape[1]]
    near = np.hypot(xx + x0 - guess[0], yy + y0 - guess[1]) <= radius + 3.0
    return float(np.nansum(np.where(band & near, alpha, 0.0)))


def _line_across(alpha: NDArray, x0: int, y0: int, fit: Centre,
                 init: tuple[float, ...] | None,
                 stretch: tuple[float, float, float] | None = None
                 ) -> tuple[NDArray | None, tuple | None]:
    """A thin dark line across the disc ``fit`` (:func:`.disc.line_across`), and the
    parameters to fit again from without it.

    A line near the rim draws the fit's edge in: the radius and blur grow to take the
    line's darkness for the edge's fall-off, and against that widened edge the line is
    no longer darker than the model. So the line is also looked for against the disc
    at the fitted centre with the radius and blur the marker had when followed
    (``init``, its last shape), and the larger of the two lines is left out, the fit
    starting again from that shape. On the second renderer's SMA bed with the wire
    across A (bench/sma_bed_apart.py, 176→160°), A's fit had grown to a radius of
    10.8–13.1 px (10.5 whole) with the wire 5–7 px from its centre, and A was up to
    0.8 px off."""
    hidden = line_across(alpha, x0, y0, fit, stretch)
    if init is None or len(init) < 4 or fit.params is None:
        return hidden, fit.params
    learned = (fit.x, fit.y, *tuple(init)[-4:-2], *fit.params[4:6])
    by_shape = line_across(alpha, x0, y0, replace(fit, params=learned), stretch)
    if by_shape is not None and (hidden is None or by_shape.sum() > hidden.sum()):
        return by_shape, learned
    return hidden, fit.params


#: The rim's background ring lies 3–5 px beyond the radius from where it was laid,
#: and the rays are cast again from the fitted centre inside the fit, so a guess
#: this far off (px) leaves the ring at least 1 px clear of the rim, and the median
#: of the ring is not moved by the few of its pixels that come nearer: no second
#: coverage. At half a pixel, a pendulum's bob (radius 26 px) was unmixed twice in
#: four frames of five: 2.9 ms a frame against 1.25 ms to decode it.
RIM_RECENTRE_PX = 2.0


def _rim(image: Frame | BinnedFrame | NDArray[np.uint8], guess: tuple[float, float], radius: float,
         marker: NDArray | None, luminance: bool, hold: float | None = None
         ) -> tuple[Centre, NDArray]:
    """The circle through the rim (:func:`.outline.fit_outline`, its centre taken at the
    radius ``hold``, px, if given) on the coverage against one background
    (:func:`.outline.rim_coverage`), taken again around the fitted centre while it is
    more than :data:`RIM_RECENTRE_PX` from where the background ring was laid; and the
    colour seen in the middle around ``guess``."""
    fit = Centre(np.nan, np.nan, np.nan, radius, False)
    seen = None
    for _ in range(4):
        patch, x0, y0 = patch_around(image, guess[0], guess[1], radius + 9)
        alpha, seen_here = rim_coverage(patch, x0, y0, guess, radius, marker, luminance,
                                        _unit_px(image))
        seen = seen_here if seen is None else seen
        fit = fit_outline(alpha, x0, y0, guess, radius, hold=hold)
        if not fit.ok or np.hypot(fit.x - guess[0], fit.y - guess[1]) <= RIM_RECENTRE_PX:
            break
        guess = (fit.x, fit.y)
    return fit, seen


def _soft_refit(image: Frame | BinnedFrame | NDArray[np.uint8], fit: Centre, alpha: NDArray,
                patch: NDArray, x0: int, y0: int, radius: float, marker: NDArray | None,
                luminance: bool, tol: float, unit: float = 1.0,
                stretch: tuple[float, float, float] | None = None
                ) -> tuple[Centre, NDArray, NDArray, int, int, float]:
    """A soft-edged disc (out of focus) fitted again with its fading edge in the window.

    The coverage is laid out to ``radius`` + 2 px, against a background sampled just
    beyond: a disc whose edge width ``s`` is :data:`SOFT_EDGE_PX` or more fades past
    that, so its background is partly its own edge and the fit trades radius, edge,
    gain and offset for one another (yupi's rover pivot, r ≈ 12.7, s ≈ 4.5 px: fits
    of 12 to 29 px from one frame to the next, gains up to 14). Laid again to
    :data:`SOFT_REACH` edge widths past the fitted rim. Returns the fit, its coverage,
    patch, patch origin and window radius (px): as given where the disc is not soft.
    ``unit``: the frame px one of ``image``'s spans (:func:`.coverage.local_coverage`);
    ``stretch`` as :func:`refine`'s.
    """
    r, s = fit.params[2], fit.params[3]
    wide = r + SOFT_REACH * s - 2.0 / unit  # the coverage reaches 2 px past its window
    if not (SOFT_EDGE_PX <= s <= radius / SOFT_PLATEAU and radius + 1.0 < wide
            < SOFT_MAX * radius):
        return fit, alpha, patch, x0, y0, radius
    patch_w, xw, yw = patch_around(image, fit.x, fit.y, wide + 9)
    alpha_w, _ = local_coverage(patch_w, xw, yw, (fit.x, fit.y), wide, marker, luminance, unit,
                                 by_edge=True)
    again = fit_disc(alpha_w, xw, yw, (fit.x, fit.y), wide, init=fit.params, tol_px=tol,
                     stretch=stretch)
    if not again.ok:
        return fit, alpha, patch, x0, y0, radius
    # The checks of a whole marker compare its area and residual with its usual,
    # which were taken in the window laid for its radius.
    return (replace(again, area=fit.area, rms_residual=fit.rms_residual), alpha_w, patch_w,
            xw, yw, wide)


def refine_blob(image: Frame | NDArray[np.uint8], guess: tuple[float, float],
                reach_px: float, extent_px: float, width_px: float,
                marker: NDArray | None = None, luminance: bool = False
                ) -> tuple[Centre, NDArray | None]:
    """Centre of a marker that is not a disc (a strip of tape, a square, a streak):
    the centroid of its coverage (:func:`.centre.blob_centroid`).

    ``guess`` is where it should be (image px), within ``reach_px``; ``extent_px``
    how far it may reach from its centre (half its length, and half its last step
    for a streak), ``width_px`` half its shorter side. The coverage's background
    ring lies beyond ``extent_px`` and the reach, and is laid again around the
    centre found while that moves by more than half a pixel. Without ``marker``
    (an acquisition) its colour is the middle's, within ``width_px`` of ``guess``.
    Returns the centre and the colour seen in its middle (within ``width_px``).
    """
    def middle(at: tuple[float, float]) -> NDArray:
        patch, x0, y0 = patch_around(image, at[0], at[1], width_px + 8)
        return local_coverage(patch, x0, y0, at, width_px / 0.6, None, luminance)[1]

    if marker is None:
        marker = middle(guess)
    fit = Centre(np.nan, np.nan, np.nan, np.nan, False)
    for _ in range(3):
        radius = extent_px + reach_px
        patch, x0, y0 = patch_around(image, guess[0], guess[1], radius + 6)
        alpha, _ = local_coverage(patch, x0, y0, guess, radius, marker, luminance)
        fit = blob_centroid(alpha, x0, y0, guess, reach_px + 1.0)
        if not fit.ok or np.hypot(fit.x - guess[0], fit.y - guess[1]) <= 0.5:
            break
        guess, reach_px = (fit.x, fit.y), 1.0
    return fit, (middle((fit.x, fit.y)) if fit.ok else None)
