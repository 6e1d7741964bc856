"""A survey of one frame: every blob that could be a marker, and how to ask for it.

Before a first track on their own footage a user needs to know what the
tracker can see: which compact blobs of one colour, or of white or black,
the frame holds, where, how big, and what ``--marker`` would follow each.
:func:`survey` finds them with the tracker's own masks (so what it lists is
what ``track`` will find) over a ring of hues and the two luminance tones.
:func:`rig_edges` fits the crank-slider's three discs, to tell whether they are in focus.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .markers import (
    COLOUR_HUES_DEG,
    DEFAULT_MARKERS,
    MarkerSpec,
    balanced_hsv,
    find_blobs,
    white_balance_gains,
)
from .refine import refine
from .video import Frame

#: How many times :func:`rig_edges` fits a disc again from its last fit.
RIG_REFITS = 3

#: Hues searched, 30° apart, each ±20°: every hue falls in at least one window.
SURVEY_HUES_DEG = tuple(range(0, 360, 30))

#: A blob within this distance (px) of one of its colour and size (within 1.5×) a
#: little later has not moved: compression moves a still blob's thresholded outline,
#: and so its centroid, by up to a pixel (the metre stick's tenths on BallToss).
STILL_PX = 2.0

#: The later frame compared to tell what moves, this many seconds on (s): long enough
#: for a marker people film to move a pixel, short enough that it is still in view.
LATER_S = 0.2



def frame_and_later(frames: Iterable[Frame], wanted: Callable[[Frame], bool]
                    ) -> tuple[Frame | None, Frame | None]:
    """The first of ``frames`` that is ``wanted`` (else the last one), and the first
    :data:`LATER_S` or more after it (None where the clip ends before): the pair
    :func:`survey` compares to tell what moves. Stops decoding there."""
    frame = None
    for f in frames:
        if frame is None or not wanted(frame):
            frame = f
        elif f.t_s >= frame.t_s + LATER_S:
            return frame, f
    return frame, None


def _hue_gap(a_deg: float, b_deg: float) -> float:
    """How far apart two hues are round the colour circle, deg (0–180)."""
    return abs((a_deg - b_deg + 180.0) % 360.0 - 180.0)


def _colour_name(hue_deg: float) -> str:
    """The named colour nearest a hue (for the label only)."""
    return min(COLOUR_HUES_DEG, key=lambda k: _hue_gap(hue_deg, COLOUR_HUES_DEG[k]))


def _blobs_table(hsv: NDArray[np.uint8], min_area_px: int) -> pd.DataFrame:
    """Every blob of the survey's hue windows and tones in one HSV frame (unranked)."""
    rows = []
    specs = [MarkerSpec("", float(h), 20.0, min_area_px=min_area_px) for h in SURVEY_HUES_DEG]
    specs += [MarkerSpec.from_colour("", tone) for tone in ("white", "black")]
    for spec in specs:
        for b in find_blobs(hsv, spec):
            if b.area < min_area_px:
                continue
            if spec.tone:
                colour, name = spec.tone, spec.tone
            else:
                colour, name = f"{spec.hue_deg:.0f}", _colour_name(spec.hue_deg)
            rows.append({"x_px": b.x, "y_px": b.y, "radius_px": b.radius, "area_px": b.area,
                         "fill": b.fill, "aspect": b.aspect, "colour": colour, "name": name,
                         "disc_like": b.disc_like(), "cored": b.cored,
                         "strip": b.elongated()})
    return pd.DataFrame(rows, columns=["x_px", "y_px", "radius_px", "area_px", "fill",
                                       "aspect", "colour", "name", "disc_like", "cored",
                                       "strip"])


def _moved(table: pd.DataFrame, later: pd.DataFrame) -> NDArray[np.bool_]:
    """For each blob of ``table``, whether no blob of its colour and size lies within
    :data:`STILL_PX` (or a tenth of its radius) of it in ``later``."""
    moved = np.ones(len(table), dtype=bool)
    for colour, rows in table.groupby("colour"):
        there = later[later["colour"] == colour]
        if there.empty:
            continue
        gap = np.hypot(rows["x_px"].to_numpy()[:, None] - there["x_px"].to_numpy()[None, :],
                       rows["y_px"].to_numpy()[:, None] - there["y_px"].to_numpy()[None, :])
        ratio = rows["radius_px"].to_numpy()[:, None] / there["radius_px"].to_numpy()[None, :]
        same = (gap <= np.maximum(STILL_PX, 0.1 * rows["radius_px"].to_numpy())[:, None]) \
            & (np.abs(np.log(ratio)) <= np.log(1.5))
        moved[table.index.get_indexer(rows.index)] = ~same.any(axis=1)
    return moved


#: A disc-like blob whose box is longer one way than this is called an oval, not a
#: disc, by :func:`shape_word`: a disc seen at a slant, a streak, or two blobs of one
#: colour touching (two touching balls of yupi's demo.avi, 2:1, were listed as a disc of
#: 28 px).
ROUND_BOX = 1.3


def shape_word(aspect: float, disc_like: bool, strip: bool, cored: bool) -> str:
    """What a blob's outline is, for people reading ``inspect``'s table: ``disc``,
    ``oval L:1`` (disc-like but longer one way than :data:`ROUND_BOX`), ``strip L:1``
    (a strip of tape, a streak, a filled rectangle), ``disc inside a blob`` (the largest
    disc inside a blob of another shape that it fills most of: a square sticker, a ball
    on a stalk of its colour; :func:`.markers.find_blobs` gives such a blob as that disc)
    or ``irregular`` (none of these: a cross, a ragged patch, a gap between things).
    ``L`` is the box's longer side over its shorter, ``aspect`` the box's width over
    its height; ``disc_like``, ``strip`` and ``cored`` as :class:`.markers.Blob` has
    them (:meth:`~.markers.Blob.disc_like`, :meth:`~.markers.Blob.elongated`,
    :attr:`~.markers.Blob.cored`)."""
    longer = max(aspect, 1.0 / aspect) if aspect > 0 else float("inf")
    if cored:
        return "disc inside a blob"
    if strip:
        return f"strip {longer:.1f}:1"
    if disc_like:
        return "disc" if longer <= ROUND_BOX else f"oval {longer:.1f}:1"
    return "irregular"


#: A blob on a round blob of one colour at least this many times its radius is a part
#: of it (a highlight, a dark spot or the cap of a ball), and a round blob up to this
#: fraction of the frame's smaller side can hold such parts (wider ones are the scene).
PART_SIZE = 2.0
PART_OF_PX = 0.1
#: A shaded ball's mask leaves out its darker rim, so its outline reaches past the
#: radius of its area: the pendulum clip's red bob is 26 px by its area, and the dark
#: cap on top of it 28–30 px from its centre.
PART_REACH = 1.25


def _holders(table: pd.DataFrame, widest_px: float) -> NDArray[np.int64]:
    """For each blob of ``table``, the index label of the blob it is a part of, or −1:
    the largest disc-like colour blob at least :data:`PART_SIZE` times its radius and
    at most ``widest_px`` in radius that it lies on (within its own radius and
    :data:`PART_REACH` times the other's). White and black blobs hold no parts: a dark
    body or a light wall is what markers are stuck on (yupi's rover: its red pivot on
    the rover's dark body)."""
    tone = table["colour"].isin(["white", "black"])
    holder = table[table["disc_like"] & ~tone & (table["radius_px"] <= widest_px)]
    out = np.full(len(table), -1, dtype=np.int64)
    if holder.empty:
        return out
    gap = np.hypot(table["x_px"].to_numpy()[:, None] - holder["x_px"].to_numpy()[None, :],
                   table["y_px"].to_numpy()[:, None] - holder["y_px"].to_numpy()[None, :])
    big, small = holder["radius_px"].to_numpy()[None, :], table["radius_px"].to_numpy()[:, None]
    on = (gap <= PART_REACH * big + small) & (big >= PART_SIZE * small)
    largest = np.argmax(np.where(on, big, -1.0), axis=1)
    found = on.any(axis=1)
    out[found] = holder.index.to_numpy()[largest[found]]
    return out


def survey(rgb: NDArray[np.uint8], min_area_px: int = 12, most: int = 12,
           later: NDArray[np.uint8] | None = None) -> pd.DataFrame:
    """Candidate markers in an RGB frame, the most marker-like first.

    Returns a table with ``x_px``, ``y_px`` (blob centroid), ``radius_px`` (of a
    disc of the same area), ``fill`` (area over its box; π/4 for a disc),
    ``aspect``, ``strip`` (a strip or a square, centred by its coverage's centroid
    when tracked), ``shape`` (:func:`shape_word`: disc, oval, strip, a disc inside a
    blob, or irregular), ``colour`` (``white``, ``black`` or the hue in degrees,
    rounded), ``name`` (the nearest colour name, for people), ``moves`` (with
    ``later``, a frame of the same clip a little later: the blob is not there
    then, at its place and size; else False), ``on`` (the ``m…`` of the larger
    round colour blob this one is a part of, such as a highlight or the cap of a
    ball; else "") and ``marker``: the ``--marker`` value that follows it, e.g.
    ``m1=120@312,99``. Blobs found in two overlapping hue windows are listed once;
    strips and streaks are kept (the tracker follows them too) but a round blob of
    a marker's size ranks higher, and among those one that moves: what people film
    a marker for (a round blob that moves counts as one of a marker's size, however
    large: a bob filmed close). Parts of another blob come last.
    """
    gains = white_balance_gains(rgb)
    table = _blobs_table(balanced_hsv(rgb, gains), min_area_px)
    if table.empty:
        return table.drop(columns="cored").assign(moves=pd.Series(dtype=bool),
                                                  on=pd.Series(dtype=str),
                                                  shape=pd.Series(dtype=str),
                                                  marker=pd.Series(dtype=str))
    table["moves"] = (False if later is None else
                      _moved(table, _blobs_table(balanced_hsv(later, gains), min_area_px)))
    # Most marker-like first: disc-like and not a disc cut from a blob of another shape
    # (grass and texture give many such cores, and their fill and aspect are a disc's
    # by construction); of a marker's size: not larger than a hand or a sign (25 px in
    # radius, or 3 % of the frame's height at 1080p), nor a speck of noise (2.5 px, or
    # 0.6 % of the height), which on busy real frames outnumber the markers and are
    # round by digitisation; moving; then the roundest. On Tracker's examples this
    # put the ball a Tracker user clicked first in three frames of its flight (was
    # 4th–7th), and the diabolo in flight 3rd and 1st (was 39th and 34th); see
    # bench/README.md. One row per place: the same blob seen through two neighbouring
    # hue windows is listed once. A plain disc that moves is not too big, however large:
    # a pendulum's bob filmed close (bartekpacia/pendulum's capsule, 50 px in radius at
    # 1280×720) was listed 5th, after the beads inside it, and 15th at 1920×1080 (now
    # 1st and 6th); Tracker's jmoljana atom went from 24th to 28th (past the 12 printed
    # either way).
    table["roundness"] = (np.abs(table["fill"] - np.pi / 4)
                          + np.abs(np.log(table["aspect"].clip(lower=1e-3))))
    table["plain_disc"] = table["disc_like"] & ~table["cored"]
    table["too_big"] = ((table["radius_px"] > max(25.0, 0.03 * min(rgb.shape[:2])))
                        & ~(table["moves"] & table["plain_disc"]))
    table["speck"] = table["radius_px"] < max(2.5, 0.006 * min(rgb.shape[:2]))
    table["holder"] = _holders(table, PART_OF_PX * min(rgb.shape[:2]))
    table["part"] = table["holder"] >= 0
    table = table.sort_values(["part", "plain_disc", "too_big", "speck", "moves", "roundness"],
                              ascending=[True, False, True, True, False, True])
    kept: list[int] = []
    for i, r in table.iterrows():
        if all(np.hypot(r.x_px - table.at[j, "x_px"], r.y_px - table.at[j, "y_px"])
               > max(r.radius_px, 2.0) for j in kept):
            kept.append(i)
    table = table.loc[kept].head(most)
    table["shape"] = [shape_word(r.aspect, r.disc_like, r.strip, r.cored)
                      for r in table.itertuples()]
    table = table.drop(columns=["roundness", "too_big", "plain_disc", "speck", "cored", "part"])
    label = {i: f"m{k + 1}" for k, i in enumerate(table.index)}
    # A part whose holder fell out of the list (a duplicate place) is still a part.
    table["on"] = [label.get(h, "a larger blob") if h >= 0 else "" for h in table["holder"]]
    table = table.drop(columns="holder").reset_index(drop=True)
    table["marker"] = [f"m{k + 1}={r.colour}@{r.x_px:.0f},{r.y_px:.0f}"
                       for k, r in table.iterrows()]
    return table


def _rig_rows(table: pd.DataFrame) -> dict[str, pd.Series] | None:
    """The crank-slider's markers among a survey's candidates (:func:`survey`): for
    each of the default A (green), B (red) and C (blue), the first plain disc whose
    hue lies in that marker's window, all three of a size (radii within 2× of each
    other); their rows by marker name, or None when any of the three is missing."""
    found: dict[str, pd.Series] = {}
    for spec in DEFAULT_MARKERS:
        for _, r in table.iterrows():
            if r.strip or not r.disc_like or r.colour in ("white", "black") or any(
                    np.hypot(r.x_px - o.x_px, r.y_px - o.y_px) < 1.0 for o in found.values()):
                continue
            if _hue_gap(float(r.colour), spec.hue_deg) <= spec.hue_tol_deg:
                found[spec.name] = r
                break
    if len(found) < len(DEFAULT_MARKERS):
        return None
    radii = [r.radius_px for r in found.values()]
    if max(radii) > 2.0 * min(radii):
        return None
    return found


def crank_slider(table: pd.DataFrame) -> dict[str, str] | None:
    """``--marker`` values naming the crank-slider's discs among a survey's candidates
    A, B and C (:func:`_rig_rows`), by marker name, or None when any of the three is
    missing. Named so, they are tracked as the printed discs the defaults are, with the
    rig's wire taken into account, and the kinematics know which is which; named m1,
    m2, m3 they are neither."""
    found = _rig_rows(table)
    if found is None:
        return None
    return {name: f"{name}={r.colour}@{r.x_px:.0f},{r.y_px:.0f}" for name, r in found.items()}


def rig_edges(image: Frame | NDArray[np.uint8], table: pd.DataFrame) -> dict[str, float]:
    """The edge width (px, the disc model's blur) of each of the crank-slider's discs
    found in a survey's ``table`` (:func:`_rig_rows`), by name, fitted as the tracker
    fits them (NaN where the fit fails; empty without all three): 2 px or more is out
    of focus (:data:`.marker_state.OUT_OF_FOCUS_EDGE_PX`)."""
    edges = {}
    for name, row in (_rig_rows(table) or {}).items():
        centre, marker = refine(image, (row.x_px, row.y_px), row.radius_px, wire=True)
        # A first fit from scratch may stop short of a blurred edge (a drawn disc blurred
        # by 3 px: 0.9 px, then 3.1 fitted again from it), as the tracker's next frames do.
        for _ in range(RIG_REFITS):
            if not centre.ok or centre.params is None:
                break
            centre, _ = refine(image, (centre.x, centre.y), centre.radius, marker,
                               init=centre.params, wire=True)
        edges[name] = (float(centre.params[3]) if centre.ok and centre.params is not None
                       else float("nan"))
    return edges
