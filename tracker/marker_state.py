"""What the tracker carries for one marker from frame to frame."""

from __future__ import annotations

import itertools
import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .centre import Centre
from .coverage import CHROMA_BASIS, LUMA_BASIS, unmixed_share
from .ellipse import (
    SHAPE_FRAMES,
    SHAPE_MIN_RADIUS_PX,
    SHAPE_REACH_RADII,
    SHAPE_TRIES,
    axis_ratio,
    long_axis_deg,
    metric_of,
    settled_metric,
)
from .foreshortening import Foreshortening
from .lighting import LIGHT_STEP, LUMA_WEIGHTS, light_ratio
from .markers import AREA_GATE, Blob, MarkerSpec, place_reach
from .scatter import STAIR_RATIO
from .template import Template

#: A fit whose residual exceeds this many times the marker's usual residual is
#: not a whole disc (partly covered, or something of its colour touching it).
RESIDUAL_LIMIT = 1.6

#: A marker whose visible area Σα differs from its usual by more than this
#: fraction is not whole (partly covered), or not alone.
AREA_TOLERANCE = 0.2
#: ...but one whose area and middle are both within this fraction of their usual is
#: whole whatever its residual: a disc sheared by a rolling shutter while it moves
#: fast (a drawn 6 px disc at 25 px a frame, read over 20 ms by 240 rows: residual 2.9×
#: its still one, area and middle within 0.3 %) is the marker itself, not a cover.
SAME_AREA = 0.05
#: A marker whose middle is dimmed to no less than this fraction of its usual α is
#: judged by its area in its own brightness (Tracker's ball toss: 0.73 in its last
#: frame); darker, it is taken as covered.
DIMMED_MIN = 0.5

#: A disc less than this fraction of which lies inside the frame is not taken from
#: what is left: its centre would rest on an arc of its rim alone. A drawn disc of
#: 10 px moving out past the frame's edge, fitted from its visible part, was 0.011 px
#: off with 4.6 px of it out, 0.028 px with 7.4 px out and 0.022 px with half of it
#: out (scratch, `tests/test_real_footage_like.py`'s drawing).
LEAST_INSIDE = 0.5

#: Points of a grid over the unit disc (each the middle of a cell 1/16 wide), over
#: which :func:`disc_in_frame` counts.
_DISC_POINTS = np.array([(u, v) for u in (np.arange(32) + 0.5) / 16.0 - 1.0
                         for v in (np.arange(32) + 0.5) / 16.0 - 1.0 if u * u + v * v < 1.0])


def disc_in_frame(x: float, y: float, r: float, size: tuple[int, int]) -> float:
    """The fraction (0–1) of a disc of radius ``r`` px about (``x``, ``y``) px that lies
    inside a frame of ``size`` (width, height) px, whose pixels' middles are at 0 …
    width − 1 (so its edges at −0.5 and width − 0.5). Within 0.01 of the exact
    fraction where the frame's edge crosses the disc (a grid of 812 points; a disc of
    10 px whose middle lies 3 px inside the edge: 0.695 against 0.688); exactly 1 clear of it."""
    w, h = size
    if not r > 0 or not (np.isfinite(x) and np.isfinite(y)):
        return 0.0
    if x - r >= -0.5 and y - r >= -0.5 and x + r <= w - 0.5 and y + r <= h - 0.5:
        return 1.0
    px, py = x + r * _DISC_POINTS[:, 0], y + r * _DISC_POINTS[:, 1]
    return float(np.mean((px >= -0.5) & (px <= w - 0.5) & (py >= -0.5) & (py <= h - 0.5)))


#: A marker's size is learned over the first this many frames it is found in, not
#: from the first alone: on a real clip the first frame was a still in which a
#: sticker showed as a 2 px speck, and every later (whole) view of it was then
#: rejected as too big. Until then its size gates blobs loosely and its look not at
#: all.
LEARN_FINDS = 5

#: A placed marker found in fewer than :data:`LEARN_FINDS` frames, then missed in this
#: many frames in a row while its last fix is still by its place, was a false start,
#: and is sought afresh (:meth:`MarkerState.restarted`). On OpenCV's vtest.avi with an
#: invisible ±1 DN pattern added, the green board given by its place was first found
#: on its lower and upper parts in turn (a white line across it splits its blob), and
#: learned so it was then refused in 649 of its 795 frames; sought afresh, in 7.
FALSE_START_MISSES = 3

#: A marker missed for at most this many frames keeps its motion: the prediction
#: still runs through its fixes from before the gap.
KEEP_MOTION_MISSED = 2

#: How far a marker's usual fitted gain may move the gains taken for it (a factor).
GAIN_DRIFT = 1.5
#: How much higher a gain is taken while a marker (not a flat disc) is learned. With an
#: invisible ±1 DN pattern added, a falling cup's gain against the colour seen in its
#: first fit was 1.73–1.95, and above 1.7 it was lost from its second frame on. Not
#: more: at 1.5× (up to 2.55), vtest's second cone learned a 1.9 px fit of its
#: reflector (it is 4 px) and was then found in 98 of 795 frames, not 785.
LEARNING_GAIN_HEADROOM = 1.2

#: Fixes kept for the prediction: three for a parabola in time, and one more to
#: tell a repeated picture from a turn (:func:`_repeats_picture`).
HISTORY_FIXES = 4

#: A marker whose last :data:`REST_STEPS` steps between fixes are each shorter than
#: this many radii stands still, or nearly: a pivot, a cone on the ground (whose fixes
#: scatter by 0.2–0.7 px on a real clip).
REST_STEP = 0.25
#: Three steps (four fixes): a crank at the turning point of its swing stands still
#: for a frame or two, and with the picture there repeated (a phone that cannot keep
#: up) for three fixes; taken for a marker at rest after two steps, it was refused its
#: next fix 9.5 px on (1.7 radii) and lost for 16 frames of a render.
REST_STEPS = 3
#: ...and a marker standing still is not taken farther than this many radii from its
#: prediction (that is a neighbour of its colour), for up to :data:`REST_MEMORY`
#: frames missed. On OpenCV's vtest.avi (a fixed camera) a road sign on a stand,
#: given as a marker, went back and forth between its two orange patches 14 px
#: (3.5 radii) apart whenever a fit failed: about half its frames on each.
REST_REACH = 1.5
REST_MEMORY = 64
#: ...unless it has moved off: two fixes refused so since its last fix taken, the
#: second at least this many radii on from the first, are a marker that has started to
#: move (:meth:`MarkerState.moved_off`); a neighbour of its colour stays where it is.
#: On yupi's rover-wheel clip (Viera2017.mp4) a green LED at rest for 163 frames set
#: off at 4–6 px a frame (1.3–2 radii), its first fit on the move failed, and every
#: later fix was refused as off its place: lost for good.
MOVE_STEP = 0.5
#: ...and the step on from the first refused fix keeps within 45° of the way from the
#: place to it (the cosine): a marker sets off along a path. On box.mp4 (no markers),
#: the defaults went from things at rest to others 170 px away, turning 56° and 140°.
MOVE_ALIGN = 0.7
#: ...and the first refused fix lies within this many radii of the place: a marker
#: setting off is first seen off its place a few radii on (the rover's LED 3.6, a test's
#: marker hidden two frames at 2.2 radii a frame 6.5). With rests kept through jitter
#: (:meth:`MarkerState.found_at`), vtest.avi's resting reflector cone (4 px) was taken
#: up 52 px off, on two fixes on people walking away from it; with a bound of 8, under
#: an invisible ±1 DN pattern, from a first fix 7.95 radii off (and then followed
#: 170 px away: 15 fixes over 3 px off).
MOVE_REACH = 7.0

#: The step (px) before a fix that all but stops, from which the fix is taken for a
#: repeated picture when predicting: slower, a stall changes the prediction by less
#: than the window allows, and a marker at rest scatters by half a pixel on a real
#: clip (vtest's sign), whose steps would pass :data:`.scatter.STAIR_STEP_PX`.
STALL_STEP_PX = 2.0
#: ...after a step at least this fraction of the one before it.
STEADY = 0.8


def _aligned(a: tuple[float, float], b: tuple[float, float], cos_min: float) -> bool:
    """Do steps ``a`` and ``b`` (px) point within the angle whose cosine is ``cos_min``?"""
    return a[0] * b[0] + a[1] * b[1] >= cos_min * math.hypot(*a) * math.hypot(*b)


def _one_way(steps: list[tuple[float, float]], reach: float) -> bool:
    """Do short ``steps`` (px) go one way: each within :data:`MOVE_ALIGN` of their sum,
    which is at least ``reach`` (px) long? A marker moving slowly does; one standing
    still jitters about its place. Taken for one at rest, a marker at 0.17 radii a
    frame hidden behind another for 9 frames was refused where it came out, 1.7 radii
    on, for 15 frames and more (:data:`REST_REACH`)."""
    total = (sum(s[0] for s in steps), sum(s[1] for s in steps))
    return math.hypot(*total) >= reach and all(_aligned(s, total, MOVE_ALIGN) for s in steps)


def _repeats_picture(history: list[tuple[float, float, float]]) -> bool:
    """Does the last of the fixes (t s, x px, y px) repeat the picture before it: the
    marker all but stopped (:data:`.scatter.STAIR_RATIO` of the step before, that step
    at least :data:`STALL_STEP_PX`) in a frame as long as the one before? The
    tracker cannot yet see the step after it, which :func:`.scatter.repeated_frames`
    also asks to point the same way; a real sudden stop is predicted a step on, and
    found by the window search around that."""
    if len(history) < 4:
        return False
    # Plain floats: this runs for every marker on every frame.
    fixes = history[-4:]
    dt = [b[0] - a[0] for a, b in itertools.pairwise(fixes)]
    step = [(b[1] - a[1], b[2] - a[2]) for a, b in itertools.pairwise(fixes)]
    earlier, before, here = (math.hypot(*d) for d in step)
    # Steady before it, as the marker was (a swing slowing into its turn is not: a
    # real pendulum's steps of 3.7, 2.6 and 0.4 px were taken for a repeat, its next
    # prediction went on past the turn, and its fits from there changed by up to
    # 0.8 px), in frames of one length.
    turn = step[0][0] * step[1][0] + step[0][1] * step[1][1]
    steady = before >= STEADY * earlier and turn > 0.5 * earlier * before
    even = max(dt) - min(dt) < 0.25 * min(dt)
    return even and steady and before >= STALL_STEP_PX and here <= STAIR_RATIO * before


#: A printed disc's fitted edge this wide (px) or wider is out of focus. In focus on
#: H.264 4:2:0 the crank-slider's discs fit at 1.0–1.5 px (the SMA bed of
#: bench/sma_bed_apart.py with its lens's blur of 0.6 px: 1.02–1.51); blurred by 1.5 px,
#: 1.8–1.9 and θ still within its σ; by 2 px, 1.9–2.4 and B refused in every frame.
OUT_OF_FOCUS_EDGE_PX = 2.0
#: How many of a marker's last disc fits its edge width is the median of.
EDGES_KEPT = 51


@dataclass
class MarkerState:
    """What the tracker remembers of one marker from frame to frame: what it looks
    like (its learned colour, radius, fitted shape, usual residual and area) and
    where it was (its last fixes, and how many frames it has been missed)."""

    spec: MarkerSpec
    learned: bool = False
    radius: float | None = None  # from the first fit, px
    #: The last :data:`HISTORY_FIXES` fixes (t s, x px, y px), oldest first.
    history: list[tuple[float, float, float]] = field(default_factory=list)
    missed: int = 0  # frames since the last fix (or since the start, never found)
    shape: tuple[float, ...] | None = None  # last fitted disc parameters
    #: Centred by its rim (a shaded ball: the disc fit is pulled toward the light)?
    #: None until decided at the first acquisition.
    rim: bool | None = None
    #: Half the length and half the width of a marker that is not a disc (a strip, a
    #: square), px: it is centred by its coverage's centroid
    #: (:func:`.refine.refine_blob`). None for a disc; decided at the first
    #: acquisition.
    extent: tuple[float, float] | None = None
    marker: NDArray | None = None  # learned marker chroma (.coverage's plane)
    #: The RGB of its middle (DN), followed as ``marker`` is (:meth:`see_rgb`).
    marker_rgb: NDArray | None = None
    #: The light (:meth:`.video.Frame.light`: R, G, B, DN) its colour was seen in
    #: (weighed over its fixes as the colour is), and this frame's (:meth:`in_light`).
    light: NDArray | None = None
    frame_light: NDArray | None = None
    #: The factors (R, G, B) the colour is fitted with on a second try in another
    #: light (:meth:`try_light`); None otherwise.
    lit: NDArray | None = None
    #: Usual RMS residual of the disc fit; for a template marker, how unlike its
    #: picture its matches usually are (1 − score).
    residual: float | None = None
    area_alpha: float | None = None  # usual visible area Σα, px²
    radius_sq: float | None = None  # usual fitted radius², px², weighed as area_alpha
    peak: float | None = None  # usual α in the marker's middle (Centre.peak)
    #: Usual fitted coverage gain (1 for a disc; a strip of tape fitted as a disc
    #: shows ≈ 1.5, its blur and gain trading off), learned after the size.
    gain: float | None = None
    #: How far the fixes have been from their predictions lately, px (the largest
    #: of the last, or 0.7 of the one before): how predictable the motion is. None
    #: until a fix was predicted from a velocity.
    surprise_px: float | None = None
    #: How a round mark on the plane looks in the image (a calibration's, given to
    #: :func:`.track.track`); None: round everywhere.
    foreshortening: Foreshortening | None = None
    #: Without a calibration, a printed disc's ellipse (:mod:`.ellipse`): the shape
    #: terms (u, v) measured on its resting fixes, while fewer than
    #: :data:`.ellipse.SHAPE_FRAMES`; then the settled ones (None: round), and where
    #: they were measured (px), from which frame on (``shape_from``, -1 until settled);
    #: the frame of the first fix measured (``shape_first``).
    shapes_seen: list[tuple[float, float]] = field(default_factory=list)
    shape_first: int = -1
    #: Resting fixes its ellipse was measured on, whether the fit came out or not.
    shape_tries: int = 0
    ellipse: tuple[float, float] | None = None
    ellipse_at: tuple[float, float] | None = None
    shape_from: int = -1
    #: Has it been standing still (:meth:`off_its_place`)?
    resting: bool = False
    #: The last steps between fixes (dx, dy px), up to :data:`REST_STEPS`, while each
    #: was short (empty after a long one).
    short_steps: list[tuple[float, float]] = field(default_factory=list)
    #: The last step between fixes (dx, dy px) if it was not short, else None.
    long_step: tuple[float, float] | None = None
    #: The last fix refused as off a resting marker's place since its last fix
    #: (t s, the fit), for :meth:`moved_off`.
    stray: tuple[float, Centre] | None = None
    #: A refused fix :meth:`moved_off` has since taken up as the marker setting off
    #: (t s, the fit): its frame's row is the marker's after all.
    taken_up: tuple[float, Centre] | None = None
    notes: list[str] = field(default_factory=list)  # things the user should hear about
    #: The nearest blob refused as too far from where the user placed the marker
    #: (x px, y px, distance px), to name if the marker is never found.
    refused_near: tuple[float, float, float] | None = None
    radii_seen: list[float] = field(default_factory=list)  # fitted radii while learning, px
    #: After a false start, the spec as its colour was learned at the first find; each
    #: later restart goes back to it, not to one learned again from fewer finds.
    first_colour: MarkerSpec | None = None
    #: A placed marker not yet found: the last blob by its place whose fit failed. On
    #: vtest.avi under an invisible ±1 DN pattern, the white plate's blob stood alone
    #: in frame 1 only and its fit failed there; in later frames the plate's colour
    #: merged with the wall's into one ragged blob, and it was not found until frame
    #: 230. Fitted again at this blob, it is found from frame 2.
    placed_failed: Blob | None = None
    #: Frames in which the marker was found while learning its size.
    learning_frames: list[int] = field(default_factory=list)
    #: Edge widths of its last :data:`EDGES_KEPT` disc fits (the model's Gaussian blur),
    #: px: how sharp it is (:func:`focus_notes`).
    edges_seen: deque[float] = field(default_factory=lambda: deque(maxlen=EDGES_KEPT))
    #: Frames whose blob of its colour, a printed disc's, was refused as shaded.
    refused_shaded: int = 0
    #: It has been found larger than learned and its size taken anew (:meth:`regrow`):
    #: how many times, and its radius as first learned (px).
    nearing: bool = False
    regrown: int = 0
    learned_radius: float | None = None
    #: After a false start: its frames and radius (px), to be judged at the next find.
    false_start: tuple[list[int], float] | None = None
    #: A template marker's picture (:mod:`.template`), taken where it was placed in
    #: the first frame tracked; None before that, and for a colour or tone marker.
    template: Template | None = None

    @property
    def learning(self) -> bool:
        """Still learning the marker's size (found in fewer than :data:`LEARN_FINDS`
        frames)?"""
        return len(self.radii_seen) < LEARN_FINDS

    @property
    def started_falsely(self) -> bool:
        """A marker the user placed (``--marker NAME=COLOUR@X,Y``), found in a few frames
        only, then missed in :data:`FALSE_START_MISSES` in a row, its last fix within
        reach of the place (:func:`.markers.place_reach`)? Sought afresh it is looked
        for by its place only: one that has moved on (a falling cup found rightly,
        then missed for three frames) would be lost for good. A marker not
        placed is not judged so: with nothing to say where it should be, sought afresh
        it took other things of its colour (on vtest.avi, which has no markers, the
        default red B was then "found" in 353 frames, not 12)."""
        near = self.spec.near_px
        if near is None or not 0 < len(self.radii_seen) < LEARN_FINDS \
                or self.missed < FALSE_START_MISSES or not self.history:
            return False
        _, x, y = self.history[-1]
        return math.hypot(x - near[0], y - near[1]) <= place_reach(self.radius or 0.0)

    def restarted(self, t: float) -> MarkerState:
        """The marker sought afresh after a false start, as before its first find: what
        was learned from those few finds of its size, shape and motion is forgotten.
        Its colour (the hue window learned at the first find) is kept: forgotten too,
        vtest's second cone, with a ±1 DN pattern, jumped more than 3 px in 381 of
        1247 fixes, not 0. The frames and radius of the false start are kept, for
        :meth:`like_false_start` at the next find, and the user hears of it once."""
        spec = self.first_colour or self.spec
        notes = list(self.notes)
        if not any("false start" in n for n in notes):
            frames = ", ".join(str(f) for f in self.learning_frames)
            notes.append(
                f"marker {spec.name}: found in frame(s) {frames} (radius "
                f"{self.radius:.1f} px), then missed in {self.missed} frames in a row by "
                f"t = {t:.3f} s; taken for a false start and sought afresh")
        # It stays missed as long as it was: its whole-frame searches keep backing off.
        return MarkerState(spec, rim=False if spec.flat else None, missed=self.missed,
                           notes=notes, first_colour=spec,
                           false_start=(list(self.learning_frames), float(self.radius)),
                           foreshortening=self.foreshortening)

    def like_false_start(self, radius: float) -> bool:
        """Is a marker found at ``radius`` px after a false start the thing found then
        (within :data:`.markers.AREA_GATE` of its area)?"""
        if self.false_start is None:
            return True
        area = (radius / self.false_start[1]) ** 2
        return AREA_GATE[0] <= area <= AREA_GATE[1]

    def refuse_far(self, blob_x: float, blob_y: float, distance: float) -> None:
        """Remember a blob refused as ``distance`` px from the marker's place, if nearer
        than any refused before."""
        if self.refused_near is None or distance < self.refused_near[2]:
            self.refused_near = (blob_x, blob_y, distance)

    def never_found_note(self) -> str | None:
        """For a placed marker never found, where the nearest blob of its colour and size
        lay (or None)."""
        if self.refused_near is None or self.spec.near_px is None:
            return None
        x, y, d = self.refused_near
        px, py = self.spec.near_px
        return (f"marker {self.spec.name} was never within reach of its place ({px:.0f}, "
                f"{py:.0f}): the nearest blob of its colour and size was at ({x:.0f}, {y:.0f}),"
                f" {d:.0f} px off, and a place is taken within the blob's diameter + 8 px. "
                f"If that is the marker, say --marker {self.spec.name}="
                f"{self.spec.tone or f'{self.spec.hue_deg:g}'}@{x:.0f},{y:.0f}")

    @property
    def edge_px(self) -> float | None:
        """Its disc fits' usual edge width, px: the median of the last
        :data:`EDGES_KEPT` (a first fit from scratch may stop short of it)."""
        return float(np.median(self.edges_seen)) if self.edges_seen else None

    @property
    def area(self) -> float | None:
        """The marker's expected blob area, px² (from its radius)."""
        return None if self.radius is None else float(np.pi * self.radius**2)

    @property
    def area_gates(self) -> tuple[tuple[float, float], ...]:
        """The blob areas a whole-frame search takes for the marker, as multiples of
        :attr:`area`, each gate tried only when nothing passed the one before:
        :data:`.markers.AREA_GATE` (0.3–3), and while its size is being learned
        0.1–10 after that (a 2.5 px speck that is a 7 px disc later passes; a 0.5 px
        glint beside a 4.5 px ball does not, and a hand 4× the ball's area loses to
        the ball far off)."""
        return (AREA_GATE, (0.1, 10.0)) if self.learning else (AREA_GATE,)

    def gain_range(self, nominal: tuple[float, float]) -> tuple[float, float]:
        """The fitted gains taken for the marker: ``nominal`` (for a gain of 1) times
        its usual gain, which may move the range by :data:`GAIN_DRIFT` either way.
        On a falling paper cup (a 8×3 px strip) the gain was 1.0–1.75 and a fixed
        upper bound of 1.7 lost it in one frame of nine. While a marker of any shape
        (not one of the crank-slider's flat discs, whose gain is 1) is being learned
        its usual gain is not known yet, and the upper bound is raised by
        :data:`LEARNING_GAIN_HEADROOM`."""
        if self.learning and not self.spec.flat:
            return nominal[0], nominal[1] * LEARNING_GAIN_HEADROOM
        usual = 1.0 if self.gain is None else min(max(self.gain, 1 / GAIN_DRIFT), GAIN_DRIFT)
        return nominal[0] * usual, nominal[1] * usual

    def unmixed(self, centre: Centre, size: tuple[int, int]) -> float:
        """The share (0–1) of the fitted marker whose coverage was unmixed in a frame of
        ``size`` (width, height) px: of a disc, the pixels whose background ring lies on
        the frame (:func:`.coverage.unmixed_share`); of a strip or streak, centred by
        its coverage's centroid (``extent``), which keeps every pixel, the part of it
        inside the frame (:func:`disc_in_frame`, at its fitted radius)."""
        if self.extent is not None:
            return disc_in_frame(centre.x, centre.y, centre.radius, size)
        return unmixed_share(centre.x, centre.y, centre.radius, size)

    def whole(self, centre: Centre, nearer: bool = False,
              size: tuple[int, int] | None = None) -> bool:
        """Does the fit look like the whole marker: its usual visible area and residual?
        (A rim fit has weighed out what covers the marker already; while learning,
        there is no usual yet.) ``nearer``: the marker has come nearer, and its usual
        area is taken at the fit's radius. ``size``: the frame's (width, height) px; by
        the frame's edge a disc is judged by its area over the pixels whose coverage was
        unmixed (:func:`.coverage.unmixed_share`: those whose background ring lies on
        the frame; the fit uses no others) and not by its residual, and one the edge
        cuts is not taken with less than :data:`LEAST_INSIDE` of it in the frame
        (:func:`disc_in_frame`)."""
        near_edge = size is not None and np.isfinite(centre.radius)
        if near_edge and disc_in_frame(centre.x, centre.y, centre.radius, size) < LEAST_INSIDE:
            return False
        if centre.rim or self.learning:
            return True
        unmixed = self.unmixed(centre, size) if near_edge else 1.0
        if self.area_alpha is not None and np.isfinite(centre.area):
            usual = self.area_alpha * unmixed
            if nearer and self.radius and np.isfinite(centre.radius):
                usual *= (centre.radius / self.radius) ** 2
            shown = centre.area / usual
            if shown < 1 - AREA_TOLERANCE and self._going_away(centre):
                # The usual area follows each fit by a tenth, so it lags about nine
                # frames of shrinking behind: discs going from 30 to 21 px in radius
                # over 30 frames were judged covered from frame 19-23 on. Judged at
                # the fitted size, they are found in 29-30 of the 30.
                shown *= self.radius_sq / centre.radius**2
            if shown < 1 - AREA_TOLERANCE:
                # Less area: covered, or dimmed as a whole (a ball falling out of the
                # light). Covered, its middle keeps its usual α; dimmed, it does not,
                # and the area in its own brightness is whole. A middle at less than
                # half its brightness is more likely hidden itself (a bar across it).
                dim = (centre.peak / self.peak if self.peak and np.isfinite(centre.peak)
                       else 1.0)
                if not DIMMED_MIN <= dim <= 1 - AREA_TOLERANCE / 2 \
                        or shown / dim < 1 - AREA_TOLERANCE:
                    return False
            elif shown > 1 + AREA_TOLERANCE:
                return False
        if self.residual is None or not np.isfinite(centre.rms_residual) or unmixed < 1.0:
            # By the frame's edge, the fit's residual is over the pixels whose ring lies
            # on the frame, fewer and another mix than the usual's.
            return True
        if centre.rms_residual <= RESIDUAL_LIMIT * max(self.residual, 0.01):
            return True
        return self._same_area_and_middle(centre)

    def _going_away(self, centre: Centre) -> bool:
        """Is the fit the whole marker seen smaller, as it goes away from the camera: its
        radius, and its last fit's, over 1 px short of the learned one, with its usual
        residual and its middle's usual α?"""
        return bool(self.radius and self.radius_sq and self.residual and self.peak
                    and np.isfinite(centre.radius) and np.isfinite(centre.peak)
                    and np.isfinite(centre.rms_residual)
                    and centre.radius < self.radius - 1.0
                    and self.shape is not None and len(self.shape) > 2
                    and self.shape[2] < self.radius - 1.0
                    and centre.rms_residual <= RESIDUAL_LIMIT * max(self.residual, 0.01)
                    and abs(centre.peak / self.peak - 1) <= SAME_AREA)

    def _same_area_and_middle(self, centre: Centre) -> bool:
        """Are the fit's visible area and middle both within :data:`SAME_AREA` of the
        marker's usual (so what raised its residual covers none of it)?"""
        if self.area_alpha is None or self.peak is None or not (
                np.isfinite(centre.area) and np.isfinite(centre.peak)):
            return False
        return (abs(centre.area / self.area_alpha - 1) <= SAME_AREA
                and abs(centre.peak / self.peak - 1) <= SAME_AREA)

    def regrow(self, radius: float) -> None:
        """Take ``radius`` (px) as the marker's size from now: it has come nearer. Its
        usual area is the next fit's."""
        if self.learned_radius is None:
            self.learned_radius = self.radius
        self.radius, self.area_alpha, self.peak, self.radius_sq = radius, None, None, None
        self.nearing = True
        self.regrown += 1

    def remember(self, centre: Centre, seen: NDArray | None, frame: int = -1) -> None:
        """Keep the fitted shape and follow slow drift of the marker's colour; while
        learning, its radius is the median of those fitted so far, and its usual
        residual and area are the latest fit's. ``frame`` is the frame's index."""
        if self.learning and np.isfinite(centre.radius):
            self.radii_seen.append(centre.radius)
            self.learning_frames.append(frame)
            self.radius = float(np.median(self.radii_seen))
            self.residual = self.area_alpha = self.peak = self.radius_sq = None
        if np.isfinite(centre.rms_residual):
            self.residual = (centre.rms_residual if self.residual is None
                             else 0.9 * self.residual + 0.1 * centre.rms_residual)
        if not self.learning and np.isfinite(centre.gain) and not centre.rim:
            self.gain = (centre.gain if self.gain is None
                         else 0.9 * self.gain + 0.1 * centre.gain)
        if np.isfinite(centre.area) and not centre.rim:
            self.area_alpha = (centre.area if self.area_alpha is None
                               else 0.9 * self.area_alpha + 0.1 * centre.area)
            if np.isfinite(centre.radius):
                self.radius_sq = (centre.radius**2 if self.radius_sq is None
                                  else 0.9 * self.radius_sq + 0.1 * centre.radius**2)
        if np.isfinite(centre.peak):
            self.peak = (centre.peak if self.peak is None
                         else 0.9 * self.peak + 0.1 * centre.peak)
        if centre.params is not None and not centre.rim and np.isfinite(centre.params[3]):
            self.edges_seen.append(float(centre.params[3]))
        self.shape = centre.params
        if self.lit is not None and self.marker is not None:
            # Found in another light (try_light): its colour is that light's from now.
            self.marker, self.light = self.colour, self.frame_light
            if self.marker_rgb is not None:
                self.marker_rgb = self.marker_rgb * self.lit
            self.lit = None
        if seen is not None:
            self.marker = seen if self.marker is None else 0.9 * self.marker + 0.1 * seen
            # The light the colour was seen in, weighed as the colour is.
            if self.frame_light is not None:
                self.light = (self.frame_light if self.light is None
                              else 0.9 * self.light + 0.1 * self.frame_light)

    def see_rgb(self, rgb: NDArray | None) -> None:
        """Follow the RGB of the marker's middle (DN) at a fix, as its colour is followed."""
        if rgb is not None:
            self.marker_rgb = (rgb if self.marker_rgb is None
                               else 0.9 * self.marker_rgb + 0.1 * rgb)

    def in_light(self, light: NDArray) -> None:
        """Take this frame's light (:meth:`.video.Frame.light`: R, G, B, DN)."""
        self.frame_light, self.lit = light, None

    def try_light(self) -> bool:
        """Set the colour to be fitted with (:attr:`colour`) to the marker's own scaled,
        channel by channel, by how much this frame's light differs from the light it was
        seen in, where that is by more than :data:`LIGHT_STEP` in a channel; say whether
        it did. For a second fit beside the one in the colour as learned: a camera's
        exposure or white balance stepping, a lamp flickering or switched on scales
        every colour in the frame; but a lit LED keeps its colour while the room around
        it darkens."""
        ratio = (None if self.marker is None or self.light is None or self.frame_light is None
                 else light_ratio(self.frame_light, self.light))
        if ratio is None or np.max(np.abs(ratio - 1.0)) <= LIGHT_STEP:
            return False
        self.lit = ratio
        return True

    def stretch_at(self, x: float, y: float) -> tuple[float, float, float] | None:
        """The disc model's metric at image px (``x``, ``y``) (:func:`.disc.stretch_of`)
        for a flat marker, printed on the plane the calibration is of; without a
        calibration, the ellipse learned while it stood (:meth:`saw_shape`) within
        :data:`.ellipse.SHAPE_REACH_RADII` radii of there; else None (round), as for a
        marker that is not flat (a ball is round from any side)."""
        if not self.spec.flat:
            return None
        if self.foreshortening is not None:
            return self.foreshortening.at(x, y)
        if self.ellipse is not None and self.ellipse_at is not None and self.radius \
                and math.hypot(x - self.ellipse_at[0], y - self.ellipse_at[1]) \
                <= SHAPE_REACH_RADII * self.radius:
            return metric_of(*self.ellipse)
        return None

    def measuring_shape(self) -> bool:
        """Is its ellipse still to be measured on this fix (:mod:`.ellipse`): a printed
        disc of :data:`.ellipse.SHAPE_MIN_RADIUS_PX` or more, without a calibration, at
        rest, not yet settled, tried on fewer than :data:`.ellipse.SHAPE_TRIES` fixes?"""
        return (self.spec.flat and self.foreshortening is None and self.shape_from < 0
                and self.resting and not self.rim and self.shape_tries < SHAPE_TRIES
                and (self.radius or 0.0) >= SHAPE_MIN_RADIUS_PX)

    def saw_shape(self, u: float, v: float, x: float, y: float, frame: int) -> None:
        """Take the shape terms measured on a resting fix at (``x``, ``y``) px in
        ``frame``; settle them after :data:`.ellipse.SHAPE_FRAMES` fixes."""
        if not self.shapes_seen:
            self.shape_first = frame
        self.shapes_seen.append((u, v))
        if len(self.shapes_seen) < SHAPE_FRAMES:
            return
        self.ellipse = settled_metric(self.shapes_seen)
        self.ellipse_at, self.shape_from = (x, y), frame
        if self.ellipse is not None:
            eu, ev = self.ellipse
            self.notes.append(
                f"marker {self.spec.name}: standing still from frame {self.shape_first} it "
                f"was seen as an ellipse (axes {axis_ratio(eu, ev):.3f} : 1, the longer at "
                f"{long_axis_deg(eu, ev):.0f}° from +x): the camera is not square to the "
                f"rig; from frame {frame + 1} it is fitted as that ellipse within "
                f"{SHAPE_REACH_RADII:.0f} radii of there. A plane calibration "
                "(`cranktrack calibrate plane`) would say the shape everywhere, and map "
                "the plane too")

    @property
    def colour(self) -> NDArray | None:
        """The colour the marker is fitted with (:func:`.coverage.local_coverage`'s
        ``marker``): ``marker``, or in another light (``lit``) ``marker`` scaled by the
        light's overall change, plus what the channels' differences from it make of the
        middle's RGB. Where every channel changed alike, that is ``marker`` times it."""
        if self.marker is None or self.lit is None:
            return self.marker
        overall = float(LUMA_WEIGHTS @ self.lit)
        if self.marker_rgb is None:
            return self.marker * overall
        basis = LUMA_BASIS if self.spec.tone else CHROMA_BASIS.astype(np.float64)
        return self.marker * overall + basis @ ((self.lit - overall) * self.marker_rgb)

    def predict(self, t: float) -> tuple[float, float] | None:
        """Where the marker should be at ``t`` (px), from its last fixes: a parabola
        through the last three (constant acceleration: a thrown ball, a falling cup),
        a line through the last two, or the last fix itself once the marker has been
        lost for more than :data:`KEEP_MOTION_MISSED` frames (a velocity carried on
        blindly takes the search away from where it was).

        Fixes may be a frame or two apart (a marker missed in between): the fit is
        in time, so the gap is allowed for. On a falling cup (Tracker's CupsClips,
        10 fps) the line missed by 4–9 px, twice its size, and every frame fell back
        to the window search; the parabola missed by 1.4–2.7 px."""
        if not self.history:
            return None
        history = self.history
        if self.missed == 0 and _repeats_picture(history):
            # The last fix shows the picture before it again: where the marker was
            # then, not at that fix's time. A parabola through it turns the marker
            # back (on a spool render with one picture in the stroke repeated, the
            # next frame was predicted 7 px behind and lost); the line through the
            # two fixes before it carries it on.
            history = history[:-1]
        t1, x1, y1 = history[-1]
        if len(history) < 2 or self.missed > KEEP_MOTION_MISSED:
            return x1, y1
        t0, x0, y0 = history[-2]
        if t1 <= t0:
            return x1, y1
        k = (t - t1) / (t1 - t0)
        linear = (x1 + k * (x1 - x0), y1 + k * (y1 - y0))
        if len(history) < 3 or history[-3][0] >= t0:
            return linear
        # Lagrange's parabola through the three fixes, evaluated at t.
        ta = history[-3][0]
        w = np.array([(t - t0) * (t - t1) / ((ta - t0) * (ta - t1)),
                      (t - ta) * (t - t1) / ((t0 - ta) * (t0 - t1)),
                      (t - ta) * (t - t0) / ((t1 - ta) * (t1 - t0))])
        xs = np.array([p[1] for p in history[-3:]])
        ys = np.array([p[2] for p in history[-3:]])
        return float(w @ xs), float(w @ ys)

    def found_at(self, t: float, x: float, y: float, predicted: tuple[float, float] | None
                 ) -> None:
        """Take a fix at (x, y) px, time ``t`` s: the motion history and, where the fix
        was predicted from a velocity (``predicted``), how far off that was."""
        moving = predicted is not None and len(self.history) >= 2
        if moving and self.missed <= KEEP_MOTION_MISSED:
            miss = float(np.hypot(x - predicted[0], y - predicted[1]))
            self.surprise_px = max(miss, 0.7 * (self.surprise_px or 0.0))
        elif self.missed > KEEP_MOTION_MISSED:
            self.surprise_px = None
        # After a short loss the fixes before it still give the motion; after a
        # longer one they are too old.
        history = self.history
        if self.missed == 0 and _repeats_picture(history):
            # The fix before repeated the picture before it: its time is not its
            # picture's, and a parabola through it would bend the motion.
            history = history[:-1]
        kept = history[1 - HISTORY_FIXES:] if self.missed <= KEEP_MOTION_MISSED else []
        self.history = [*kept, (t, x, y)]
        self.missed = 0
        self.stray = None
        # Standing still or moving, remembered past a loss, as are the steps before
        # it. One step out of line (a poor fit) does not end a rest, nor two that go
        # back and forth: two long steps one way (within MOVE_ALIGN) do. Vtest.avi's
        # reflector cone, whose fixes step by a quarter of its radius or more, lost its
        # rest on such jitter under an invisible ±1 DN pattern; no longer resting, it
        # took a fix 12 px off, its window grew with that step, and it was taken
        # 170 px away on another orange thing.
        if len(self.history) >= 2 and self.radius is not None:
            (_, xa, ya), (_, xb, yb) = self.history[-2:]
            step = (xb - xa, yb - ya)
            short = bool(np.hypot(*step) < REST_STEP * self.radius)
            self.short_steps = [*self.short_steps[1 - REST_STEPS:], step] if short else []
            if len(self.short_steps) == REST_STEPS \
                    and not _one_way(self.short_steps, REST_STEP * self.radius):
                self.resting = True
            elif not short and self.long_step is not None \
                    and _aligned(self.long_step, step, MOVE_ALIGN):
                self.resting = False
            self.long_step = None if short else step

    def forget_motion(self) -> None:
        """The last fix is not trusted (two markers on one blob): sought afresh."""
        self.history, self.missed, self.surprise_px = [], 1, None

    def off_its_place(self, centre: Centre, pred: tuple[float, float] | None) -> bool:
        """Is ``centre`` too far from the prediction ``pred`` (px) for a marker that has
        been standing still to be it (unless it has been lost so long that it may
        have been moved meanwhile)? A marker at rest that starts to move is followed:
        its prediction moves with it."""
        return (self.resting and pred is not None and self.radius is not None
                and self.missed <= REST_MEMORY
                and float(np.hypot(centre.x - pred[0], centre.y - pred[1]))
                > REST_REACH * self.radius)

    def moved_off(self, centre: Centre, t: float) -> bool:
        """Has the resting marker moved off its place, ``centre`` (at ``t`` s) being
        refused by :meth:`off_its_place`? Yes where the fix refused before it (since the
        last fix taken) lies at least :data:`MOVE_STEP` radii back along the way from
        the place (within :data:`MOVE_ALIGN`): the motion is taken up from those two
        fixes (the refused one enters the history, and is given back to its frame:
        :attr:`taken_up`). A neighbour of the marker's colour found in its stead stays
        put, and is refused frame after frame."""
        before, self.stray = self.stray, (t, centre)
        if before is None or not self.history or self.radius is None:
            return False
        t0, x0, y0 = before[0], before[1].x, before[1].y
        _, xr, yr = self.history[-1]
        out = (x0 - xr, y0 - yr)  # from its place to the first refused fix
        on = (centre.x - x0, centre.y - y0)  # and on from there
        step = math.hypot(*on)
        if step < MOVE_STEP * self.radius or not _aligned(out, on, MOVE_ALIGN) \
                or math.hypot(*out) > MOVE_REACH * self.radius:
            return False
        self.resting, self.short_steps, self.stray, self.long_step = False, [], None, None
        self.history, self.missed, self.surprise_px = [(t0, x0, y0)], 0, None
        self.taken_up = before
        return True

    def set_off_prediction(self, t: float) -> tuple[float, float] | None:
        """Where a resting marker would be at ``t`` (s) had the fix last refused off its
        place (:meth:`moved_off`) been it setting off: on along the line from its place
        through that fix, at that pace (px). None without such a fix."""
        if self.stray is None or not self.resting or not self.history:
            return None
        (tr, xr, yr), (t0, c0) = self.history[-1], self.stray
        x0, y0 = c0.x, c0.y
        if t0 <= tr:
            return None
        k = (t - t0) / (t0 - tr)
        return x0 + k * (x0 - xr), y0 + k * (y0 - yr)

    def from_place(self, x: float, y: float) -> float:
        """How far (x, y) px lies from the marker's last fix (its place, at rest), px."""
        return math.hypot(x - self.history[-1][1], y - self.history[-1][2])

    def mark_way(self, t: float, at: Centre, pred: tuple[float, float] | None) -> None:
        """A blob of the resting marker at ``at`` (at ``t`` s) whose fit failed: where it
        lies off the marker's place (:meth:`off_its_place`) but within the
        :data:`MOVE_REACH` a set-off is taken up from, it marks the way a later fix may
        be taken up along (:meth:`moved_off`), as a refused fix would. The first frames
        of a set-off are blurred, and their fits fail (yupi's rover LED under an
        invisible pattern: lost for its whole turn without this). It is no fix itself
        (``at.ok`` is False, so :attr:`taken_up` is not written back); farther off it
        would only widen the search."""
        if self.off_its_place(at, pred) and \
                self.from_place(at.x, at.y) <= MOVE_REACH * self.radius:
            self.stray = (t, at)

    def stray_step(self) -> float:
        """How far the fix last refused off the marker's place lies from it, px."""
        if self.stray is None or not self.history:
            return 0.0
        return self.from_place(self.stray[1].x, self.stray[1].y)

    def motion_px(self) -> float:
        """How far the marker may be from its prediction for its motion, px: the last
        step, or less where the fixes have kept close to their predictions (a falling
        cup moves 29 px a frame, within a pixel of its parabola: a window of twice
        the step took a neighbouring cup of the same colour as it left the view)."""
        step = self.speed_px()
        return step if self.surprise_px is None else min(step, 2.0 * self.surprise_px + 1.0)

    def speed_px(self) -> float:
        """Displacement between the last two fixes, px."""
        if len(self.history) < 2:
            return 0.0
        (_, x0, y0), (_, x1, y1) = self.history[-2:]
        return float(np.hypot(x1 - x0, y1 - y0))


def _out_of_focus(soft: dict[str, float]) -> str:
    """``A, C look out of focus: edges blurred over …`` for printed discs whose fitted
    edges (px, by name) are :data:`OUT_OF_FOCUS_EDGE_PX` or wider."""
    return (f"{', '.join(soft)} look{'s' if len(soft) == 1 else ''} out of focus: edges "
            f"blurred over {', '.join(f'{e:.1f}' for e in soft.values())} px (1.0-1.5 in "
            "focus on H.264)")


def rig_focus_note(edges: dict[str, float]) -> str | None:
    """What ``inspect`` should say of the crank-slider's discs whose fitted edges
    (``edges``, px, by name) are :data:`OUT_OF_FOCUS_EDGE_PX` or wider, or None."""
    soft = {name: e for name, e in edges.items() if e >= OUT_OF_FOCUS_EDGE_PX}
    if not soft:
        return None
    return (f"{_out_of_focus(soft)}. Out of focus, θ may be off by 0.1-0.7° and a marker "
            "lost in up to a tenth of the frames (bench/README.md, stops 49-52): focus the "
            "camera on the markers before filming")


def nearer_notes(states: list[MarkerState]) -> list[str]:
    """What the user should hear of markers whose size was taken anew as they came nearer
    (:meth:`MarkerState.regrow`): one note for all of them, or none."""
    grew = [st for st in states if st.regrown and st.learned_radius and st.radius]
    if not grew:
        return []
    one = len(grew) == 1
    times = ("once" if one and grew[0].regrown == 1
             else ", ".join(str(st.regrown) for st in grew) + " times")
    return [f"marker{'' if one else 's'} {', '.join(st.spec.name for st in grew)} grew from "
            f"{', '.join(f'{st.learned_radius:.1f}' for st in grew)} to "
            f"{', '.join(f'{st.radius:.1f}' for st in grew)} px in radius (the rig or camera "
            f"came nearer?): {'its size was' if one else 'their sizes were'} taken anew "
            f"{times}. A scale in mm from one known "
            "length holds at one distance from the camera only: keep the camera and the rig "
            "where they are while filming"]


def focus_notes(states: list[MarkerState], found: dict[str, float]) -> list[str]:
    """What the user should hear of the crank-slider's printed discs if they look out of
    focus: found in half the frames or more (``found``: fraction of frames, by name) with
    their fitted edges blurred over :data:`OUT_OF_FOCUS_EDGE_PX` or more, or, never
    found, a blob of their colour refused as shaded."""
    flat = [st for st in states if st.spec.flat]
    # Found in half the frames or more: a patch of a disc's colour taken for it now and
    # then on a clip with no markers (a door on OpenCV's vtest.avi) is no disc to judge.
    soft = {st.spec.name: st.edge_px for st in flat if found.get(st.spec.name, 0.0) >= 0.5
            and st.edge_px is not None and st.edge_px >= OUT_OF_FOCUS_EDGE_PX}
    notes = []
    if soft:
        notes.append(
            f"marker{'s' if len(soft) > 1 else ''} {_out_of_focus(soft)}. On a second "
            "renderer's SMA bed blurred so, θ was off by 0.1-0.7° against a σ of "
            "0.1-0.2°, and A, with the wire across it, lost in up to a tenth of the frames "
            "(bench/README.md, stops 49-52); focus the camera on the markers")
    for st in flat:
        if found.get(st.spec.name, 0.0) == 0 and st.refused_shaded:
            notes.append(
                f"marker {st.spec.name}: a blob of its colour was refused in "
                f"{st.refused_shaded} frames, its coverage uneven across its middle (a "
                "shaded ball's, or a disc out of focus with the wire across it)")
    return notes
