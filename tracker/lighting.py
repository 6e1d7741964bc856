"""The light of the frames: how much it changes from frame to frame, and when a
marker is fitted again in this frame's light.

A camera's exposure or white balance stepping, a lamp on the mains flickering into
a short exposure, or a light switched on scales every colour channel in the frame.
A marker is fitted in the colour it was learned in; where the frame's light
(:meth:`.video.Frame.light`, per channel) has moved from the light that colour was
seen in by more than :data:`LIGHT_STEP`, it is fitted again with its colour scaled
channel by channel by the change (:meth:`.marker_state.MarkerState.try_light`). A
run says when the light moved so between frames (:func:`lighting_notes`).

>>> flicker = [np.full(3, v) for v in [130.0, 85.0, 85.0] * 20]  # 100 Hz filmed at 30 fps
>>> print(lighting_notes(flicker)[0][:96])
the light of the frames changed by more than 10 % from one frame to the next 39 times in 60 fram
>>> lighting_notes([np.array([120.0, 100.0, 90.0])] * 50)
[]
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise

import numpy as np
from numpy.typing import NDArray

#: A frame whose light differs from the light a marker's colour was seen in by more
#: than this fraction has the marker fitted a second time, with its colour scaled to
#: match (:meth:`.marker_state.MarkerState.try_light`). Drawn discs lit 1.43 times
#: brighter from one frame to the next were called partly covered from then on, and
#: 2 times dimmer, never found again; a camera's exposure stepping that much over five
#: frames lost them too, and a light flickering ±25 % lost every other frame. Within
#: this, the gain's range and the colour's own drift take it, as before.
LIGHT_STEP = 0.1
#: Where the fits in both colours pass, the one in this frame's light is taken only if
#: the light changed by more than this (log of its factor, 1.35×) and its gain is
#: nearer the usual: yupi's LED, a light of its own, showed gains of 0.97–1.48 on the
#: move while the room darkened by 13–17 %, and taken in the room's light its colour
#: went wrong (3 frames lost). A lamp flickering ±30 % (bench/sma_bed_apart.py
#: --flicker 0.3) changes the light by 1.5× between frames.
LIGHT_SURE = 0.3
#: The light is compared only where both frames have at least this much (median luma,
#: DN): the median of a dark frame (pucks on a black table) is its noise, not its light.
LIGHT_FLOOR_DN = 20.0
#: A run says the light changed where it stepped by more than :data:`LIGHT_STEP` between
#: neighbouring frames in at least this share of them, or by more than
#: :data:`LIGHT_SURE` once.
FLICKER_SHARE = 0.05


#: BT.601's weights of R, G and B in the luma.
LUMA_WEIGHTS = np.array([0.299, 0.587, 0.114])


def light_ratio(now: NDArray, then: NDArray) -> NDArray[np.float64] | None:
    """Per channel (R, G, B), ``now`` over ``then`` (frame lights, DN). A channel with
    less than :data:`LIGHT_FLOOR_DN` in either takes the luma's ratio; None where the
    luma has less than that too."""
    now, then = np.asarray(now, np.float64), np.asarray(then, np.float64)
    luma_now, luma_then = float(LUMA_WEIGHTS @ now), float(LUMA_WEIGHTS @ then)
    if min(luma_now, luma_then) < LIGHT_FLOOR_DN:
        return None
    lit = np.minimum(now, then) >= LIGHT_FLOOR_DN
    return np.where(lit, now / np.maximum(then, 1e-9), luma_now / luma_then)


def light_change(ratio: NDArray) -> float:
    """How far a per-channel ratio of lights is from none: the largest |log| of its
    channels."""
    return float(np.max(np.abs(np.log(ratio))))


def light_moved(now: NDArray, then: NDArray) -> bool:
    """Has the light moved by more than :data:`LIGHT_SURE` from ``then`` to ``now``
    (frame lights, DN)? Not where either is too dark to tell (:func:`light_ratio`)."""
    ratio = light_ratio(now, then)
    return ratio is not None and light_change(ratio) > LIGHT_SURE


def settling_note(light: NDArray, later: NDArray, t_s: float, later_s: float) -> str | None:
    """What ``inspect`` should say where a frame's light (at ``t_s``) and a frame's a
    little later (at ``later_s``; R, G, B in DN, :meth:`.video.Frame.light`) differ by
    more than :data:`LIGHT_SURE`: a camera's exposure still settling at the start of a
    clip (yupi's rover clip: 2.3-2.5× darker at 0 s than 0.2 s on), which dims every
    marker below the value floors, so that some are not listed. None where they agree.

    >>> settling_note(np.array([52.0, 42.0, 38.0]), np.array([118.0, 103.0, 97.0]), 0.0, 0.2)[:60]
    'the light at 0.000 s is 0.42× what it is at 0.200 s (a camer'
    >>> settling_note(np.array([120.0, 100.0, 90.0]), np.array([118.0, 101.0, 92.0]), 0.0, 0.2)
    """
    if not light_moved(light, later):
        return None
    overall = float(LUMA_WEIGHTS @ light_ratio(light, later))
    return (f"the light at {t_s:.3f} s is {overall:.2f}× what it is at {later_s:.3f} s (a "
            "camera's exposure settling, or a lamp): markers it dims or brightens may be "
            "missing from this list; inspect a later frame too (--at)")


def lighting_notes(lights: Sequence[NDArray]) -> list[str]:
    """What a user should hear of the light of a run's frames (R, G, B in DN, one per
    frame, in order): where it stepped between neighbouring frames, how often and how
    far, what the tracker did, and how to avoid it. Empty where it held steady."""
    steps = [light_change(r) for a, b in pairwise(lights)
             if (r := light_ratio(b, a)) is not None]
    if not steps:
        return []
    change = np.asarray(steps)
    stepped = int(np.sum(change > np.log1p(LIGHT_STEP)))
    largest = float(np.exp(change.max()))
    if stepped < max(1, FLICKER_SHARE * len(steps)) and change.max() <= LIGHT_SURE:
        return []
    return [f"the light of the frames changed by more than {100 * LIGHT_STEP:.0f} % from one "
            f"frame to the next {stepped} times in {len(lights)} frames (at most "
            f"{largest:.2f}× in a colour): a lamp on the mains flickering into a short "
            "exposure, or the camera's exposure, white balance or a light changing; each "
            "marker was fitted again in its frame's light. An exposure of 1/50 s or 1/60 s "
            "(whole flicker periods), a lamp on DC or a fixed exposure and white balance "
            "avoids it"]
