"""The per-frame loop: frames in, a tracks table out.

Each marker is *acquired* by a full-frame colour search (the first frame,
and again whenever it is lost), then *followed* in a small window around a
constant-acceleration prediction, so most frames touch only a few thousand
pixels per marker. Its colour window is learned from the first acquisition,
its size over the first frames it is found in (:data:`.marker_state.LEARN_FINDS`).
Every found blob is refined to a sub-pixel centre with a 1-σ
(:mod:`.refine`). A marker not found is NaN with ``_ok = False`` and a
``_status`` that says why; nothing is interpolated.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import CranktrackError
from ..tables import tracker_columns
from .centre import Centre, weighted_centroid
from .coverage import local_coverage
from .disc import line_across
from .ellipse import axis_ratio, ellipse_misfit, ellipse_of, long_axis_deg
from .foreshortening import Foreshortening
from .lighting import LIGHT_SURE, light_change, lighting_notes
from .marker_state import (
    KEEP_MOTION_MISSED,
    REST_REACH,
    REST_STEP,
    MarkerState,
    focus_notes,
    nearer_notes,
)
from .markers import (
    DEFAULT_MARKERS,
    Blob,
    MarkerSpec,
    balanced_hsv,
    choose_blob,
    find_blobs,
    learn_spec,
    place_reach,
)
from .outline import shaded
from .refine import (
    BAND_EDGE_PX,
    patch_around,
    refine,
    refine_blob,
    wire_band,
    wire_band_half_px,
)
from .scatter import (
    WHOLE_PX,
    drawn_at_whole_pixels,
    found_xy,
    repeated_frames,
    whole_pixel_share,
    with_scatter_floor,
)
from .search import (
    balance_gains,
    full_frame_blob,
    full_hsv,
    other_blobs,
    placed_blob,
    search_whole_frame,
    search_window,
    window,
)
from .template import (
    SCORE_DROP,
    Match,
    Template,
    fits_on,
    likest_other,
    match_template,
    nearly_as_like,
    search_box,
    take_template,
    template_half,
)
from .video import Frame, FrameSource, colourless_note, timing_report

#: Why a marker has no position in a frame (the ``_status`` column).
STATUSES = {
    "ok": "found",
    "not_found": "no blob of the marker's colour where it was looked for (a template "
                 "marker: no place like its picture)",
    "rejected": "blobs of the colour, but none of the marker's size and shape (a template "
                "marker: the place found far off was no likelier than the likest other "
                "place in the first frame)",
    "out_of_view": "the predicted position is outside the image",
    "refine_failed": "a blob was found but no sub-pixel centre could be fitted",
    "partly_covered": "the marker is there but does not look like a whole disc "
                      "(its fit residual is far above usual; a template marker: its match "
                      "scores far under its usual), so its centre is not trusted",
    "same_blob": "two markers were found on one blob; neither is kept there",
    "not_sought": "lost for a second or more, so looked for only on some frames "
                  "(tracker/search.py, search_window), not on this one",
}

#: Fitted coverage gain of a marker that is really there (≈ 1; an absent or
#: hidden marker fits ≈ 0), as multiples of the marker's usual gain
#: (:attr:`.MarkerState.gain_range`). Wide, because at a radius of a few pixels
#: the gain trades off against the edge's blur.
GAIN_RANGE = (0.5, 1.7)

#: A resting marker's fit from the prediction whose radius is more than this factor
#: off the last fit's found another solution of the disc model, not the marker: yupi's
#: rover LED at rest, unchanged to the eye, fitted at 1.33 px in radius against 2.38
#: the frame before and 0.9 px off, with σ 0.3 px; the jump then carried the
#: prediction off and the LED was lost for three frames. The largest steps otherwise
#: taken on the real clips of the benches: 1.43 (the tossed ball, as it leaves the
#: light), 1.36 (the diabolo), 1.33 (a falling cup).
RADIUS_STEP = 1.5


def _honest(c: Centre) -> bool:
    """A centre whose σ says something: finite, and smaller than the marker itself
    (a σ as large as the marker locates nothing and is a gap, not a point)."""
    return bool(np.isfinite(c.sigma) and 0 < c.sigma < c.radius)


def _window_blob(frame: Frame, state: MarkerState, at: tuple[float, float], half: float,
                 hsv_cache: dict) -> tuple[Blob | None, str]:
    """The blob of the marker's colour and size nearest ``at`` (px) within ``half`` px
    of it, and :func:`.markers.choose_blob`'s status."""
    patch, x0, y0 = patch_around(frame, at[0], at[1], half)
    if patch.size == 0:  # a window wholly off the frame
        return None, "not_found"
    hsv = balanced_hsv(patch, hsv_cache.get("gains"))
    # Within the window's circle: its square's corners reach 1.4× as far.
    near = [b for b in find_blobs(hsv, state.spec, x0, y0)
            if np.hypot(b.x - at[0], b.y - at[1]) <= half]
    return choose_blob(near, state.area, at, shape=state.spec.takes)


#: A followed marker whose fit from its prediction failed is fitted again with its
#: radius and edge held (:func:`_held_fit`) if it usually stands out this many times
#: over its fit's residual, and the held fit does too. Yupi's rover LED (2.4 px):
#: the held fit takes it in 14 of its 164 frames at rest and 9 of 52 on the move,
#: where the free fit failed; held at rest, it shows 3.9–8.7 times its residual.
#: OpenCV's vtest.avi: the default A, taken on a patch of lawn, shows a median of 0.8
#: (90 % under 2.3); without this bound it was followed there in 22 % of the frames
#: instead of 2 %, and tracking took twice as long.
HELD_CLEAR = 3.0
#: ...and the held fit lies within this many radii of the prediction: a resting
#: step (:data:`.marker_state.REST_STEP`) for a marker at rest, this for a moving one.
#: Held, a fit no longer tells a disc from a patch of texture of its colour, so it
#: may not walk the marker off: a resting cone on vtest.avi, held within its whole
#: radius, was carried 158 px away by people passing in front. Nor is a marker held
#: whose last fixes missed their predictions by more than this: on vtest.avi under
#: one invisible ±1 DN pattern, the sign, placed by hand 7 px from it and from an
#: orange patch above it, was taken on the patch 14 px from its fix before, and
#: held fits kept it there for the rest of the clip (638 frames 14 px off).
HELD_STEP = 0.5


def _may_hold(state: MarkerState) -> bool:
    """May the marker be fitted with its shape held (:func:`_held_fit`, :func:`_or_held`)?
    A disc (not a rim) with a free fit's shape, that usually stands out
    :data:`HELD_CLEAR` times over its fit's residual (a marker, not a patch of texture
    of its colour), and whose motion has been predictable (its last fixes within
    :data:`HELD_STEP` radii of their predictions, :attr:`.MarkerState.surprise_px`)."""
    return (not state.rim and state.shape is not None
            and state.surprise_px is not None and state.surprise_px <= HELD_STEP * state.radius
            and (state.gain or 0.0) > HELD_CLEAR * (state.residual or np.inf))


def _held_at(frame: Frame, state: MarkerState, at: tuple[float, float], reach: float,
             luminance: bool,
             wire_line: tuple[tuple[float, float], tuple[float, float]] | None = None
             ) -> tuple[Centre, NDArray | None] | None:
    """The marker's fit from ``at`` (px) with its radius and edge held at its last free
    fit's, if it lies within ``reach`` px of ``at`` and stands out :data:`HELD_CLEAR`
    times over its residual; else None. ``wire_line``: the wire's ends, as for
    :func:`.refine.refine` (held, a disc out of focus leaves the wire's band out too)."""
    centre, seen = refine(frame, at, state.radius, state.colour, init=state.shape,
                          luminance=luminance, rim=False, wire=state.spec.flat,
                          hold_shape=True, wire_line=wire_line, stretch=state.stretch_at(*at))
    if not (np.hypot(centre.x - at[0], centre.y - at[1]) <= reach
            and centre.gain > HELD_CLEAR * centre.rms_residual):
        return None
    return centre, seen


def _teaching_nothing(centre: Centre, state: MarkerState) -> Centre:
    """A held fit, or one of a disc the frame's edge cuts, as the marker remembers it:
    it teaches nothing of its size, gain or residual (its colour is still the
    middle's), and the next fit starts from the last free fit's shape (this one's, on
    the marker's first find)."""
    return replace(centre, gain=np.nan, area=np.nan, rms_residual=np.nan, peak=np.nan,
                   params=centre.params if state.shape is None else state.shape)


def _cut_by_edge(frame: Frame, state: MarkerState, centre: Centre) -> bool:
    """Does the frame's edge cut the fitted marker, or a disc's background ring? Its fit
    then saw only part of it (:meth:`.MarkerState.unmixed`): it teaches the marker
    nothing of its size, gain, area or residual (:func:`_teaching_nothing`)."""
    return bool(np.isfinite(centre.radius) and state.unmixed(centre, frame.size) < 1.0)


def _clear_of_edge(frame: Frame, r: float, x: float, y: float) -> bool:
    """Is (x, y) px far enough inside the frame for a disc of radius ``r`` to be fitted
    from there (its patch whole)?"""
    w, h = frame.size
    return r + 2 <= x <= w - r - 3 and r + 2 <= y <= h - r - 3


def _inside(frame: Frame, x: float, y: float) -> bool:
    """Does (x, y) px lie inside the frame (its pixels' middles from 0 to width − 1)?"""
    w, h = frame.size
    return 0.0 <= x <= w - 1.0 and 0.0 <= y <= h - 1.0


def _held_fit(frame: Frame, state: MarkerState, pred: tuple[float, float],
              luminance: bool,
              wire_line: tuple[tuple[float, float], tuple[float, float]] | None = None
              ) -> tuple[Centre, NDArray | None] | None:
    """A followed marker's fit with its radius and edge held at its last fit's, where
    the free fit from ``pred`` failed: on a disc a few pixels across, six parameters
    trade off (radius, edge and gain) and the fit runs off from one frame of a still
    picture to the next. None unless the marker may be held (:func:`_may_hold`) and
    the held fit is clear and lies near ``pred`` (:data:`HELD_STEP` radii, a resting
    step at rest)."""
    if not _may_hold(state):
        return None
    reach = (REST_STEP if state.resting else HELD_STEP) * state.radius
    return _held_at(frame, state, pred, reach, luminance, wire_line)


def _plausible(c: Centre, guess: tuple[float, float], state: MarkerState) -> bool:
    """A fit from a prediction that found the marker's colour, near the prediction, and
    for a marker at rest at about the size of its last fit (:data:`RADIUS_STEP`)."""
    lo, hi = state.gain_range(GAIN_RANGE)
    # Only at rest: on the move a fit's size changes with its blur and its distance.
    last = state.shape[2] if state.shape is not None and state.resting else np.nan
    sized = not (np.isfinite(c.radius) and last > 0) or \
        (c.radius > 0 and abs(np.log(c.radius / last)) <= np.log(RADIUS_STEP))
    return c.ok and _honest(c) and sized and lo < c.gain < hi and np.hypot(
        c.x - guess[0], c.y - guess[1]) < state.radius


def _locate(frame: Frame, state: MarkerState, t: float, hsv_cache: dict,
            pred: tuple[float, float] | None,
            wire_line: tuple[tuple[float, float], tuple[float, float]] | None = None
            ) -> tuple[Centre | None, str]:
    """The marker's centre in ``frame`` (at ``t`` s), predicted at ``pred`` (px,
    :meth:`.MarkerState.predict`), and its status. ``wire_line``: two points on the
    crank-slider's wire, which may cross this printed disc (px; :func:`.refine.refine`)."""
    w, h = frame.size
    blob, status = None, "not_found"
    if pred is not None and state.radius is not None:
        r = state.radius
        if not (-r <= pred[0] <= w + r and -r <= pred[1] <= h + r):
            status = "out_of_view"
        elif not search_window(state):
            status = "not_sought"  # long lost: its window is searched only on some frames
        else:
            # Following: refine straight from the prediction; the colour search
            # is only needed when that fails (fast motion, occlusion, a jump). By the
            # frame's edge, only a marker the user placed (a default one was followed
            # along box.mp4's bottom edge, which has no markers): its fit there takes
            # the pixels whose background lies on the frame (coverage.unmixed_share).
            # Yupi's ball, by the edge in 382 of its 1000 frames, was searched for by
            # its blob in 428 (now in 79): bench/real_footage.py's decode/track ratio
            # on it went from 0.38-0.40 to 0.47.
            if _clear_of_edge(frame, r, *pred) or (
                    state.spec.near_px is not None and _inside(frame, *pred)):
                centre, seen, held, plausible = _followed(frame, state, pred, wire_line)
                if state.try_light():
                    second = _followed(frame, state, pred, wire_line)
                    if _likelier_lit(state, second[0],
                                     second[3] and state.whole(second[0], size=frame.size),
                                     centre, plausible and state.whole(centre, size=frame.size)):
                        centre, seen, held, plausible = second
                    else:
                        state.lit = None
                if plausible:
                    if not state.whole(centre, size=frame.size):
                        return None, "partly_covered"
                    if state.nearing and not held and centre.radius > state.radius + GREW:
                        # Still coming nearer: its size is taken on before its rim
                        # reaches the background ring (discs growing to 87 px were
                        # 0.040-0.082 px RMS off when lost and refound instead, not
                        # 0.026-0.047).
                        state.regrow(centre.radius)
                    state.remember(_teaching_nothing(centre, state)
                                   if held or _cut_by_edge(frame, state, centre) else centre,
                                   seen, frame.index)
                    if not held and state.measuring_shape():
                        _measure_shape(frame, state, centre, wire_line)
                    return centre, "ok"
            blob, status = _window_blob(frame, state, pred, window(state), hsv_cache)
            setting_off = state.set_off_prediction(t)
            if blob is None and setting_off is not None:
                # A fix refused off a resting marker's place may have been the marker
                # setting off: it is looked for on that way too (MarkerState.moved_off).
                blob, _ = _window_blob(frame, state, setting_off,
                                       3.0 * state.radius + 2.0 * state.stray_step() + 4.0,
                                       hsv_cache)
    whole_frame = blob is None
    if whole_frame and pred is None and state.spec.near_px is not None \
            and not search_whole_frame(state, pred):
        blob, status = placed_blob(frame, state, hsv_cache)
        whole_frame = False
        if blob is None:
            blob = state.placed_failed
            if blob is None:
                return None, status
    if whole_frame:
        if not search_whole_frame(state, pred):
            return None, status
        blob, full_status = full_frame_blob(frame, state, t, hsv_cache, pred)
        if blob is None:
            blob = state.placed_failed if pred is None else None
            if blob is None:
                return None, status if status == "out_of_view" else full_status
    centre, seen, failure = _refine_blob_in_light(frame, state, blob, hsv_cache)
    if pred is None and state.spec.near_px is not None:
        # A placed marker not yet found, whose blob by its place was found but not
        # fitted: where no blob is found later (its colour merged with its
        # surroundings'), it is fitted again there (:attr:`.MarkerState.placed_failed`),
        # unless another blob like it lies by the place too.
        state.placed_failed = (blob if failure and not _placed_rival(frame, state, blob,
                                                                     hsv_cache) else None)
    if failure and pred is not None and (whole_frame or search_whole_frame(state, pred)):
        # The blob nearest the prediction was not the marker (a hand, a reflection):
        # the next nearest of its colour and size may be. That needs the whole
        # frame's colours, so only on a frame where the whole frame may be searched.
        # With no velocity yet (seen once) the marker may be anywhere near: as wide
        # as after a whole-frame search.
        wide = whole_frame or len(state.history) < 2
        for other in other_blobs(frame, state, hsv_cache, pred, blob, wide):
            centre, seen, failure = _refine_blob_in_light(frame, state, other, hsv_cache)
            if not failure:
                blob = other
                break
    elif not failure and whole_frame and len(state.history) == 1 and state.radius:
        centre, seen = _likest(frame, state, hsv_cache, pred, blob, centre, seen)
    if failure:
        state.mark_way(t, Centre(blob.x, blob.y, np.nan, blob.radius, False), pred)
        return None, failure
    if state.off_its_place(centre, pred) and not state.moved_off(centre, t):
        return None, "rejected"  # a neighbour of its colour, not a marker at rest
    if state.radius is None:
        state.radius = centre.radius
    elif _nearer(state, blob) and centre.radius > state.shape[2]:
        state.regrow(centre.radius)
    state.remember(_teaching_nothing(centre, state) if _cut_by_edge(frame, state, centre)
                   else centre,
                   seen, frame.index)
    return centre, "ok"


def _followed(frame: Frame, state: MarkerState, pred: tuple[float, float],
              wire_line: tuple[tuple[float, float], tuple[float, float]] | None
              ) -> tuple[Centre, NDArray | None, bool, bool]:
    """A followed marker's fit at its prediction ``pred`` (px), in its colour
    (:attr:`.MarkerState.colour`): the centre, what it saw, whether it is the held fit
    (:func:`_held_fit`), and whether it is plausible (:func:`_plausible`)."""
    luminance = bool(state.spec.tone)
    if state.extent is not None:
        centre, seen = _blob_centre(frame, state, pred, state.motion_px() + 1.0)
        return centre, seen, False, _plausible(centre, pred, state)
    centre, seen = refine(frame, pred, state.radius, state.colour, init=state.shape,
                          luminance=luminance, rim=state.rim, wire=state.spec.flat,
                          wire_line=wire_line, stretch=state.stretch_at(*pred))
    plausible = _plausible(centre, pred, state)
    again = None if plausible else _held_fit(frame, state, pred, luminance, wire_line)
    if again is None:
        return centre, seen, False, plausible
    return *again, True, _plausible(again[0], pred, state)


def _coverage_around(frame: Frame, state: MarkerState, at: tuple[float, float],
                     radius: float) -> tuple[NDArray, int, int]:
    """The marker's coverage in ``frame`` around ``at`` (px) for a disc of ``radius``
    (px), in its learned colour (:func:`.coverage.local_coverage`), and the patch's
    top-left pixel."""
    patch, x0, y0 = patch_around(frame, at[0], at[1], radius + 9)
    alpha, _ = local_coverage(patch, x0, y0, at, radius, state.colour, bool(state.spec.tone))
    return alpha, x0, y0


def _ellipse_learned(state: MarkerState) -> dict[str, float | int | None]:
    """What ``run.json`` says of a marker's ellipse learned without a calibration
    (:mod:`.ellipse`): the ratio of its axes and its longer axis's direction (degrees
    from +x toward +y), and the first frame fitted so; None for each where it was taken
    as round or not measured."""
    if state.ellipse is None:
        return {"ellipse_axes_ratio": None, "ellipse_long_axis_deg": None,
                "ellipse_from_frame": None}
    u, v = state.ellipse
    return {"ellipse_axes_ratio": round(axis_ratio(u, v), 4),
            "ellipse_long_axis_deg": round(long_axis_deg(u, v), 1),
            "ellipse_from_frame": state.shape_from + 1}


def _measure_shape(frame: Frame, state: MarkerState, centre: Centre,
                   wire_line: tuple[tuple[float, float], tuple[float, float]] | None) -> None:
    """Measure the ellipse of a resting printed disc's fix ``centre`` (:mod:`.ellipse`)
    on its coverage in ``frame``, for :meth:`.MarkerState.saw_shape`, without the band
    the crank-slider's wire (``wire_line``: its ends, px) darkens and without a dark
    line found across it. Left in, the wire tied at C's centre made C's disc look
    0.975 : 1 on the second renderer's SMA bed filmed square-on, and the wire across A
    made A 0.950 : 1 (bench/sma_bed_apart.py)."""
    state.shape_tries += 1
    radius = state.radius
    alpha, x0, y0 = _coverage_around(frame, state, (centre.x, centre.y), radius)
    edge = centre.params[3] if centre.params is not None else 1.0
    if wire_line is not None:
        alpha = np.where(wire_band(alpha.shape, x0, y0, wire_line, edge, radius), np.nan,
                         alpha)
    line = line_across(alpha, x0, y0, centre)
    if line is not None:
        alpha = np.where(line, np.nan, alpha)
    shape = ellipse_of(alpha, x0, y0, centre)
    if shape is not None:
        state.saw_shape(shape[0], shape[1], centre.x, centre.y, frame.index)


def _refine_blob_in_light(frame: Frame, state: MarkerState, blob: Blob, hsv_cache: dict
                          ) -> tuple[Centre | None, NDArray | None, str]:
    """:func:`_refine_blob`, and in a frame lit otherwise than the marker's colour was
    seen in, again in this frame's light (:meth:`.MarkerState.try_light`), taken where
    :func:`_likelier_lit`."""
    first = _refine_blob(frame, state, blob, hsv_cache)
    if not state.try_light():
        return first
    second = _refine_blob(frame, state, blob, hsv_cache)
    if _likelier_lit(state, second[0], not second[2], first[0], not first[2]):
        return second
    state.lit = None
    return first


def _likelier_lit(state: MarkerState, lit: Centre | None, lit_ok: bool,
                  plain: Centre | None, plain_ok: bool) -> bool:
    """Is the fit in this frame's light (``lit``) the marker, rather than the one in its
    colour as learned (``plain``)? Where only one passed its checks, that one; where
    both did and the light changed by more than :data:`LIGHT_SURE`, the one whose gain
    is nearer the marker's usual: a marker lit by the room shows its usual gain in the
    room's light, an LED in its own colour."""
    if lit_ok != plain_ok:
        return lit_ok
    if not lit_ok or light_change(state.lit) < LIGHT_SURE:
        return False
    usual = state.gain or 1.0

    def off(c: Centre) -> float:
        return abs(np.log(c.gain / usual)) if np.isfinite(c.gain) and c.gain > 0 else np.inf
    return off(lit) < off(plain)


def _placed_rival(frame: Frame, state: MarkerState, blob: Blob, hsv_cache: dict) -> bool:
    """Is there a blob of the marker's colour and shape, of ``blob``'s area within 2×,
    other than ``blob``, within :func:`.markers.place_reach` of the place the user gave?
    Vtest.avi's sign was placed by hand 7 px from it and from an orange patch above it:
    a failed fit at either is no sign of which one the marker is (refitted at a failed
    blob, with three invisible ±1 DN patterns it was followed up to 14 px off its fixes
    as is in 121 frames, against 3)."""
    near = state.spec.near_px
    reach = place_reach(blob.radius)
    # Only the pixels by the place: a marker placed where nothing fits fails there on
    # every frame, and a whole frame's colours cost as much as decoding it.
    patch, x0, y0 = patch_around(frame, near[0], near[1], reach + 2.0 * blob.radius + 2.0)
    hsv = balanced_hsv(patch, balance_gains(frame, hsv_cache))
    return any(state.spec.takes(b) and 0.5 * blob.area <= b.area <= 2.0 * blob.area
               and np.hypot(b.x - blob.x, b.y - blob.y) > 1.0
               and np.hypot(b.x - near[0], b.y - near[1]) <= reach
               for b in find_blobs(hsv, state.spec, x0, y0))


#: How much nearer in log size (a factor of 1.1 in radius) another blob's fit must be
#: to a marker seen once to be taken over the nearest blob (:func:`_likest`): twice
#: the scatter of a small marker's fitted radius from frame to frame (Tracker's cups:
#: 1.93–2.07 px; the knuckle beside its tossed ball is 0.69 from the ball's size).
LIKER = float(np.log(1.1))


def _likest(frame: Frame, state: MarkerState, hsv_cache: dict, pred: tuple[float, float],
            blob: Blob, centre: Centre, seen: NDArray | None
            ) -> tuple[Centre, NDArray | None]:
    """Of the blobs within reach of a marker seen once, the fit nearest its size.

    With no velocity yet, nearness says little: on Tracker's ball toss the ball is 36
    px (8 radii) from its first fix a frame later, and a knuckle of the hand that
    threw it 29 px, of the ball's colour and within its size gate (a fit of radius
    3.4 px against 4.6). A marker's size changes little from one frame to the next,
    so the fit closest to the first one's size is taken, where it is closer by more
    than :data:`LIKER`; among blobs of about one size the nearest stays. Tracker's
    falling cups are side by side and of one size (radii 1.9–2.1 px): by size alone,
    an invisible ±1 DN pattern decided which cup was followed. The size is the
    fitted radius and, where both fits have one, the visible area Σα: with that
    pattern a knuckle's disc fit came out at 4.75 px against the ball's 4.56, but
    its visible area was a quarter of the ball's."""
    def unlike(c: Centre) -> float:
        by_radius = abs(np.log(c.radius / state.radius))
        if state.area_alpha and np.isfinite(c.area) and c.area > 0:
            return max(by_radius, 0.5 * abs(np.log(c.area / state.area_alpha)))
        return by_radius

    best = (centre, seen)
    for other in other_blobs(frame, state, hsv_cache, pred, blob, wide=True):
        c, s, failure = _refine_blob(frame, state, other, hsv_cache)
        if not failure and unlike(c) < unlike(best[0]) - LIKER:
            best = (c, s)
    return best


#: Dark lines up to this wide (px) across one of the crank-slider's printed discs are
#: filled before the disc is judged shaded (:func:`.outline.shaded`): the SMA wire
#: tied at B, 1.3 px wide and 2–4 px in 4:2:0 chroma on a second renderer's SMA bed
#: (bench/sma_bed_apart.py), spread B's middle by up to 0.52, and B was rejected in
#: every frame. Filled, 0.02–0.06; a shaded ball of B's colour stays near 1, and the
#: flat markers of the design render 0.01–0.03.
WIRE_FILL_PX = 7
#: ...and this many px wider per px of the disc's fitted edge width beyond a sharp
#: disc's (:data:`SHARP_EDGE_PX`, the second renderer's discs in focus on H.264): out
#: of focus the wire's shadow spreads as wide as the disc's edge. On that renderer's
#: bed blurred by 2 px B was rejected in every frame (its middle leaning by 0.26 of its
#: coverage) and by 2.5 px in 71 % of them; filled so, it was found in 82 and 100 %
#: (bench/README.md, stop 50). In focus nothing changes.
WIRE_FILL_PER_EDGE_PX = 4.0
SHARP_EDGE_PX = 1.2
#: ...and at least this fraction of the disc's radius: filmed close, the wire is as many
#: px wide as the discs are large (the thesis's 0.5 mm wire on 8 mm discs is an eighth
#: of their radius, before 4:2:0 chroma and the lens spread it). On 1080p H.264 with
#: discs of radius 30 px and a wire 3 px wide from B to C (bench/large_markers.py
#: --wire), B's middle filled 7 px wide still spread by 0.18-0.29, and B was refused
#: as shaded in every frame.
WIRE_FILL_PER_RADIUS = 0.25


def _wire_fill_px(centre: Centre) -> int:
    """How wide (px) a dark line across a printed disc fitted as ``centre`` is filled
    before the disc is judged shaded."""
    if centre.params is None:
        return WIRE_FILL_PX
    extra = WIRE_FILL_PER_EDGE_PX * max(centre.params[3] - SHARP_EDGE_PX, 0.0)
    return round(max(float(WIRE_FILL_PX + extra), WIRE_FILL_PER_RADIUS * centre.radius))


def _wire_band_px(centre: Centre) -> float:
    """Half the width (px) of the band through a printed disc fitted as ``centre`` that
    its shading is judged without when it is out of focus (0: in focus)."""
    if centre.params is None or centre.params[3] < BAND_EDGE_PX:
        return 0.0
    return wire_band_half_px(centre.params[3], centre.radius)


#: While a printed disc's size is being learned, its fit may lie at most this many of its
#: blob's radii from the blob's centroid. The wire across A, 4 px from its centre,
#: blurred by a lens 2-2.5 px out of focus, left a disc fit of 7 px (10.4 drawn) on
#: the larger side, 0.31-0.41 radii off: learned so, A was followed 0.5-4 px off for
#: the whole clip (the second renderer's bed, case 2; θ 1.1-1.9° off). The fits
#: learned on the bench's other renders lay 0.00-0.12 radii off (bench/README.md,
#: stop 53).
LEARN_DRIFT = 0.2


def _off_its_blob(frame: Frame, state: MarkerState, blob: Blob, centre: Centre) -> bool:
    """Does a printed disc's fit, while its size is learned, lie more than
    :data:`LEARN_DRIFT` of its blob's radii from the blob's centroid, where that
    centroid is the disc's? The wire's pull moves the fit off the blob, while the
    coverage's own centroid (:func:`.centre.weighted_centroid`, the start of an
    acquisition's fit) stays within 0.1 radii of the blob's: that fit is refused.
    A marker whose hue is its fringe alone moves the blob instead, and its coverage's
    centroid lies off the blob too: where the user placed the marker (``@X,Y``), the
    fit is then held to that centroid. Yupi's rover LED, 3 px across, has a white
    core; its hue blob lay 0.3-0.6 radii from its coverage's centroid, so, named B,
    it was lost for the clip's first 24 frames (bench/README.md, stop 62). Passed
    where it lay near either centroid, the second renderer's A, out of focus with the
    wire across it, was learned 0.26 radii off and followed up to 2.9 px off."""
    limit = LEARN_DRIFT * blob.radius
    if np.hypot(centre.x - blob.x, centre.y - blob.y) <= limit:
        return False
    if state.spec.near_px is None:
        # Not placed by the user: the blob may be anything of the colour, and only its
        # own centroid is trusted (held to either, OpenCV's box.mp4, which has no
        # markers, had its default C taken in 39 % of its frames, not 12 %).
        return True
    alpha, x0, y0 = _coverage_around(frame, state, (blob.x, blob.y), blob.radius)
    middle = weighted_centroid(alpha, x0, y0, (blob.x, blob.y), blob.radius,
                               noise_alpha=0.05)
    if not middle.ok or np.hypot(middle.x - blob.x, middle.y - blob.y) <= limit:
        return True
    return bool(np.hypot(centre.x - middle.x, centre.y - middle.y) > limit)


#: A blob at least this many px larger in radius than the marker's learned size may be
#: the marker come nearer (:func:`_nearer`): its rim then lies past the pixels the
#: coverage unmixes (2 px past the learned rim) and nears its background ring (3-5 px
#: past). Such a blob is fitted at its own size, and a fit larger than the last one
#: becomes the marker's size (:meth:`.MarkerState.regrow`). With the size kept as
#: learned, discs growing to 1.45 times their radius were found in 12-51 % of the
#: frames (bench/large_markers.py --nearer 1.45; 93-100 % now).
GROWN = 2.0
#: ...and only where the marker's last fit had grown by this already (px), or it has
#: been found nearer before: on a real clip a blob larger than its marker is most often
#: the marker merged with something of its colour. Without it, box.mp4's default B (no
#: markers there) was taken in 52 % of the frames, not 26 % (bench/real_clips.py).
GREW = 1.0


def _nearer(state: MarkerState, blob: Blob) -> bool:
    """Has the marker come nearer, ``blob`` being it at its new size? (:data:`GROWN`,
    :data:`GREW`.)"""
    r = state.radius
    if state.learning or not r or state.shape is None or len(state.shape) < 3:
        return False
    return bool(blob.radius > r + GROWN and (state.nearing or state.shape[2] > r + GREW))


def _refine_blob(frame: Frame, state: MarkerState, blob: Blob, hsv_cache: dict
                 ) -> tuple[Centre | None, NDArray | None, str]:
    """The refined centre on a blob, what it saw, and why it failed ("" if it did not)."""
    # While its size is being learned, the blob in hand says how big the marker is.
    nearer = _nearer(state, blob)
    radius = blob.radius if state.learning or state.radius is None or nearer \
        else state.radius
    if not state.learned:
        # Learning follows a full-frame search, whose white-balanced HSV is at hand.
        hsv_patch, x0, y0 = patch_around(full_hsv(frame, hsv_cache), blob.x, blob.y,
                                         radius + 3)
        state.spec = learn_spec(state.spec, hsv_patch, (blob.x, blob.y), radius, x0, y0)
        state.learned = True
    luminance = bool(state.spec.tone)
    if state.rim is None and not state.spec.flat and state.extent is None:
        _decide_blob(frame, state, blob)
    if state.extent is not None:
        centre, seen = _blob_centre(frame, state, (blob.x, blob.y), 2.0)
        return _whole_and_honest(state, centre, seen, size=frame.size)
    centre, seen = refine(frame, (blob.x, blob.y), radius, state.colour, luminance=luminance,
                          rim=state.rim, wire=state.spec.flat,
                          stretch=state.stretch_at(blob.x, blob.y))
    if (state.rim is None or state.spec.flat) and centre.ok:
        # A flat marker's coverage is even over its middle; a shaded ball's falls
        # away from the light, and pulls a disc fit toward it: that one is centred
        # by its rim from now on (decided once, so that a flat marker partly hidden
        # later is not taken for a ball: its rim would be half the cover's edge).
        alpha, x0, y0 = _coverage_around(frame, state, (centre.x, centre.y), centre.radius)
        # The crank-slider's wire is tied at B and may cross A: on a printed disc a
        # dark line is the wire, not shading.
        ball = shaded(alpha, x0, y0, (centre.x, centre.y), centre.radius,
                      _wire_fill_px(centre) if state.spec.flat else 0,
                      _wire_band_px(centre) if state.spec.flat else 0.0)
        if state.spec.flat:
            # One of the crank-slider's printed discs is never a ball: a shaded
            # blob of its colour (a sleeve, a sign) is something else, and its disc
            # fit would be pulled toward the light by pixels with a small σ.
            if ball:
                state.refused_shaded += 1
                return None, None, "rejected"
            if centre.params is None:
                # No disc fitted, only the blob's centroid (refine's fallback for an
                # acquisition): a printed disc is fitted as one.
                return _or_held(frame, state, blob, (None, None, "refine_failed"))
            if (state.learning or state.radius is None) and _off_its_blob(
                    frame, state, blob, centre):
                return None, None, "refine_failed"
            return _or_held(frame, state, blob,
                            _whole_or_refitted(frame, state, centre, seen, radius, luminance,
                                               nearer))
        state.rim = ball
        if state.rim and not centre.rim:
            centre, seen = refine(frame, (centre.x, centre.y), radius, state.colour,
                                  luminance=luminance, rim=True)
        elif not state.rim and centre.rim:
            return None, None, "refine_failed"  # a flat marker's disc fit failed
    return _or_held(frame, state, blob,
                    _whole_or_refitted(frame, state, centre, seen, radius, luminance, nearer))


def _or_held(frame: Frame, state: MarkerState, blob: Blob,
             result: tuple[Centre | None, NDArray | None, str]
             ) -> tuple[Centre | None, NDArray | None, str]:
    """``result`` of a fit to a blob, or where that fit failed, the marker's fit there
    with its radius and edge held at its last free fit's, as :func:`_held_fit` makes it
    for a followed marker: a disc a few pixels across whose six-parameter fit from
    scratch runs off. Yupi's rover LED (2.4 px), refound by its blob as it sets off and
    on the move, failed so in 4 frames, and the marker then lost others; held, it is
    found in 211 of its 216 lit frames, not 205.

    Taken only for a marker that usually stands out clearly over its fit's residual
    (:func:`_may_hold`) and whose held fit does too, within a radius of the blob's centre;
    that was followed within the last :data:`.marker_state.KEEP_MOTION_MISSED` frames,
    with a motion as predictable as :func:`_held_fit` asks (so its shape is this
    frame's); whose blob lies clear of the frame's edge, as a followed fit's prediction
    must, unless the user placed it (``@X,Y``); and, at rest, within its resting reach
    of its place (not a neighbour's blob). By the edge a disc's coverage is unmixed
    only where its background ring lies on the frame (:func:`.coverage.unmixed_share`),
    an arc of its rim, along which its radius trades with its centre: there the held
    radius is the marker's. A drawn disc 7.5 px out of the frame's edge failed so, and
    yupi's blue ball at the edges of its box in 33 of its 1000 frames. On box.mp4,
    which has no markers, without the edge bound the default B was followed
    along the frame's bottom edge in 14 % of the frames, not 2 %; without the bound on
    frames lost, its A was taken up again far off after 116 frames lost; without the
    one on motion, its C, refound with no motion yet, was then followed in 42 % of the
    frames. Like a followed marker's held fit, it teaches the marker nothing of its
    size, gain or residual."""
    r = state.radius
    if result[2] != "refine_failed" or state.learning or not _may_hold(state) \
            or state.missed > KEEP_MOTION_MISSED or not (
                state.spec.near_px is not None or _clear_of_edge(frame, r, blob.x, blob.y)) \
            or (state.resting and state.history
                and state.from_place(blob.x, blob.y) > REST_REACH * r):
        return result
    held = _held_at(frame, state, (blob.x, blob.y), r, bool(state.spec.tone))
    if held is None or _whole_and_honest(state, *held, size=frame.size)[2]:
        return result
    return _teaching_nothing(held[0], state), held[1], ""


def _whole_or_refitted(frame: Frame, state: MarkerState, centre: Centre,
                       seen: NDArray | None, radius: float, luminance: bool,
                       nearer: bool = False) -> tuple[Centre | None, NDArray | None, str]:
    """:func:`_whole_and_honest` of a fit to a blob; where it looks covered, the disc
    is fitted again from the marker's last shape, as when it is followed. A fit
    from a blob starts from scratch, and its edge and residual may differ from the
    usual: a whole disc refound 9.5 px from its prediction was called covered, its
    residual 1.6 times the usual, while the fit from its last shape was whole.

    A printed disc's first fit that leaves much of its patch unexplained
    (:data:`FIRST_RESIDUAL`) is fitted as an ellipse too (a disc at a slant): where
    that does not explain it either, it is no printed disc."""
    if _explains_little(state, centre):
        alpha, x0, y0 = _coverage_around(frame, state, (centre.x, centre.y), centre.radius)
        misfit = ellipse_misfit(alpha, x0, y0, centre)
        if misfit is None or misfit > FIRST_RESIDUAL:
            return None, None, "rejected"
    first = _whole_and_honest(state, centre, seen, nearer, frame.size)
    if first[2] != "partly_covered" or centre.rim or state.shape is None \
            or len(state.shape) < 3:
        return first
    again, seen_again = refine(frame, (centre.x, centre.y), radius, state.colour,
                               init=(centre.x, centre.y, *state.shape[2:]),
                               luminance=luminance, rim=state.rim, wire=state.spec.flat,
                               stretch=state.stretch_at(centre.x, centre.y))
    second = _whole_and_honest(state, again, seen_again, nearer, frame.size) if again.ok \
        else first
    return second if not second[2] else first


def _blob_centre(frame: Frame, state: MarkerState, guess: tuple[float, float],
                 reach_px: float) -> tuple[Centre, NDArray | None]:
    """Centre of a marker that is not a disc near ``guess`` (px), within ``reach_px``:
    it may reach its half-length plus half its last step from its centre (a streak
    is as long as the motion in the exposure, at most a step)."""
    length, width = state.extent
    return refine_blob(frame, guess, reach_px, length + 0.5 * state.speed_px(), width,
                       state.colour, bool(state.spec.tone))


#: A blob whose coverage is longer than wide by this (its second moments) is a
#: strip or a streak, not a disc: a disc fitted to a streak 2.5× as long as wide
#: was off by 0.3–0.5 px along it, its centroid by 0.01–0.03.
ELONGATION = 1.6


#: ...and symmetric along its length: a ball with bonds of its colour (a Jmol atom
#: on Tracker's jmoljana clip, skew 0.31) is long one way too, but lopsided; a
#: drawn streak's is 0.003.
SKEW = 0.2


#: ...and centred on the blob, within this many of its half-widths: a streak's faint
#: ends lie either side of it. A coverage whose centre lies farther took in something
#: else: on Tracker's falling cups (7×9 px) the probe of one took in the cup beside it,
#: 5–14 px off, and with an invisible ±1 DN pattern added it was then taken for a strip
#: 12 px long and lost in every frame after.
PROBE_DRIFT = 0.5


def _decide_blob(frame: Frame, state: MarkerState, blob: Blob) -> None:
    """At a marker's first acquisition: is it a strip, a square or a streak (centred by
    its coverage's centroid from now on, ``state.extent``), or a disc or ball?
    Decided once, by the thresholded blob's box or, for a streak whose faint ends
    fell below the threshold, by its coverage's second moments."""
    if blob.elongated():
        state.extent, state.rim = (blob.half_length + 0.5, blob.half_width), False
        return
    if not blob.solid():
        return
    probe, _ = refine_blob(frame, (blob.x, blob.y), 2.0, 2.0 * blob.half_length + 2.0,
                           blob.half_width, None, bool(state.spec.tone))
    if probe.ok and probe.length_px > ELONGATION * probe.width_px and abs(probe.skew) < SKEW \
            and np.hypot(probe.x - blob.x, probe.y - blob.y) <= PROBE_DRIFT * blob.half_width:
        state.extent, state.rim = (probe.length_px + 0.5, probe.width_px), False


#: A printed disc's first fit leaves a residual (RMS, in coverage) under this fraction
#: of its gain, or an ellipse fitted to its patch does (:func:`.ellipse.ellipse_misfit`):
#: the disc and its background explain it. Measured on first fits (scratch): printed
#: discs on the project's H.264 render and the second renderer's SMA bed (the wire across
#: A included), 0.10-0.19, and 0.06 on yupi's real red pivot; seen by a camera pitched 55°
#: (`bench/tilted_bed.py --tilt 55`, ellipses of axes 0.5-0.6) 0.32-0.50, as ellipses
#: 0.11-0.17. OpenCV's vtest.avi's red door, lit unevenly and taken for the default B in
#: 36 % of its frames, 1.50, as an ellipse 1.18; tree.avi's thing taken for C 0.95 and
#: 0.78. A fit from a blob starts from scratch and may be rough (a disc blurred by a
#: Gaussian of 3 px left 0.36, where the next frame's left 0.017): the fit is kept as it
#: is wherever the ellipse explains the patch.
FIRST_RESIDUAL = 0.3


def _explains_little(state: MarkerState, centre: Centre) -> bool:
    """Is ``centre`` a printed disc's first fit that leaves more than
    :data:`FIRST_RESIDUAL` of its gain unexplained?"""
    if not state.spec.flat or state.residual is not None or centre.params is None \
            or not centre.ok:
        return False
    return bool(centre.rms_residual > FIRST_RESIDUAL * centre.params[4])


def _whole_and_honest(state: MarkerState, centre: Centre, seen: NDArray | None,
                      nearer: bool = False, size: tuple[int, int] | None = None
                      ) -> tuple[Centre | None, NDArray | None, str]:
    """The centre if its fit is sound and shows the whole marker, else why not.
    ``nearer``: fitted as the marker come nearer (:func:`_nearer`); ``size``: the
    frame's (width, height) px, whose edge may cut the disc
    (:meth:`.MarkerState.whole`)."""
    lo, hi = state.gain_range(GAIN_RANGE)
    # A first fit, whose colour is the blob's middle, has a gain of about 1 by making:
    # one far above that has run off (yupi's rover pivot, a soft disc in a dark ring,
    # came out at 4.9 and 20.8 px for 12.7, and the pivot was lost in frames 0-8). A low
    # one is let be: refused, vtest's default B was taken up on clothes more often.
    if not centre.ok or not _honest(centre) or centre.gain >= hi or (
            state.marker is not None and not centre.gain > lo):
        return None, None, "refine_failed"
    lo, hi = state.area_gates[-1]
    if state.radius is not None and not lo <= (centre.radius / state.radius) ** 2 <= hi:
        return None, None, "rejected"  # a fit of another size: a glint, a neighbour
    if not state.whole(centre, nearer, size):
        return None, None, "partly_covered"
    return centre, seen, ""


@dataclass(frozen=True)
class Span:
    """The part of a video to track: from ``start`` to ``end`` inclusive, in seconds
    from the start of the video's clock (:attr:`.video.FrameSource.clock_start`, as players
    count them), or in frame numbers when ``unit`` is ``"frame"``."""

    start: float = 0.0
    end: float = float("inf")
    unit: str = "s"

    @property
    def given(self) -> bool:
        return self.start > 0 or np.isfinite(self.end)

    def _at(self, frame: Frame) -> float:
        return float(frame.index) if self.unit == "frame" else frame.t_s

    def before(self, frame: Frame) -> bool:
        return self._at(frame) < self.start

    def after(self, frame: Frame) -> bool:
        return self._at(frame) > self.end

    def describe(self) -> str:
        unit = " s" if self.unit == "s" else ""
        what = "frame " if self.unit == "frame" else ""
        end = f"{what}{self.end:g}{unit}" if np.isfinite(self.end) else "the end"
        return f"between {what}{self.start:g}{unit} and {end}"


@dataclass(frozen=True)
class Roi:
    """The part of each frame to search, px: ``x``, ``y`` its top-left corner, ``w``, ``h``
    its size. Markers are looked for inside it only; positions stay in the whole
    frame's pixels."""

    x: int
    y: int
    w: int
    h: int

    def inside(self, size: tuple[int, int]) -> tuple[int, int, int, int]:
        """The cut (x0, y0, x1, y1) within a frame of ``size`` (width, height): the
        region clipped to the frame and shrunk to whole 2×2 colour cells (even x0
        and y0, even width, height a multiple of 4), so a 4:2:0 frame is cut where
        its chroma was stored.

        Raises
        ------
        CranktrackError
            The region does not overlap the frame, or leaves less than 8×8 px.
        """
        w, h = size
        x0, y0 = max(self.x, 0), max(self.y, 0)
        x1, y1 = min(self.x + self.w, w), min(self.y + self.h, h)
        x0 += x0 % 2
        y0 += y0 % 2
        x1 -= (x1 - x0) % 2
        y1 -= (y1 - y0) % 4
        if x1 - x0 < 8 or y1 - y0 < 8:
            raise CranktrackError(f"--roi {self.x},{self.y},{self.w},{self.h} leaves no "
                                  f"usable part of the {w}x{h} frame; give X,Y,W,H inside it")
        return x0, y0, x1, y1


@dataclass
class TrackResult:
    """The tracks table and what the run learned about the footage."""

    tracks: pd.DataFrame
    timing: dict
    found_fraction: dict[str, float]
    problems: list[str] = field(default_factory=list)
    learned: dict[str, dict] = field(default_factory=dict)
    #: The tracker's state after the last frame (what a checkpoint saves).
    state: TrackerState | None = None

    def to_dict(self) -> dict:
        """JSON-ready summary for ``run.json``."""
        return {"timing": self.timing, "found_fraction": self.found_fraction,
                "problems": self.problems, "learned_markers": self.learned}


@dataclass
class TrackerState:
    """Everything the loop carries from frame to frame, so a run can resume.

    ``rows`` are the finished rows; ``markers`` each marker's learned colour,
    size, motion history and fit shape; ``balance`` the white balance.
    """

    markers: list[MarkerState]
    balance: dict
    rows: list[list]
    #: Each tracked frame's light (:meth:`.video.Frame.light`: R, G, B, DN), in order.
    lights: list[NDArray] = field(default_factory=list)

    @classmethod
    def start(cls, specs: Sequence[MarkerSpec] = DEFAULT_MARKERS) -> TrackerState:
        """The state before the first frame: nothing learned yet."""
        return cls([MarkerState(spec, rim=False if spec.flat else None) for spec in specs],
                   {"gains": None}, [])

    def radii(self) -> dict[str, float | None]:
        """Each marker's learned radius, px: the median over the first frames it was
        found in (None where never found)."""
        return {st.spec.name: st.radius for st in self.markers}

    @property
    def last_frame(self) -> int:
        """Index of the last finished frame (−1 before the first)."""
        return int(self.rows[-1][0]) if self.rows else -1


class TrackingInterrupted(KeyboardInterrupt):
    """Ctrl-C during tracking; carries the state up to the last finished frame."""

    def __init__(self, state: TrackerState) -> None:
        super().__init__("tracking interrupted")
        self.state = state


@contextmanager
def _between_frames() -> Iterator[list[bool]]:
    """Ctrl-C (SIGINT) is held until the frame in hand is finished: a frame half
    tracked would leave some markers' memory a frame ahead of the rows, and a
    resumed run would then differ from an uninterrupted one. Yields a list that
    is non-empty once Ctrl-C was pressed. A second Ctrl-C interrupts at once.
    Only the main thread can take signals; elsewhere nothing is held."""
    asked: list[bool] = []
    if threading.current_thread() is not threading.main_thread():
        yield asked
        return

    def hold(signum: int, frame_: object) -> None:
        if asked:
            raise KeyboardInterrupt
        asked.append(True)

    previous = signal.signal(signal.SIGINT, hold)
    try:
        yield asked
    finally:
        # None: the handler before was not set from Python and cannot be put back;
        # Python's own (KeyboardInterrupt) is the nearest.
        signal.signal(signal.SIGINT, signal.default_int_handler if previous is None
                      else previous)


#: A template marker missed for up to this many frames is matched over the whole frame
#: in each; then at a colour marker's falling rate (:func:`.search.search_whole_frame`).
#: The whole 384×800 free-fall frame takes 11 ms against 0.4 ms to decode it.
TEMPLATE_EVERY_FRAME_MISSED = 16
#: How far (radii, and at least 40 px) a template marker is sought from its place
#: while it has no velocity yet.
TEMPLATE_FIRST_REACH = 4.0
#: Sought widely, a template marker's match away from where it was looked for is taken
#: only if it is likelier by this much than the likest other place in the first frame
#: (:func:`.template.likest_other`). On Tracker's car clip a post 490 px from the car
#: matched its picture at 0.92 in the first frame, and was taken for it once it was lost.
TEMPLATE_RIVAL_MARGIN = 0.02


def _template_at_start(frame: Frame, state: MarkerState) -> Centre:
    """A template marker's picture, taken where the user placed it in the first frame
    tracked, and that place as its first fix (:mod:`.template`)."""
    spec = state.spec
    x, y = spec.near_px
    r = spec.template_radius_px
    w, h = frame.size
    if not fits_on((x, y), r, frame.size):
        raise CranktrackError(
            f"marker {spec.name} is placed at ({x:g}, {y:g}) with a radius of {r:g} px, so "
            f"its picture reaches past the {w}×{h} frame; place it where it lies whole, or "
            "start tracking where it does (--start)")
    half, ix, iy = template_half(r), round(x), round(y)
    box = (ix - half, iy - half, ix + half + 1, iy + half + 1)
    state.template = take_template(frame.luma(*box), box[0], box[1], (x, y), r)
    state.radius = r
    if state.template.plain:
        raise CranktrackError(
            f"marker {spec.name}'s picture within {r:g} px of ({x:g}, {y:g}) is plain, so "
            "there is nothing in it to follow: a template marker is followed by what it "
            "shows inside its outline (highlights, shading, print); a plain disc or ball is "
            f"found by its colour or tone instead (--marker {spec.name}=white@{x:g},{y:g}, "
            "or the colour `cranktrack inspect` lists it with)")
    rival = likest_other(frame.luma(0, 0, w, h), state.template)
    state.template = replace(state.template, rival=rival)
    if nearly_as_like(state.template, rival[2]):
        state.notes.append(
            f"marker {spec.name}: another place in the first frame, ({rival[0]:.0f}, "
            f"{rival[1]:.0f}), looks almost as like its picture (a match of "
            f"{rival[2]:.2f}), so where it is lost it is not sought past its window; a "
            "radius that takes in more of what only it shows makes it surer")
    # How unlike its picture a match usually is starts from what the noise alone
    # gives: a first match far worse is refused like any sudden drop. Without it, the
    # first match set the usual: on Tracker's car clip (a streaked car, 70 px a frame)
    # that was a place 51 px behind the car, and the fixes that followed were all
    # false, 47 of them (the last 42 on a post 490 px away).
    state.residual = state.template.unlike
    # The place given is where the picture was taken: its σ is the picture's own noise
    # over its gradients (matched against itself it would leave nothing, and say 0).
    return Centre(x, y, state.template.sigma, r, True)


def _locate_by_template(frame: Frame, state: MarkerState, pred: tuple[float, float] | None
                        ) -> tuple[Centre | None, str]:
    """A template marker's centre in ``frame`` and its status: its picture matched
    around its prediction ``pred`` (px); within :data:`TEMPLATE_FIRST_REACH` radii of
    its place while it has no velocity yet; over the whole frame in each of the first
    :data:`TEMPLATE_EVERY_FRAME_MISSED` frames it is missed, and then at the rate a lost
    colour marker's is searched (:func:`.search.search_whole_frame`), unless another
    place in the first frame looks nearly as like it (:func:`.template.nearly_as_like`).
    A match scoring :data:`.template.SCORE_DROP` under its usual is refused
    (``partly_covered``), and one found far off no likelier than that other place
    (``rejected``)."""
    if state.template is None:
        return _template_at_start(frame, state), "ok"
    template = state.template
    w, h = frame.size
    guess = pred if pred is not None else state.spec.near_px
    if not (0.0 <= guess[0] < w and 0.0 <= guess[1] < h):
        return None, "out_of_view"
    # Close about the prediction: a match past the window's border is sought again
    # about where it was found (below). Matching 18 px each way took 1.1 ms a frame
    # on the free-fall clip, 4 px 0.66 ms.
    reach = 2.0 * state.motion_px() + 4.0
    local = reach
    if len(state.history) < 2:
        # With no velocity yet it may be anywhere near: a thrown ball moves radii a
        # frame. Not the whole frame: on Tracker's car clip that took a post 560 px away.
        reach = max(TEMPLATE_FIRST_REACH * template.radius, 40.0)
    elif state.missed > 0 and not nearly_as_like(template, template.rival[2]) \
            and (state.missed <= TEMPLATE_EVERY_FRAME_MISSED
                 or search_whole_frame(state, pred)):
        # Missed, its motion is not carried past a few frames (KEEP_MOTION_MISSED), so
        # a ball falling behind a plate comes out where no window about its last fix
        # reaches.
        reach = float(max(w, h))
    box = search_box(template, guess, reach, frame.size)
    if box is None:
        return None, "partly_covered"
    found = match_template(frame.luma(*box), box[0], box[1], template)
    for _ in range(3):
        if found is None or not found.bordered or _at_cut_edge(found, template, box,
                                                                frame.size):
            break
        # Best on the border of the places tried (a bounce, a fix after a loss): the
        # peak may lie past it, so it is sought again about there. Read at the border,
        # a drawn ball just out from behind a plate was 0.2 px off.
        box = search_box(template, (found.x, found.y), 4.0, frame.size)
        found = None if box is None else match_template(frame.luma(*box), box[0], box[1],
                                                        template)
    if found is None:
        return None, "not_found"
    if _at_cut_edge(found, template, box, frame.size):
        # The best place lies against the frame's edge: the marker may be further on,
        # partly off the frame, where no whole template fits.
        return None, "partly_covered"
    if reach > local and found.score <= template.rival[2] + TEMPLATE_RIVAL_MARGIN \
            and np.hypot(found.x - guess[0], found.y - guess[1]) > local:
        # Sought widely and found away from where it was looked for, no likelier than
        # the likest other place in the first frame: that place's kind, not the marker.
        return None, "rejected"
    # How unlike its picture it usually is (1 − the match's score), over the matches
    # taken: its look may change slowly (turning, in another light), not at once.
    unlike = 1.0 - found.score
    usual = state.residual
    if usual is not None and unlike > usual + SCORE_DROP:
        # Suddenly far less like its picture: partly hidden, or something else. A drawn
        # ball with a sixth of its height behind a plate still scored 0.79 against its
        # usual 0.98, and was 0.45 px off; on the free-fall clip, with the ball gone
        # past the frame's edge, the best place in the frame scored 0.63 against 0.81.
        return None, "partly_covered"
    state.residual = unlike if usual is None else 0.9 * usual + 0.1 * unlike
    return Centre(found.x, found.y, found.sigma, template.radius, True,
                  rms_residual=found.rms_residual), "ok"


def _at_cut_edge(found: Match, template: Template, box: tuple[int, int, int, int],
                 size: tuple[int, int]) -> bool:
    """Does ``found``'s template lie against a side of ``box`` (px) that the frame's
    edge cut (a frame ``size`` (width, height) px)?"""
    left = found.x - template.anchor[0]
    top = found.y - template.anchor[1]
    side = template.picture.shape[0]
    w, h = size
    return ((box[0] == 0 and left < box[0] + 1.0) or (box[1] == 0 and top < box[1] + 1.0)
            or (box[2] == w and left + side > box[2] - 1.0)
            or (box[3] == h and top + side > box[3] - 1.0))


def _locate_markers(frame: Frame, state: TrackerState) -> list:
    """Each marker's ``x, y, σ, ok, status`` in one frame, in the tracks table's order.

    Updates ``state``: what each marker has learned, and its last two fixes."""
    values: list = []
    hsv_cache: dict = state.balance.copy()
    found: list[tuple[MarkerState, Centre]] = []
    predictions = [st.predict(frame.t_s) for st in state.markers]
    wire_line = _wire_line(state.markers, predictions)
    light = frame.light
    state.lights.append(light)
    for st in state.markers:
        st.in_light(light)
    for k, st in enumerate(state.markers):
        predicted = predictions[k]
        if st.spec.template_radius_px is not None:
            centre, status = _locate_by_template(frame, st, predicted)
        else:
            centre, status = _locate(frame, st, frame.t_s, hsv_cache, predicted,
                                     wire_line if st.spec.flat else None)
        state.balance["gains"] = hsv_cache.get("gains")
        state.balance["gains_light"] = hsv_cache.get("gains_light")
        if centre is None:
            values += [np.nan, np.nan, np.nan, False, status]
            st.missed += 1  # searched for around its last fix, in a widening window
            if st.started_falsely:
                state.markers[k] = st.restarted(frame.t_s)
        else:
            if st.false_start is not None:
                _judge_false_start(state.rows, k, st, centre.radius)
            if st.taken_up is not None:
                if st.taken_up[1].ok:  # a fix, not a blob whose fit failed
                    _give_back(state.rows, k, *st.taken_up)
                st.taken_up = None
            st.found_at(frame.t_s, centre.x, centre.y, predicted)
            st.see_rgb(_middle_rgb(frame, centre))
            values += [centre.x, centre.y, centre.sigma, True, status]
            found.append((st, centre))
    _one_blob_each(found, state.markers, values, frame.t_s)
    return values


def _middle_rgb(frame: Frame, centre: Centre) -> NDArray[np.float64] | None:
    """The median RGB (DN) of the square of pixels within 0.4 of ``centre``'s radius of
    it, all inside a disc (the pixel under it for a small marker); None off the frame."""
    half = 0.4 * centre.radius if np.isfinite(centre.radius) else 0.0
    w, h = frame.size
    x0, y0 = max(round(centre.x - half), 0), max(round(centre.y - half), 0)
    x1, y1 = min(round(centre.x + half) + 1, w), min(round(centre.y + half) + 1, h)
    if x1 <= x0 or y1 <= y0:
        return None
    return frame.median_rgb(x0, y0, x1, y1)


def _wire_line(markers: list[MarkerState], predictions: list[tuple[float, float] | None]
               ) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The ends of the crank-slider's SMA wire, tied at B and ending at C: the
    predictions of its printed discs B and C (px), or None without both."""
    at = {st.spec.name: p for st, p in zip(markers, predictions, strict=True)
          if st.spec.flat and p is not None}
    return (at["B"], at["C"]) if "B" in at and "C" in at else None


def _judge_false_start(rows: list[list], k: int, st: MarkerState, radius: float) -> None:
    """The first find after marker ``k``'s false start, at ``radius`` px: if the thing
    found then was of another size (a speck where the marker is a disc), its rows in
    ``rows`` are not the marker's and are marked ``rejected``."""
    frames, _ = st.false_start
    if not st.like_false_start(radius):
        wrong = set(frames)
        for row in rows:
            if int(row[0]) in wrong:
                row[2 + 5 * k:7 + 5 * k] = [np.nan, np.nan, np.nan, False, "rejected"]
    st.false_start = None


def _give_back(rows: list[list], k: int, t: float, centre: Centre) -> None:
    """Marker ``k``'s fix ``centre``, refused at time ``t`` (s) as off its place and
    since taken up as the marker setting off (:meth:`.MarkerState.moved_off`), written
    into that frame's row."""
    for row in reversed(rows):
        if row[1] == t:
            row[2 + 5 * k:7 + 5 * k] = [centre.x, centre.y, centre.sigma, True, "ok"]
            return


def _one_blob_each(found: list[tuple[MarkerState, Centre]], markers: list[MarkerState],
                   values: list, t: float) -> None:
    """Two markers on one blob (two of one colour given by hand, a marker lost onto
    its neighbour): neither is kept there, and the user hears of it once."""
    clash = set()
    for i, (a, ca) in enumerate(found):
        for b, cb in found[i + 1:]:
            if np.hypot(ca.x - cb.x, ca.y - cb.y) < max(ca.radius, cb.radius):
                clash |= {id(a), id(b)}
                if not any("one blob" in n for n in a.notes):
                    a.notes.append(
                        f"markers {a.spec.name} and {b.spec.name} were both found on the blob "
                        f"at ({ca.x:.0f}, {ca.y:.0f}) at t = {t:.3f} s; neither is kept where "
                        "that happens: give each its own colour or say where each is "
                        "(--marker NAME=COLOUR@X,Y)")
    for k, st in enumerate(markers):
        if id(st) in clash:
            values[5 * k:5 * k + 5] = [np.nan, np.nan, np.nan, False, "same_blob"]
            st.forget_motion()  # neither fix is trusted: sought afresh


def locate(frame: Frame | NDArray[np.uint8], markers: Sequence[MarkerSpec] = DEFAULT_MARKERS,
           state: TrackerState | None = None, t_s: float = 0.0) -> pd.DataFrame:
    """Find each marker in one frame: the per-frame step of :func:`track`.

    Parameters
    ----------
    frame : ndarray or Frame
        An RGB image (h, w, 3) of uint8, or a decoded :class:`.video.Frame`.
    markers : sequence of MarkerSpec
        What to look for (default A green, B red, C blue); ignored when
        ``state`` is given, which already holds them.
    state : TrackerState, optional
        Carried from frame to frame (``TrackerState.start(markers)``) so that
        each marker is followed from where it was, with the colour and size
        it showed; without it every call is a fresh full-frame search.
    t_s : float
        The frame's time, s, for the motion prediction (a Frame's own time
        is used for a Frame).

    Returns
    -------
    DataFrame
        One row per marker: ``marker``, ``x_px``, ``y_px`` (pixel centres
        at integer coordinates), ``sigma_px`` (per-axis 1-σ, px), ``ok`` and
        ``status`` (a key of :data:`STATUSES`).

    Examples
    --------
    A red disc of radius 6 px drawn at (70.3, 50.6) with its edge pixels
    partly covered, as a camera would see it:

    >>> import numpy as np
    >>> from cranktrack.tracker.markers import MarkerSpec
    >>> s = 8  # sub-samples per pixel side
    >>> y, x = (np.mgrid[0:120 * s, 0:160 * s] + 0.5) / s - 0.5
    >>> disc = ((x - 70.3) ** 2 + (y - 50.6) ** 2 < 36).reshape(120, s, 160, s).mean((1, 3))
    >>> rgb = 230 * (1 - disc[..., None]) + np.array([220, 30, 30]) * disc[..., None]
    >>> found = locate(rgb.round().astype(np.uint8), [MarkerSpec("B", hue_deg=0)])
    >>> found[["marker", "x_px", "y_px", "status"]].round(2)
      marker  x_px  y_px status
    0      B  70.3  50.6     ok
    """
    if not isinstance(frame, Frame):
        rgb = np.asarray(frame)
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
            raise CranktrackError(f"locate needs an RGB image of shape (h, w, 3) and dtype "
                                  f"uint8, not {rgb.shape} {rgb.dtype}")
        frame = Frame(0, float(t_s), np.ascontiguousarray(rgb))
    state = TrackerState.start(tuple(markers)) if state is None else state
    values = _locate_markers(frame, state)
    rows = [(st.spec.name, *values[5 * i:5 * i + 5]) for i, st in enumerate(state.markers)]
    return pd.DataFrame(rows, columns=["marker", "x_px", "y_px", "sigma_px", "ok", "status"])


#: The fraction of its found frames in which a marker repeats the picture before, from
#: which a run warns that the footage repeats pictures.
STAIRS_WARN = 0.05


def stair_notes(tracks: pd.DataFrame, specs: tuple[MarkerSpec, ...]) -> list[str]:
    """A sentence for each marker whose track moves in stairs
    (:func:`.scatter.repeated_frames` in at least :data:`STAIRS_WARN` of its found
    frames, and at least 3)."""
    notes = []
    for s in specs:
        frames = tracks["frame"].to_numpy()[repeated_frames(found_xy(tracks, s.name))]
        if len(frames) >= max(3, STAIRS_WARN * tracks[s.name + "_ok"].sum()):
            shown = ", ".join(str(f) for f in frames[:4])
            notes.append(
                f"{s.name} moves in stairs: in {len(frames)} frames ({shown}, …) it all but "
                "stops between two frames in which it moves on. Footage converted from a "
                "lower frame rate repeats pictures like this, and so does a phone that "
                "cannot keep up; their timestamps are not when they were taken. The σ "
                "floor and the kinematics are made without them")
    return notes


def whole_pixel_notes(tracks: pd.DataFrame, specs: tuple[MarkerSpec, ...]) -> list[str]:
    """A sentence for each marker whose track lies on whole pixels as it moves
    (:func:`.scatter.drawn_at_whole_pixels`)."""
    notes = []
    for s in specs:
        xy = found_xy(tracks, s.name)
        if drawn_at_whole_pixels(xy):
            notes.append(
                f"{s.name} lies on whole pixels: on each axis, "
                f"{100 * whole_pixel_share(xy):.0f} % or more of its places while it moves are "
                f"within {WHOLE_PX} px of a whole pixel, where a fifth would be by chance. The "
                "footage looks drawn by a program that "
                "rounds each place to the pixel, so its steps from frame to frame are the "
                "drawing's, up to half a pixel, not the fit's error: σ is the fit's own, "
                "not raised to the track's scatter, and speeds carry those steps")
    return notes


def tracks_table(rows: list[list], specs: tuple[MarkerSpec, ...],
                 radii: dict[str, float | None] | None = None) -> pd.DataFrame:
    """The tracks table from finished rows.

    Each found centre's σ is raised to the track's local frame-to-frame scatter
    where its own fit claims less (:mod:`.scatter`). The rows keep the fit's σ,
    so a resumed run raises them over the same frames as an uninterrupted one.
    Where the raised σ is as large as the marker's radius (``radii``, px, by
    marker name: the track jumps about by a marker's size, so no one point is
    located), the row is a gap with status ``refine_failed``.
    """
    tracks = pd.DataFrame(rows, columns=tracker_columns(tuple(s.name for s in specs)))
    tracks["frame"] = tracks["frame"].astype(int)
    for s in specs:
        ok = tracks[s.name + "_ok"].astype(bool).to_numpy()
        sigma = with_scatter_floor(tracks[s.name + "_sigma_px"].to_numpy(float),
                                   found_xy(tracks, s.name))
        radius = (radii or {}).get(s.name)
        if radius is not None:
            lost = ok & ~(sigma < radius)
            if lost.any():
                ok = ok & ~lost
                tracks.loc[lost, [s.name + "_x_px", s.name + "_y_px"]] = np.nan
                sigma[lost] = np.nan
                tracks.loc[lost, s.name + "_status"] = "refine_failed"
        tracks[s.name + "_ok"] = ok
        tracks[s.name + "_sigma_px"] = sigma
    return tracks


def _within(specs: tuple[MarkerSpec, ...], cut: tuple[int, int, int, int] | None
            ) -> tuple[MarkerSpec, ...]:
    """The specs with where the user said a marker is (``near_px``) in the cut's pixels."""
    if cut is None:
        return specs
    return tuple(replace(s, near_px=None if s.near_px is None else
                         (s.near_px[0] - cut[0], s.near_px[1] - cut[1])) for s in specs)


def _shifted(values: list, cut: tuple[int, int, int, int]) -> list:
    """One frame's ``x, y, σ, ok, status`` per marker, from the cut's pixels to the frame's."""
    out = list(values)
    for k in range(0, len(out), 5):
        out[k] += cut[0]
        out[k + 1] += cut[1]
    return out


def track(
    source: FrameSource,
    specs: tuple[MarkerSpec, ...] = DEFAULT_MARKERS,
    on_frame: Callable[[int], None] | None = None,
    resume: TrackerState | None = None,
    checkpoint: Callable[[TrackerState], None] | None = None,
    checkpoint_every: int = 250,
    span: Span | None = None,
    roi: Roi | None = None,
    foreshortening: Foreshortening | None = None,
) -> TrackResult:
    """Find every marker in every frame of ``source`` (within ``span``, if given), in
    the part of each frame ``roi`` says (the whole frame by default).

    Returns one row per decoded frame with ``frame``, ``t_s`` and, per marker,
    ``_x_px``, ``_y_px``, ``_sigma_px`` (per-axis 1-σ, px), ``_ok`` and
    ``_status`` (a key of :data:`STATUSES`). A marker found in no frame is
    still a column (all NaN); ``found_fraction`` says so and the caller
    decides what to tell the user.

    ``foreshortening`` (from the plane's calibration, :mod:`.foreshortening`) makes the
    flat markers' disc fits ellipses, as a camera not square to the plane sees them.

    ``resume`` continues from a saved :class:`TrackerState` (frames up to its
    last one are decoded but not tracked again); ``checkpoint(state)`` is
    called every ``checkpoint_every`` frames. Ctrl-C raises
    :class:`TrackingInterrupted` with the state so far.

    Raises
    ------
    CranktrackError
        No frame could be decoded, or a marker found by hue is asked for in pictures
        stored without colour (:attr:`.video.FrameSource.stores_colour`).
    """
    hued = [s.name for s in specs if not s.tone and s.template_radius_px is None]
    if hued and not source.stores_colour:
        raise CranktrackError(
            f"{source.path.name} is stored without colour ({source.pixel_format}, as "
            f"monochrome cameras record), so marker{'s' * (len(hued) > 1)} "
            f"{', '.join(hued)}, found by hue, cannot be seen in it; name white, black or "
            f"grey markers instead (--marker NAME=white@X,Y), as `cranktrack inspect` lists "
            "them")
    cut = None if roi is None else roi.inside((source.width, source.height))
    state = resume or TrackerState.start(_within(specs, cut))
    for st in state.markers:
        # Set on a resumed run too: it is this run's calibration, not the saved one's.
        st.foreshortening = (foreshortening if foreshortening is None or cut is None
                             else foreshortening.shifted(cut[0], cut[1]))
    done = state.last_frame
    span = span or Span()
    said = len(source.problems)  # what reading the frames says is added after these
    try:
        with _between_frames() as asked:
            for frame in source.frames(prefetch=8):
                if asked:
                    raise KeyboardInterrupt
                if span.after(frame):
                    break
                if frame.index <= done or span.before(frame):
                    continue
                if cut is None:
                    values = _locate_markers(frame, state)
                else:
                    values = _shifted(_locate_markers(frame.cropped(*cut), state), cut)
                state.rows.append([frame.index, frame.t_s, *values])
                if on_frame:
                    on_frame(frame.index)
                if checkpoint and len(state.rows) % checkpoint_every == 0:
                    checkpoint(state)
            if asked:
                raise KeyboardInterrupt
    except KeyboardInterrupt as e:
        raise TrackingInterrupted(state) from e
    if not state.rows:
        # Why, where reading said it: pictures it could not read, frames of another size.
        why = f" ({source.problems[said]})" if len(source.problems) > said else ""
        if span.given:
            raise CranktrackError(f"no frame of {source.path} lies {span.describe()}{why}")
        raise CranktrackError(f"no frame of {source.path} could be decoded{why}")
    tracks = tracks_table(state.rows, specs, state.radii())
    found = {s.name: float(tracks[s.name + "_ok"].mean()) for s in specs}
    learned = {st.spec.name: {**({} if st.spec.template_radius_px is not None else
                                 {"hue_deg": round(st.spec.hue_deg, 2),
                                  "hue_tol_deg": round(st.spec.hue_tol_deg, 2)}),
                              "radius_px": None if st.radius is None else round(st.radius, 3),
                              "edge_px": None if st.edge_px is None else round(st.edge_px, 3),
                              **_ellipse_learned(st)}
               for st in state.markers}
    notes = [n for st in state.markers for n in st.notes] + stair_notes(tracks, specs)
    notes += whole_pixel_notes(tracks, specs)
    notes += [note for st in state.markers if found[st.spec.name] == 0
              and (note := st.never_found_note())]
    notes += nearer_notes(state.markers)
    notes += focus_notes(state.markers, found) + lighting_notes(state.lights)
    if hued and (note := colourless_note(source)):
        notes.insert(0, note)
    return TrackResult(tracks, timing_report(tracks["t_s"].to_numpy(), source.nominal_fps),
                       found, list(source.problems) + notes, learned, state)
