"""The per-frame loop: frames in, a tracks table out.

Each marker is *acquired* by a full-frame colour search (the first frame,
and again whenever it is lost), then *followed* in a small window around a
constant-velocity prediction, so most frames touch only a few thousand
pixels per marker. Its colour window is learned from the first acquisition.
Every found blob is refined to a sub-pixel centre with a 1-σ
(:mod:`.refine`). A marker not found is NaN with ``_ok = False`` and a
``_status`` that says why; nothing is interpolated.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import CranktrackError
from ..tables import tracker_columns
from .markers import (
    DEFAULT_MARKERS,
    Blob,
    MarkerSpec,
    acquire,
    balanced_hsv,
    choose_blob,
    find_blobs,
    learn_spec,
    white_balance_gains,
)
from .outline import fit_outline, rim_coverage, shaded
from .refine import (
    Centre,
    fit_disc,
    fit_disc_cells,
    fit_edges,
    local_coverage,
    weighted_centroid,
)
from .scatter import with_scatter_floor
from .video import Frame, FrameSource, timing_report

#: Why a marker has no position in a frame (the ``_status`` column).
STATUSES = {
    "ok": "found",
    "not_found": "no blob of the marker's colour where it was looked for",
    "rejected": "blobs of the colour, but none of the marker's size and shape",
    "out_of_view": "the predicted position is outside the image",
    "refine_failed": "a blob was found but no sub-pixel centre could be fitted",
    "partly_covered": "the marker is there but does not look like a whole disc "
                      "(its fit residual is far above usual), so its centre is not trusted",
    "same_blob": "two markers were found on one blob; neither is kept there",
}

#: A fit whose residual exceeds this many times the marker's usual residual is
#: not a whole disc (partly covered, or something of its colour touching it).
RESIDUAL_LIMIT = 1.6

#: A marker whose visible area Σα differs from its usual by more than this
#: fraction is not whole (partly covered), or not alone.
AREA_TOLERANCE = 0.2

#: Fitted coverage gain of a marker that is really there (≈ 1; an absent or
#: hidden marker fits ≈ 0). Wide, because at a radius of a few pixels the gain
#: trades off against the edge's blur.
GAIN_RANGE = (0.5, 1.7)


@dataclass
class _MarkerState:
    spec: MarkerSpec
    learned: bool = False
    radius: float | None = None  # from the first fit, px
    history: list[tuple[float, float, float]] = field(default_factory=list)  # (t, x, y)
    missed: int = 0  # frames since the last fix (or since the start, never found)
    shape: tuple[float, ...] | None = None  # last fitted disc parameters
    #: Centred by its rim (a shaded ball: the disc fit is pulled toward the light)?
    #: None until decided at the first acquisition.
    rim: bool | None = None
    marker: NDArray | None = None  # learned marker chroma
    residual: float | None = None  # usual RMS residual of the disc fit
    area_alpha: float | None = None  # usual visible area Σα, px²
    notes: list[str] = field(default_factory=list)  # things the user should hear about

    @property
    def area(self) -> float | None:
        """The marker's expected blob area, px² (from its radius)."""
        return None if self.radius is None else float(np.pi * self.radius**2)

    def whole(self, centre: Centre) -> bool:
        """Does the fit look like the whole marker: its usual visible area and residual?
        (A rim fit has weighed out what covers the marker already.)"""
        if centre.rim:
            return True
        if self.area_alpha is not None and np.isfinite(centre.area):
            if not 1 - AREA_TOLERANCE <= centre.area / self.area_alpha <= 1 + AREA_TOLERANCE:
                return False
        if self.residual is None or not np.isfinite(centre.rms_residual):
            return True
        return centre.rms_residual <= RESIDUAL_LIMIT * max(self.residual, 0.01)

    def remember(self, centre: Centre, seen: NDArray | None) -> None:
        """Keep the fitted shape and follow slow drift of the marker's colour."""
        if np.isfinite(centre.rms_residual):
            self.residual = (centre.rms_residual if self.residual is None
                             else 0.9 * self.residual + 0.1 * centre.rms_residual)
        if np.isfinite(centre.area) and not centre.rim:
            self.area_alpha = (centre.area if self.area_alpha is None
                               else 0.9 * self.area_alpha + 0.1 * centre.area)
        self.shape = centre.params
        if seen is not None:
            self.marker = seen if self.marker is None else 0.9 * self.marker + 0.1 * seen

    def predict(self, t: float) -> tuple[float, float] | None:
        """Constant-velocity prediction from the last two fixes (px); the last fix
        itself once the marker has been lost for more than a frame or two (a
        velocity carried on blindly takes the search away from where it was)."""
        if not self.history:
            return None
        t1, x1, y1 = self.history[-1]
        if len(self.history) < 2 or self.missed > 2:
            return x1, y1
        t0, x0, y0 = self.history[-2]
        if t1 <= t0:
            return x1, y1
        k = (t - t1) / (t1 - t0)
        return x1 + k * (x1 - x0), y1 + k * (y1 - y0)

    def speed_px(self) -> float:
        """Displacement between the last two fixes, px."""
        if len(self.history) < 2:
            return 0.0
        (_, x0, y0), (_, x1, y1) = self.history[-2:]
        return float(np.hypot(x1 - x0, y1 - y0))


def patch_around(image: Frame | NDArray, cx: float, cy: float, half: float
           ) -> tuple[NDArray[np.uint8], int, int]:
    """The pixels within ``half`` px of (cx, cy), clipped to the image, and the
    patch's top-left pixel. ``image`` is a frame (converted to RGB only
    there) or an array (RGB, HSV)."""
    w, h = image.size if isinstance(image, Frame) else (image.shape[1], image.shape[0])
    x0, y0 = max(int(cx - half), 0), max(int(cy - half), 0)
    x1, y1 = min(int(cx + half) + 1, w), min(int(cy + half) + 1, h)
    if isinstance(image, Frame):
        return image.region(x0, y0, x1, y1), x0, y0
    return image[y0:y1, x0:x1], x0, y0


def refine(image: Frame | NDArray[np.uint8], guess: tuple[float, float], radius: float,
           marker: NDArray | None = None, init: tuple[float, ...] | None = None,
           edges: bool | None = None, luminance: bool = False, rim: bool | None = None
           ) -> tuple[Centre, NDArray | None]:
    """Sub-pixel centre of a marker near ``guess`` (see :mod:`.refine`).

    Chroma unmixing against a ring background, then a blurred-disc fit. A
    rough guess (an acquisition: no ``init``) is first improved by a
    weighted centroid and the ring re-centred there; a prediction from the
    previous frames (with ``init``, that frame's fitted shape) goes straight
    to the fit. ``marker`` is the learned marker chroma (None at
    acquisition). ``edges`` adds the luminance of the edge's clean sectors
    (:func:`.refine.fit_edges`); by default it does so for frames with
    full-resolution chroma (:attr:`Frame.full_chroma`), not for arrays. On
    the decoder's own 4:2:0 planes the centre and σ are refitted at the
    chroma's resolution instead (:func:`.refine.fit_disc_cells`).
    ``luminance`` unmixes brightness instead of chroma (a white or black marker:
    luminance is stored at full resolution, so no chroma-cell refit).
    With ``rim`` True the centre is the circle through the marker's rim
    instead (:func:`.outline.fit_outline`: a shaded ball, a bead on its
    string); with ``rim`` None (not yet known which the marker is) that circle
    is taken where the disc fit fails; with False never (a flat marker whose
    disc fit fails is partly hidden, and its rim would be half the cover's
    edge).
    Returns the centre and the chroma seen in its middle.
    """
    if rim is True and init is not None:
        # Following a ball: its rim has a coverage of its own, so the disc fit's is
        # not made at all.
        return _rim(image, guess, radius, marker, luminance)
    patch, x0, y0 = patch_around(image, guess[0], guess[1], radius + 9)
    alpha, seen = local_coverage(patch, x0, y0, guess, radius, marker, luminance)
    c = None
    if init is None:
        c = weighted_centroid(alpha, x0, y0, guess, radius, noise_alpha=0.05)
        if not c.ok:
            return c, seen
        guess = (c.x, c.y)
        alpha, seen = local_coverage(patch, x0, y0, guess, radius, marker, luminance)
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
    fit = fit_disc(alpha, x0, y0, guess, radius, init=init, tol_px=tol)
    for _ in range(3):
        # The background ring must be centred on the marker; a guess more than
        # half a pixel off (a prediction when the motion changes) is redone.
        if not fit.ok or np.hypot(fit.x - guess[0], fit.y - guess[1]) <= 0.5:
            break
        guess = (fit.x, fit.y)
        patch, x0, y0 = patch_around(image, guess[0], guess[1], radius + 9)
        alpha, seen = local_coverage(patch, x0, y0, guess, radius, marker, luminance)
        fit = fit_disc(alpha, x0, y0, guess, radius, init=fit.params, tol_px=tol)
    if fit.ok and edges:
        fit = fit_edges(patch, alpha, x0, y0, fit, radius) or fit
    elif fit.ok and cells:
        # The decoder's own 4:2:0 planes: the chroma is refitted where it was stored.
        fit = fit_disc_cells(alpha, x0, y0, fit)
    if fit.ok:
        return fit, seen
    if rim is None:
        # Perhaps not a flat disc (a shaded ball, a bead on its string): its rim.
        outline, _ = _rim(image, guess, radius, marker, luminance)
        if outline.ok:
            return outline, seen
    if c is None:
        return fit, seen
    return Centre(c.x, c.y, c.sigma, c.radius, True), seen


def _rim(image: Frame | NDArray[np.uint8], guess: tuple[float, float], radius: float,
         marker: NDArray | None, luminance: bool) -> tuple[Centre, NDArray]:
    """The circle through the rim (:func:`.outline.fit_outline`) on the coverage
    against one background (:func:`.outline.rim_coverage`), taken again around the
    fitted centre while it moves by more than half a pixel; and the colour seen in
    the middle around ``guess``."""
    fit = Centre(np.nan, np.nan, np.nan, radius, False)
    seen = None
    for _ in range(4):
        patch, x0, y0 = patch_around(image, guess[0], guess[1], radius + 9)
        alpha, seen_here = rim_coverage(patch, x0, y0, guess, radius, marker, luminance)
        seen = seen_here if seen is None else seen
        fit = fit_outline(alpha, x0, y0, guess, radius)
        if not fit.ok or np.hypot(fit.x - guess[0], fit.y - guess[1]) <= 0.5:
            break
        guess = (fit.x, fit.y)
    return fit, seen


def _honest(c: Centre) -> bool:
    """A centre whose σ says something: finite, and smaller than the marker itself
    (a σ as large as the marker locates nothing and is a gap, not a point)."""
    return bool(np.isfinite(c.sigma) and 0 < c.sigma < c.radius)


def _plausible(c: Centre, guess: tuple[float, float], radius: float) -> bool:
    """A fit from a prediction that found the marker's colour, near the prediction."""
    return c.ok and _honest(c) and GAIN_RANGE[0] < c.gain < GAIN_RANGE[1] and np.hypot(
        c.x - guess[0], c.y - guess[1]) < radius


def _locate(frame: Frame, state: _MarkerState, t: float, hsv_cache: dict
            ) -> tuple[Centre | None, str]:
    w, h = frame.size
    pred = state.predict(t)
    blob, status = None, "not_found"
    if pred is not None and state.radius is not None:
        r = state.radius
        if not (-r <= pred[0] <= w + r and -r <= pred[1] <= h + r):
            status = "out_of_view"
        else:
            # Following: refine straight from the prediction; the colour search
            # is only needed when that fails (fast motion, occlusion, a jump).
            if r + 2 <= pred[0] <= w - r - 3 and r + 2 <= pred[1] <= h - r - 3:
                luminance = bool(state.spec.tone)
                centre, seen = refine(frame, pred, r, state.marker, init=state.shape,
                                      luminance=luminance, rim=state.rim)
                if _plausible(centre, pred, r):
                    if not state.whole(centre):
                        return None, "partly_covered"
                    state.remember(centre, seen)
                    return centre, "ok"
            half = _window(state)
            patch, x0, y0 = patch_around(frame, pred[0], pred[1], half)
            hsv = balanced_hsv(patch, hsv_cache.get("gains"))
            blob, status = choose_blob(find_blobs(hsv, state.spec, x0, y0), state.area, pred)
    whole_frame = blob is None
    if whole_frame:
        if not _search_whole_frame(state, pred):
            return None, status
        blob, full_status = _full_frame_blob(frame, state, t, hsv_cache, pred)
        if blob is None:
            return None, status if status == "out_of_view" else full_status
    centre, seen, failure = _refine_blob(frame, state, blob, hsv_cache)
    if failure and pred is not None and (whole_frame or _search_whole_frame(state, pred)):
        # The blob nearest the prediction was not the marker (a hand, a reflection):
        # the next nearest of its colour and size may be. That needs the whole
        # frame's colours, so only on a frame where the whole frame may be searched.
        # With no velocity yet (seen once) the marker may be anywhere near: as wide
        # as after a whole-frame search.
        wide = whole_frame or len(state.history) < 2
        for other in _other_blobs(frame, state, hsv_cache, pred, blob, wide):
            centre, seen, failure = _refine_blob(frame, state, other, hsv_cache)
            if not failure:
                break
    if failure:
        return None, failure
    if state.radius is None:
        state.radius = centre.radius
    state.remember(centre, seen)
    return centre, "ok"


#: A marker that is not where it was looked for is sought in the whole frame only
#: every this many frames (and in each of the first ones of a video): a full-frame
#: search costs as much as decoding the frame, so a marker that has left the view,
#: or was never there, would otherwise slow every frame down.
FULL_SEARCH_EVERY = 8


def _window(state: _MarkerState) -> float:
    """Half-width (px) of the window searched around the prediction: three radii and
    twice the last step, doubled for each of the first two frames the marker has
    been missed (wider than that costs as much as the whole-frame search)."""
    r = state.radius or 0.0
    return (3.0 * r + 2.0 * state.speed_px() + 4.0) * 2.0 ** min(state.missed, 2)


def _search_whole_frame(state: _MarkerState, pred: tuple[float, float] | None) -> bool:
    """Is this frame one where the whole frame is searched for the marker?"""
    if pred is None or len(state.history) < 2:
        # Not yet seen, or seen once, so with no velocity to say where to look (a
        # thrown ball moves many radii a frame): each of the first frames.
        return state.missed < FULL_SEARCH_EVERY or state.missed % FULL_SEARCH_EVERY == 0
    return state.missed > 0 and state.missed % FULL_SEARCH_EVERY == 0


def _full_hsv(frame: Frame, hsv_cache: dict) -> NDArray[np.uint8]:
    """The whole frame's white-balanced HSV, made once per frame for all markers."""
    if "full" not in hsv_cache:
        if hsv_cache.get("gains") is None:
            hsv_cache["gains"] = white_balance_gains(frame.rgb)
        hsv_cache["full"] = balanced_hsv(frame.rgb, hsv_cache["gains"])
    return hsv_cache["full"]


def _full_frame_blob(frame: Frame, state: _MarkerState, t: float, hsv_cache: dict,
                     pred: tuple[float, float] | None) -> tuple[Blob | None, str]:
    """The marker's blob in the whole frame, white-balanced (lost, or never seen)."""
    near = pred if pred is not None else state.spec.near_px
    blob, status, rivals = acquire(_full_hsv(frame, hsv_cache), state.spec, state.area, near)
    if blob is not None and pred is None and near is not None and np.hypot(
            blob.x - near[0], blob.y - near[1]) > 4 * blob.radius + 20:
        return None, "not_found"  # not yet where the user said it is
    if blob is not None and rivals and pred is None and not state.notes:
        where = "; ".join(f"({r.x:.0f}, {r.y:.0f})" for r in rivals[:3])
        state.notes.append(
            f"marker {state.spec.name}: {1 + len(rivals)} blobs of its colour and size at "
            f"t = {t:.3f} s; following the one at ({blob.x:.0f}, {blob.y:.0f}), not "
            f"{where}; if that is the wrong one, cover or recolour the others, or say "
            f"where it is: --marker {state.spec.name}=COLOUR@X,Y")
    return blob, status


def _other_blobs(frame: Frame, state: _MarkerState, hsv_cache: dict,
                 pred: tuple[float, float], tried: Blob, wide: bool, most: int = 3
                 ) -> list[Blob]:
    """Blobs of the marker's colour, shape and size, nearest to the prediction first,
    other than the one ``tried``, within reach: the search window (:func:`_window`)
    or, ``wide``, 20 radii plus three times the last step (a thrown ball moves 15
    radii a frame). A blob farther off is another object of the same colour, not
    the marker."""
    reach = (20.0 * (state.radius or tried.radius) + 3.0 * state.speed_px() if wide
             else np.sqrt(2.0) * _window(state))
    good = [b for b in find_blobs(_full_hsv(frame, hsv_cache), state.spec) if b.disc_like()
            and (not state.area or 0.3 * state.area <= b.area <= 3.0 * state.area)
            and np.hypot(b.x - tried.x, b.y - tried.y) > 1.0
            and np.hypot(b.x - pred[0], b.y - pred[1]) <= reach]
    good.sort(key=lambda b: (b.x - pred[0]) ** 2 + (b.y - pred[1]) ** 2)
    return good[:most]


def _refine_blob(frame: Frame, state: _MarkerState, blob: Blob, hsv_cache: dict
                 ) -> tuple[Centre | None, NDArray | None, str]:
    """The refined centre on a blob, what it saw, and why it failed ("" if it did not)."""
    radius = state.radius or blob.radius
    if not state.learned:
        # Learning follows a full-frame search, whose white-balanced HSV is at hand.
        hsv_patch, x0, y0 = patch_around(_full_hsv(frame, hsv_cache), blob.x, blob.y,
                                         radius + 3)
        state.spec = learn_spec(state.spec, hsv_patch, (blob.x, blob.y), radius, x0, y0)
        state.learned = True
    luminance = bool(state.spec.tone)
    centre, seen = refine(frame, (blob.x, blob.y), radius, state.marker, luminance=luminance,
                          rim=state.rim)
    if state.rim is None and centre.ok:
        # A flat marker's coverage is even over its middle; a shaded ball's falls
        # away from the light, and pulls a disc fit toward it: that one is centred
        # by its rim from now on (decided once, so that a flat marker partly hidden
        # later is not taken for a ball: its rim would be half the cover's edge).
        patch, x0, y0 = patch_around(frame, centre.x, centre.y, centre.radius + 9)
        alpha, _ = local_coverage(patch, x0, y0, (centre.x, centre.y), centre.radius,
                                  state.marker, luminance)
        state.rim = shaded(alpha, x0, y0, (centre.x, centre.y), centre.radius)
        if state.rim and not centre.rim:
            centre, seen = refine(frame, (centre.x, centre.y), radius, state.marker,
                                  luminance=luminance, rim=True)
        elif not state.rim and centre.rim:
            return None, None, "refine_failed"  # a flat marker's disc fit failed
    if not centre.ok or not _honest(centre) or (
            state.marker is not None and not GAIN_RANGE[0] < centre.gain < GAIN_RANGE[1]):
        return None, None, "refine_failed"
    if not state.whole(centre):
        return None, None, "partly_covered"
    return centre, seen, ""


@dataclass(frozen=True)
class Span:
    """The part of a video to track: from ``start`` to ``end`` inclusive, in seconds
    of the video's clock, or in frame numbers when ``unit`` is ``"frame"``."""

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

    markers: list[_MarkerState]
    balance: dict
    rows: list[list]

    @classmethod
    def start(cls, specs: Sequence[MarkerSpec] = DEFAULT_MARKERS) -> TrackerState:
        """The state before the first frame: nothing learned yet."""
        return cls([_MarkerState(spec) for spec in specs], {"gains": None}, [])

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


def _locate_markers(frame: Frame, state: TrackerState) -> list:
    """Each marker's ``x, y, σ, ok, status`` in one frame, in the tracks table's order.

    Updates ``state``: what each marker has learned, and its last two fixes."""
    values: list = []
    hsv_cache: dict = state.balance.copy()
    found: list[tuple[_MarkerState, Centre]] = []
    for st in state.markers:
        centre, status = _locate(frame, st, frame.t_s, hsv_cache)
        state.balance["gains"] = hsv_cache.get("gains")
        if centre is None:
            values += [np.nan, np.nan, np.nan, False, status]
            st.missed += 1  # searched for around its last fix, in a widening window
        else:
            # After a loss the last fix is too old to give a velocity.
            st.history = [*(st.history[-1:] if st.missed == 0 else []),
                          (frame.t_s, centre.x, centre.y)]
            st.missed = 0
            values += [centre.x, centre.y, centre.sigma, True, status]
            found.append((st, centre))
    _one_blob_each(found, state.markers, values, frame.t_s)
    return values


def _one_blob_each(found: list[tuple[_MarkerState, Centre]], markers: list[_MarkerState],
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
            st.history, st.missed = [], 1  # neither fix is trusted: sought afresh


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


def tracks_table(rows: list[list], specs: tuple[MarkerSpec, ...]) -> pd.DataFrame:
    """The tracks table from finished rows.

    Each found centre's σ is raised to the track's local frame-to-frame scatter
    where its own fit claims less (:mod:`.scatter`). The rows keep the fit's σ,
    so a resumed run raises them over the same frames as an uninterrupted one.
    """
    tracks = pd.DataFrame(rows, columns=tracker_columns(tuple(s.name for s in specs)))
    tracks["frame"] = tracks["frame"].astype(int)
    for s in specs:
        ok = tracks[s.name + "_ok"].astype(bool)
        tracks[s.name + "_ok"] = ok
        xy = tracks[[s.name + "_x_px", s.name + "_y_px"]].to_numpy(float, copy=True)
        xy[~ok.to_numpy()] = np.nan
        tracks[s.name + "_sigma_px"] = with_scatter_floor(
            tracks[s.name + "_sigma_px"].to_numpy(float), xy)
    return tracks


def track(
    source: FrameSource,
    specs: tuple[MarkerSpec, ...] = DEFAULT_MARKERS,
    on_frame: Callable[[int], None] | None = None,
    resume: TrackerState | None = None,
    checkpoint: Callable[[TrackerState], None] | None = None,
    checkpoint_every: int = 250,
    span: Span | None = None,
) -> TrackResult:
    """Find every marker in every frame of ``source`` (within ``span``, if given).

    Returns one row per decoded frame with ``frame``, ``t_s`` and, per marker,
    ``_x_px``, ``_y_px``, ``_sigma_px`` (per-axis 1-σ, px), ``_ok`` and
    ``_status`` (a key of :data:`STATUSES`). A marker found in no frame is
    still a column (all NaN); ``found_fraction`` says so and the caller
    decides what to tell the user.

    ``resume`` continues from a saved :class:`TrackerState` (frames up to its
    last one are decoded but not tracked again); ``checkpoint(state)`` is
    called every ``checkpoint_every`` frames. Ctrl-C raises
    :class:`TrackingInterrupted` with the state so far.

    Raises
    ------
    CranktrackError
        No frame could be decoded.
    """
    state = resume or TrackerState.start(specs)
    done = state.last_frame
    span = span or Span()
    try:
        with _between_frames() as asked:
            for frame in source.frames(prefetch=8):
                if asked:
                    raise KeyboardInterrupt
                if span.after(frame):
                    break
                if frame.index <= done or span.before(frame):
                    continue
                state.rows.append([frame.index, frame.t_s, *_locate_markers(frame, state)])
                if on_frame:
                    on_frame(frame.index)
                if checkpoint and len(state.rows) % checkpoint_every == 0:
                    checkpoint(state)
            if asked:
                raise KeyboardInterrupt
    except KeyboardInterrupt as e:
        raise TrackingInterrupted(state) from e
    if not state.rows:
        if span.given:
            raise CranktrackError(f"no frame of {source.path} lies {span.describe()}")
        raise CranktrackError(f"no frame of {source.path} could be decoded")
    tracks = tracks_table(state.rows, specs)
    found = {s.name: float(tracks[s.name + "_ok"].mean()) for s in specs}
    learned = {st.spec.name: {"hue_deg": round(st.spec.hue_deg, 2),
                              "hue_tol_deg": round(st.spec.hue_tol_deg, 2),
                              "radius_px": None if st.radius is None else round(st.radius, 3)}
               for st in state.markers}
    notes = [n for st in state.markers for n in st.notes]
    return TrackResult(tracks, timing_report(tracks["t_s"].to_numpy(), source.nominal_fps),
                       found, list(source.problems) + notes, learned, state)
