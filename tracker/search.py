"""Where to look for a marker that is not where it was predicted: the search ladder.

First a window around the prediction (:func:`window`, widening while the
marker stays lost), then the whole frame, but only on some frames
(:func:`search_whole_frame`): a full-frame search costs as much as decoding
the frame. Where the blob found is not the marker, the next ones of its colour
and size within reach (:func:`other_blobs`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .lighting import light_moved
from .marker_state import MarkerState
from .markers import (
    AREA_GATE,
    Blob,
    MarkerSpec,
    acquire,
    balanced_hsv,
    find_blobs,
    place_reach,
    white_balance_gains,
)
from .refine import patch_around
from .video import Frame

#: A marker that is not where it was looked for is sought in the whole frame only
#: every this many frames (and in each of the first ones of a video): a full-frame
#: search costs as much as decoding the frame, so a marker that has left the view,
#: or was never there, would otherwise slow every frame down.
FULL_SEARCH_EVERY = 8
#: ...and ever more rarely the longer it stays lost: every 8 frames over its first
#: 64 frames missed, every 32 over the next 64, then every 128. On a real clip a
#: full-frame search of a busy 768×576 frame took 24 ms against 2 ms to decode it
#: (three saturation floors, thousands of blobs), so three markers that are not in
#: a clip made tracking 5× slower than decoding at one search in 8 frames.
BACKOFF_FRAMES = 64


def full_search_interval(missed: int) -> int:
    """Frames between whole-frame searches for a marker missed ``missed`` frames."""
    return FULL_SEARCH_EVERY * 4 ** min(missed // BACKOFF_FRAMES, 2)


#: A marker missed for more frames than this is looked for in its plain window again.
WIDEN_MISSED = 2


def window(state: MarkerState) -> float:
    """Half-width (px) of the window searched around the prediction: three radii and
    twice how far the motion may take it from the prediction
    (:meth:`.MarkerState.motion_px`), doubled for each of the first two frames the
    marker has been missed (wider than that costs as much as the whole-frame
    search). Missed for longer, it is hidden or gone rather than faster than
    predicted: the plain window around where it was is searched (a hidden marker
    comes back there), and the whole frame at its own lower rate. On a webcam clip
    the 4× window of a lost marker (260 px square for a 9 px one) on every frame
    cost more than decoding."""
    r = state.radius or 0.0
    wider = 2.0 ** state.missed if state.missed <= WIDEN_MISSED else 1.0
    return (3.0 * r + 2.0 * state.motion_px() + 4.0) * wider


#: A marker missed for this many frames (a second at 30 fps) has its window
#: searched only every :data:`WINDOW_EVERY` frames: it has left, or is hidden, and
#: on a webcam clip the windows of two such markers cost as much as decoding the
#: frames. A marker hidden for less (a hand passing) is looked for in every frame.
WINDOW_BACKOFF_MISSED = 30
WINDOW_EVERY = 4


def search_window(state: MarkerState) -> bool:
    """Is this frame one where the window around the marker's prediction is searched?
    Every frame until it has been missed :data:`WINDOW_BACKOFF_MISSED` times, then
    every :data:`WINDOW_EVERY` frames (so a marker back in view is found within
    that many frames)."""
    return state.missed < WINDOW_BACKOFF_MISSED or state.missed % WINDOW_EVERY == 0


def search_whole_frame(state: MarkerState, pred: tuple[float, float] | None) -> bool:
    """Is this frame one where the whole frame is searched for the marker?"""
    if pred is None or len(state.history) < 2:
        # Not yet seen, or seen once, so with no velocity to say where to look (a
        # thrown ball moves many radii a frame): each of the first frames.
        return (state.missed < FULL_SEARCH_EVERY
                or state.missed % full_search_interval(state.missed) == 0)
    return state.missed > 0 and state.missed % full_search_interval(state.missed) == 0


def balance_gains(frame: Frame, hsv_cache: dict) -> NDArray[np.float32]:
    """The run's white-balance gains, taken from the first frame that needs them, and
    again from one whose light (:attr:`.video.Frame.light`) has moved by more than
    :data:`.lighting.LIGHT_SURE` from the light they were taken in. Yupi's rover clip
    opens 2.4× darker and redder than it is from its third frame on (its camera's
    exposure and white balance settling); with the first frame's gains for the whole
    run, its red pivot read as magenta and was not found in frames 2-5."""
    taken = hsv_cache.get("gains_light")
    if hsv_cache.get("gains") is None or (taken is not None and light_moved(frame.light, taken)):
        hsv_cache["gains"] = white_balance_gains(frame.rgb)
        hsv_cache["gains_light"] = frame.light
    return hsv_cache["gains"]


def full_hsv(frame: Frame, hsv_cache: dict) -> NDArray[np.uint8]:
    """The whole frame's white-balanced HSV, made once per frame for all markers."""
    if "full" not in hsv_cache:
        hsv_cache["full"] = balanced_hsv(frame.rgb, balance_gains(frame, hsv_cache))
    return hsv_cache["full"]


def full_blobs(frame: Frame, spec: MarkerSpec, hsv_cache: dict) -> list[Blob]:
    """The blobs of ``spec``'s colour in the whole frame, found once per frame: a marker
    whose blob was not it looks at the others of its colour after its full-frame
    search has found them (on a webcam clip, 101 such second looks cost 0.6 of 2.3 s)."""
    found = hsv_cache.setdefault("blobs", {})
    if spec not in found:
        found[spec] = find_blobs(full_hsv(frame, hsv_cache), spec)
    return found[spec]


#: Half-width (px) of the window searched on every frame around where the user said
#: a marker not yet found is (``--marker NAME=COLOUR@X,Y``). A blob farther than
#: :func:`.markers.place_reach` from that place is not taken for it anyway.
PLACED_WINDOW_PX = 64


def placed_blob(frame: Frame, state: MarkerState, hsv_cache: dict) -> tuple[Blob | None, str]:
    """The blob of a marker not yet found in the window around where the user said it
    is. Searched on every frame (a window costs little), where the whole frame is
    searched only at the back-off rate: on Tracker's 30 fps ball toss the ball leaves
    the hand at the place given in frame 10, between two whole-frame searches, and
    was then never found."""
    near = state.spec.near_px
    patch, x0, y0 = patch_around(frame, near[0], near[1], PLACED_WINDOW_PX)
    hsv = balanced_hsv(patch, balance_gains(frame, hsv_cache))
    blob, status, _ = acquire(hsv, state.spec, state.area, near, state.area_gates,
                              lambda spec: find_blobs(hsv, spec, x0, y0))
    if blob is not None and _off_its_place(state, blob, near):
        return None, "not_found"
    return blob, status


def _off_its_place(state: MarkerState, blob: Blob, near: tuple[float, float]) -> bool:
    """Does ``blob`` lie beyond :func:`.markers.place_reach` of the place ``near`` the
    user gave? If so the marker remembers it as refused (for its never-found note)."""
    off = float(np.hypot(blob.x - near[0], blob.y - near[1]))
    if off <= place_reach(blob.radius):
        return False
    state.refuse_far(blob.x, blob.y, off)
    return True


#: How far (radii) from its one fix a marker seen once may be found by a whole-frame
#: search: as far as :func:`other_blobs` looks for it then.
SEEN_ONCE_REACH = 20.0


def full_frame_blob(frame: Frame, state: MarkerState, t: float, hsv_cache: dict,
                     pred: tuple[float, float] | None) -> tuple[Blob | None, str]:
    """The marker's blob in the whole frame, white-balanced (lost, or never seen)."""
    near = pred if pred is not None else state.spec.near_px
    blob, status, rivals = acquire(full_hsv(frame, hsv_cache), state.spec, state.area, near,
                                   state.area_gates,
                                   lambda spec: full_blobs(frame, spec, hsv_cache))
    if blob is not None and pred is None and near is not None \
            and _off_its_place(state, blob, near):
        return None, "not_found"  # not yet where the user said it is
    if blob is not None and pred is not None and len(state.history) < 2 and np.hypot(
            blob.x - pred[0], blob.y - pred[1]) > SEEN_ONCE_REACH * (state.radius or blob.radius):
        # Seen once, the marker may be anywhere near (a thrown ball moves 15 radii a
        # frame), but not anywhere: on vtest.avi with an invisible ±1 DN pattern, a
        # cone seen once, whose own blob then failed its size gate, was taken 150 px
        # off (37 radii) on another orange thing, and followed there in 781 frames.
        return None, "not_found"
    # Where the user said the marker is, the blob there was taken: the others are not
    # a guess to warn of.
    if blob is not None and rivals and pred is None and near is None and not state.notes:
        where = "; ".join(f"({r.x:.0f}, {r.y:.0f})" for r in rivals[:3])
        state.notes.append(
            f"marker {state.spec.name}: {1 + len(rivals)} blobs of its colour and size at "
            f"t = {t:.3f} s; following the one at ({blob.x:.0f}, {blob.y:.0f}), not "
            f"{where}; if that is the wrong one, cover or recolour the others, or say "
            f"where it is: --marker {state.spec.name}=COLOUR@X,Y")
    return blob, status


def other_blobs(frame: Frame, state: MarkerState, hsv_cache: dict,
                 pred: tuple[float, float], tried: Blob, wide: bool, most: int = 3
                 ) -> list[Blob]:
    """Blobs of the marker's colour, shape and size, nearest to the prediction first,
    other than the one ``tried``, within reach: the search window (:func:`window`)
    or, ``wide``, 20 radii plus three times the last step (a thrown ball moves 15
    radii a frame). A blob farther off is another object of the same colour, not
    the marker."""
    reach = (SEEN_ONCE_REACH * (state.radius or tried.radius) + 3.0 * state.speed_px() if wide
             else np.sqrt(2.0) * window(state))
    good = [b for b in full_blobs(frame, state.spec, hsv_cache)
            if state.spec.takes(b)
            and (not state.area
                 or AREA_GATE[0] * state.area <= b.area <= AREA_GATE[1] * state.area)
            and np.hypot(b.x - tried.x, b.y - tried.y) > 1.0
            and np.hypot(b.x - pred[0], b.y - pred[1]) <= reach]
    good.sort(key=lambda b: (b.x - pred[0]) ** 2 + (b.y - pred[1]) ** 2)
    return good[:most]
