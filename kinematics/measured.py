"""Kinematics measured from tracks in the mechanism plane.

θ is the internal angle at A between A→C and A→B, computed per frame from
the three tracked points (so a pivot that moves does not bias it) and
unwrapped (tracked without C, ``--marker C=none``: A→B's angle from the plane's
x axis, :func:`arm_angle`); ω, α, v_B and L3' come from :mod:`.differentiate` on the real
frame times, with non-oscillatory windows (no smearing across the instants
a drive starts or stops) whose length is chosen from the data by
leave-one-out cross-validation on θ.

Every column carries a 1-σ propagated from the per-point ``_sigma_mm``, to
first order, and, for lengths and speeds, from the calibration's scale.
Positions (θ, L3) keep that σ — much of a tracker's error on compressed video
is the same in every frame (a bias) and belongs there — widened where the
rigid links |AB| and |AC| wander more than it allows (:func:`link_excess`):
a moving marker's error on compressed video changes slowly and no single
frame's fit sees it, but the links do.
Rates (ω, α, v_B, L3') see only the part that changes from frame to frame,
so their propagated σ is *calibrated*: the leave-one-out residuals of θ show
how large that part really is, and the rate σ are scaled by the ratio,
taken over about a second around each frame (its median over the run is
reported as ``sigma_scale``). The differentiator's own bias — a polynomial
fitted to a curve — is estimated as the difference from the next longer
window and added in quadrature.

Rigid links: |AB| (``L2_mm``) and |AC| (``L1_mm``) are reported per frame;
``rigid_ok`` is false where either leaves its median by more than 5σ (a
tracking glitch, or a camera that is not square to the plane).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import CranktrackError
from ..tracker.scatter import found_xy, repeated_frames
from .differentiate import Derivatives, choose_window, local_polynomial
from .table import kinematics_table


def _xy(tracks: pd.DataFrame, m: str) -> np.ndarray:
    return tracks[[f"{m}_x_mm", f"{m}_y_mm"]].to_numpy(float)


def window_samples(t_s: np.ndarray, window_s: float, order: int) -> int:
    """An odd window length in samples covering about ``window_s`` seconds."""
    dt = np.diff(np.asarray(t_s, float))
    dt = dt[dt > 0]
    step = float(np.median(dt)) if dt.size else 1.0
    n = round(window_s / step)
    n = max(n, order + 3)
    return n if n % 2 else n + 1


def _unwrapped(theta: np.ndarray, never: str) -> np.ndarray:
    """Angles (rad, NaN where not measured) unwrapped over the frames that have one;
    where none has, the markers ``never`` found together say so."""
    ok = np.isfinite(theta)
    if not ok.any():
        raise CranktrackError(f"markers {never} found in the same frame, so the crank angle "
                              "cannot be measured")
    theta[ok] = np.unwrap(theta[ok])
    return theta


def crank_angle(tracks: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """θ (rad, unwrapped, positive on the assembly the run starts in) and its 1-σ.

    Frames where any of A, B, C is missing are NaN. Tracks without C (``--marker
    C=none``) give the angle of A→B from the plane's +x axis toward +y instead
    (:func:`arm_angle`).
    """
    if "C_x_mm" not in tracks:
        return arm_angle(tracks)
    A, B, C = _xy(tracks, "A"), _xy(tracks, "B"), _xy(tracks, "C")
    ab, ac = B - A, C - A
    cross = ac[:, 0] * ab[:, 1] - ac[:, 1] * ab[:, 0]
    dot = (ac * ab).sum(axis=1)
    theta = _unwrapped(np.arctan2(cross, dot), "A, B and C are never all")
    ok = np.isfinite(theta)
    if np.median(theta[ok]) < 0:
        theta = -theta  # the mirror assembly: report the internal angle as positive
    # Gradients of θ with respect to B and C are perpendicular to AB and AC,
    # of size 1/|AB| and 1/|AC|; A's gradient is minus their sum.
    perp = np.array([[0.0, -1.0], [1.0, 0.0]])
    gB = ab @ perp.T / (ab**2).sum(axis=1, keepdims=True)
    gC = -(ac @ perp.T) / (ac**2).sum(axis=1, keepdims=True)
    gA = -(gB + gC)
    s = {m: tracks[f"{m}_sigma_mm"].to_numpy(float) for m in "ABC"}
    var = sum((g**2).sum(axis=1) * s[m] ** 2 for g, m in ((gA, "A"), (gB, "B"), (gC, "C")))
    return theta, np.sqrt(var)


def arm_angle(tracks: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """The angle (rad, unwrapped) of A→B from the plane's +x axis toward its +y axis,
    and its 1-σ: θ of a crank or arm tracked without C. NaN where A or B is missing."""
    A, B = _xy(tracks, "A"), _xy(tracks, "B")
    ab = B - A
    theta = _unwrapped(np.arctan2(ab[:, 1], ab[:, 0]), "A and B are never")
    # Moving B (or A the other way) across A→B turns it by 1/|AB| per unit.
    s = np.hypot(tracks["A_sigma_mm"].to_numpy(float), tracks["B_sigma_mm"].to_numpy(float))
    return theta, s / np.hypot(ab[:, 0], ab[:, 1])


#: Samples in the running window of the noise scale: about a second at 30 fps.
SCALE_WINDOW = 31


def noise_scale(loo: np.ndarray, sigma: np.ndarray, fit_sigma: np.ndarray,
                 kink: np.ndarray) -> np.ndarray:
    """Ratio of the real frame-to-frame noise to the propagated σ, per sample,
    from leave-one-out residuals.

    A sample's leave-one-out residual has variance σᵢ² + (σ of the fit
    without it)²; the ratio is the root of the mean squared normalised
    residual over :data:`SCALE_WINDOW` samples around each one. Local, not
    over the whole run, because the noise is not stationary: a still marker
    on compressed video keeps its error from frame to frame (the codec copies
    the block), while a moving one crosses the pixel grid and draws a new
    error every frame — several times more frame-to-frame noise in the same
    run (a median over the run, tried first, gave moving frames a σ a third
    to a quarter of their errors). Samples at a ``kink`` (where the differentiator shifted
    its window) whose residual is beyond 3σ of the local median level are
    left out: that residual is the kink, not noise.
    Samples with too few neighbours use the mean over the run.
    """
    var = sigma**2 + fit_sigma**2
    ok = np.isfinite(loo) & (var > 0)
    if ok.sum() < 10:
        return np.ones_like(loo, dtype=float)
    z2 = pd.Series(np.where(ok, loo**2 / np.where(ok, var, 1.0), np.nan))
    roll = {"window": SCALE_WINDOW, "center": True, "min_periods": SCALE_WINDOW // 2}
    level = z2.rolling(**roll).median() / 0.4549364
    z2[(z2 > 9.0 * level) & kink] = np.nan
    local = z2.rolling(**roll).mean()
    local = local.fillna(float(np.nanmean(z2))).to_numpy()
    return np.sqrt(local)


def rates(t: np.ndarray, y: np.ndarray, s: np.ndarray, window: int, order: int,
          scale: np.ndarray | float, d: Derivatives | None = None,
          richardson: bool = False) -> Derivatives:
    """``y(t)``'s rates (:func:`.local_polynomial` over ``window`` samples) with σ =
    the propagated σ times its calibration ``scale`` (:func:`noise_scale`) ⊕ the window's
    bias ⊕ the window-selection spread near kinks. ``d``: the fit at ``window``, if
    already made.

    The bias is |this window's rate − the next longer one's| by default. With
    ``richardson`` it is the whole bias a window's length brings, from a window twice as
    long: a local polynomial's centred rates are off by a term growing as the window's
    half-length squared, so |d(w) − d(2w − 1)| is three times it. The next longer
    window's difference is only the growth of that bias over two samples, 4/w of it: on
    a body turning steadily (drawn tracks) its speed's σ so made held the truth in 17 %
    of frames.
    """
    d = d or local_polynomial(t, y, s, window, order, adaptive=True)
    longer, part = (2 * window - 1, 3.0) if richardson else (window + 2, 1.0)
    wider = local_polynomial(t, y, s, longer, order, adaptive=True)
    if richardson and not np.isfinite(wider.d1).any():
        # A run too short for the window twice as long: the next longer one's growth.
        wider, part = local_polynomial(t, y, s, window + 2, order, adaptive=True), 1.0
    bias1 = np.nan_to_num(np.abs(d.d1 - wider.d1)) / part
    bias2 = np.nan_to_num(np.abs(d.d2 - wider.d2)) / part
    s1 = np.sqrt((scale * d.d1_sigma) ** 2 + bias1**2 + np.nan_to_num(d.d1_select) ** 2)
    s2 = np.sqrt((scale * d.d2_sigma) ** 2 + bias2**2 + np.nan_to_num(d.d2_select) ** 2)
    return replace(d, d1_sigma=s1, d2_sigma=s2)


#: A link length this many of its σ from its run median is a glitch (``rigid_ok``).
LINK_JUMP_SIGMA = 5.0


@dataclass(frozen=True)
class _Link:
    length: np.ndarray  # mm, per frame
    deviation: np.ndarray  # from the run's median, mm
    sigma: np.ndarray  # from the two points' σ, mm
    jump: np.ndarray  # beyond LINK_JUMP_SIGMA σ: a glitch
    direction: np.ndarray  # of A → the other end, rad, unwrapped over the frames found


def _rigid_links(tracks: pd.DataFrame) -> dict[str, _Link]:
    """|AC| (``L1_mm``) and |AB| (``L2_mm``) per frame, with what the checks need."""
    A = _xy(tracks, "A")
    sA = tracks["A_sigma_mm"].to_numpy(float)
    out = {}
    for name, m in (("L1_mm", "C"), ("L2_mm", "B")):
        if f"{m}_x_mm" not in tracks:
            continue  # no C: no |AC|
        d = _xy(tracks, m) - A
        length = np.hypot(*d.T)
        sigma = np.hypot(sA, tracks[f"{m}_sigma_mm"].to_numpy(float))
        dev = length - np.nanmedian(length)
        direction = np.arctan2(d[:, 1], d[:, 0])
        seen = np.isfinite(direction)
        direction[seen] = np.unwrap(direction[seen])
        out[name] = _Link(length, dev, sigma,
                          np.abs(dev) > LINK_JUMP_SIGMA * np.maximum(sigma, 1e-9), direction)
    return out


#: A rigid link whose spread over the run is this many times what its points'
#: σ allow is reported (``std_over_sigma`` in the links summary).
LINK_WANDER = 2.0

#: A rigid link whose deviations change this little from frame to frame against
#: their spread wanders slowly (their Durbin–Watson statistic, ``durbin_watson`` in
#: the links summary: 2 for white noise). On the spool and SMA scenes at 640×360,
#: |AB|'s was 0.76–1.83 filmed square-on and 0.08–0.72 with the camera tilted 5–10°
#: (three seeds, two). |AC|'s went down to 0.26 square-on, here and on the second
#: renderer's bed (`bench/sma_bed_apart.py`, 0.27 and 0.31 with the spread 1.0–1.3
#: of the points' median σ): A and C stand, so their errors are slow, and a tilt
#: cannot bend a link that does not turn. So a slow link is reported only when it
#: turns by :data:`LINK_TURN_DEG` and its spread exceeds the points' median σ
#: (:func:`link_wanders`).
LINK_SLOW_DW = 0.4

#: How far a link must turn over the run (the 5th to the 95th percentile of its
#: direction, degrees) for a slow change of its length to point at the camera: a
#: tilt or a lens changes a length as its direction or place in the image changes.
LINK_TURN_DEG = 10.0


def link_wanders(summary: dict[str, float | int]) -> bool:
    """Whether a rigid link's summary (:func:`_link_summary`) shows a wander a tilted
    camera or a distorting lens would cause: a spread of over :data:`LINK_WANDER`
    times the points' σ, or, on a link that turns, a slow one (:data:`LINK_SLOW_DW`)
    over their median σ."""
    return bool(summary["std_over_sigma"] > LINK_WANDER
                or (summary["durbin_watson"] < LINK_SLOW_DW
                    and summary["std_over_median_sigma"] > 1.0
                    and summary["turns_deg"] >= LINK_TURN_DEG))


#: Ratio of a link's mean square deviation to its σ² above which it shows an
#: excess: two standard errors (√(2/31)) of a mean over :data:`SCALE_WINDOW`.
LINK_SIGNIFICANCE = 1.5


def link_excess(tracks: pd.DataFrame) -> dict[str, np.ndarray]:
    """Per-marker error variance (mm², per axis) that the rigid links show
    beyond the tracker's ``_sigma_mm``.

    |AB| and |AC| are constant in the mechanism, so their deviation from the
    run's median is tracking error (the radial part of B − A and C − A).
    Where that deviation is larger than the points' σ say — on compressed
    video, a marker that moves crosses the codec's blocks and carries an
    error that changes slowly over a second, which no single frame's fit can
    see — the excess is the mean square deviation over :data:`SCALE_WINDOW`
    frames around each one less the mean σ², counted only where the ratio
    passes 1.5 (two standard errors of such a mean for errors as reported)
    so that honest σ are not widened by chance. Frames more than
    :data:`LINK_JUMP_SIGMA` σ off (glitches, which ``rigid_ok`` flags) are
    left out. The excess shared by
    both links is given to A, the rest of each link's to its other end.
    Errors are taken as isotropic, so the radial excess stands for the
    tangential one θ feels. A bias that stays the same all run (a still
    marker's) is in the median and not seen, and a real change of a link's
    length (a pivot that moves, a camera not square to the plane) is counted
    as error: the excess only ever widens σ.
    """
    return _excess(_rigid_links(tracks))


def _excess(links: dict[str, _Link]) -> dict[str, np.ndarray]:
    """:func:`link_excess` from the links already measured."""
    roll = {"window": SCALE_WINDOW, "center": True, "min_periods": SCALE_WINDOW // 2}
    excess = {}
    for name, link in links.items():
        dev2 = np.where(link.jump, np.nan, link.deviation**2)
        level = pd.Series(dev2).rolling(**roll).mean().to_numpy()
        expected = pd.Series(np.where(np.isfinite(dev2), link.sigma**2, np.nan))
        expected = expected.rolling(**roll).mean().to_numpy()
        with np.errstate(invalid="ignore"):
            seen = level > LINK_SIGNIFICANCE * expected
        excess[name] = np.where(seen, level - expected, 0.0)
    if "L1_mm" not in excess:
        # Without C, |AB| alone: its excess cannot be shared out, and goes to B.
        return {"A": np.zeros_like(excess["L2_mm"]), "B": excess["L2_mm"]}
    # L2 is |AB|, L1 is |AC|.
    shared = np.minimum(excess["L2_mm"], excess["L1_mm"])
    return {"A": shared, "B": excess["L2_mm"] - shared, "C": excess["L1_mm"] - shared}


@dataclass(frozen=True)
class MeasureInfo:
    """How the kinematics were measured: the window (samples and s), the
    σ scale applied to the rates (median over the run, and its range, since
    it follows the motion), the leave-one-out score of each candidate window
    and the rigid-link figures (mm)."""

    window: int
    window_s: float
    sigma_scale: float
    window_scores: dict[int, float]
    links: dict[str, dict[str, float]]
    sigma_scale_range: tuple[float, float] = (float("nan"), float("nan"))
    #: Frames left out because their picture repeats the one before
    #: (:func:`repeated_rows`).
    repeated_frames: int = 0
    #: What θ is measured from: ``"A-C"`` (the crank-slider's angle at A) or
    #: ``"x axis"`` (tracks without C, :func:`arm_angle`).
    theta_from: str = "A-C"

    def to_dict(self) -> dict:
        return {"window_samples": self.window, "window_s": self.window_s,
                "sigma_scale": self.sigma_scale,
                "sigma_scale_range": list(self.sigma_scale_range),
                "window_scores": {str(k): v for k, v in self.window_scores.items()},
                "links": self.links, "repeated_frames": self.repeated_frames,
                "theta_from": self.theta_from}


def _travel_sigma(dBx: Derivatives, dBy: Derivatives) -> tuple[np.ndarray, np.ndarray]:
    """1-σ of B's speed (mm/s, the velocity's σ along its direction of travel) and of
    its direction (rad: the σ across the direction over the speed); the speed's σ is the
    whole σ where B stands still."""
    vx, vy = dBx.d1, dBy.d1
    speed = np.hypot(vx, vy)
    with np.errstate(invalid="ignore", divide="ignore"):
        along = np.sqrt((vx * dBx.d1_sigma) ** 2 + (vy * dBy.d1_sigma) ** 2) / speed
        across = np.sqrt((vy * dBx.d1_sigma) ** 2 + (vx * dBy.d1_sigma) ** 2) / speed**2
    still = ~(speed > 0)
    along[still] = np.hypot(dBx.d1_sigma, dBy.d1_sigma)[still]
    return along, across


def _link_summary(link: _Link) -> dict[str, float | int]:
    """How rigid one link measured: its median, spread and range (mm), and the
    frames flagged as jumps."""
    std = float(np.nanstd(link.length))
    return {"median": float(np.nanmedian(link.length)),
            "std": std,
            "range": float(np.nanmax(link.length) - np.nanmin(link.length)),
            "frames_flagged": int(np.sum(link.jump & np.isfinite(link.length))),
            # The spread against what the points' σ allow: about 1 for a rigid
            # link tracked as the σ say (0.7–1.1 on the H.264 renders); a camera
            # not square to the plane or a lens that distorts bends it as the
            # mechanism moves.
            "std_over_sigma": float(std / np.sqrt(np.nanmean(link.sigma**2))),
            # A few frames of large σ lift the RMS above; the median is the σ of most.
            "std_over_median_sigma": float(std / np.nanmedian(link.sigma)),
            # Slow against frame-to-frame change: a tilt bends a link smoothly as the
            # mechanism moves, while each frame's noise is new. Over the frames where
            # the link is measured, in order.
            "durbin_watson": _durbin_watson(link.deviation),
            "turns_deg": _turn_deg(link.direction)}


def _turn_deg(direction: np.ndarray) -> float:
    """How far a link turns over the run: the 5th to the 95th percentile of its
    direction, degrees (0 when it is never measured)."""
    d = direction[np.isfinite(direction)]
    return float(np.degrees(np.subtract(*np.percentile(d, [95, 5])))) if d.size else 0.0


def _durbin_watson(deviation: np.ndarray) -> float:
    """The Durbin–Watson statistic of a link's deviations (NaN frames left out):
    about 2 for independent errors, near 0 for a slow drift; NaN under 3 frames."""
    d = deviation[np.isfinite(deviation)]
    e = d - d.mean() if d.size else d
    if e.size < 3 or not np.any(e):
        return float("nan")
    # statsmodels.stats.stattools.durbin_watson is this line; importing it costs
    # 1.2 s at the end of every `track`.
    return float(np.sum(np.diff(e) ** 2) / np.sum(e**2))


def repeated_rows(tracks: pd.DataFrame, names: Iterable[str] = "ABC") -> NDArray[np.bool_]:
    """Rows of a tracks table whose picture repeats the one before: in the pixel track
    of any marker of ``names`` (where the table has it; A, B and C by default) the
    marker all but stops for one frame between two in which it moves on the same way
    (:func:`.tracker.scatter.repeated_frames`). A phone that cannot keep up writes the
    last picture again; footage converted from a lower frame rate repeats every second
    or third."""
    out = np.zeros(len(tracks), dtype=bool)
    for m in names:
        if {f"{m}_x_px", f"{m}_y_px", f"{m}_ok"} <= set(tracks.columns):
            out |= repeated_frames(found_xy(tracks, m))
    return out


def measure_kinematics(
    tracks: pd.DataFrame, window_s: float | None = None, order: int = 2,
    scale_sigma: float = 0.0, skip_repeats: bool = True,
) -> tuple[pd.DataFrame, MeasureInfo]:
    """The kinematics table from a tracks table with plane coordinates.

    Parameters
    ----------
    tracks : DataFrame
        Tracks with ``t_s`` and ``A|B|C`` ``_x_mm``, ``_y_mm``, ``_sigma_mm``. Without
        C's columns θ is A→B's angle from the plane's x axis (:func:`arm_angle`), and
        ``L1_mm``, ``L3_mm`` and ``L3_rate_mm_s`` are NaN.
    window_s : float, optional
        Length of the differentiator's window, s; ``None`` chooses it from
        the data (leave-one-out cross-validation on θ).
    order : int
        Degree of the local polynomials.
    scale_sigma : float
        Relative 1-σ of the calibration's scale (``PlaneCalibration.scale_sigma``),
        added in quadrature to the σ of lengths and speeds.
    skip_repeats : bool
        Leave out the frames whose picture repeats the one before
        (:func:`repeated_rows`): their rows are NaN. Their timestamp is not when
        their picture was taken, and a rate fitted across one is off by the whole
        step: with one frame in twenty repeated, as a phone that cannot keep up
        writes them, ω of a crank turning at 2 rad/s (drawn tracks, σ 0.02 mm) was
        off by 0.34 rad/s RMS with them and 0.0004 without.

    Returns
    -------
    (DataFrame, MeasureInfo)
        The kinematics table of DESIGN.md (plus ``L1_mm``, ``L2_mm``,
        ``rigid_ok`` and ``theta_deg_sigma_tracker``, θ's σ from the
        tracker's σ alone), one row per frame, and how it was made.
    """
    for m in "AB" if "C_x_px" not in tracks else "ABC":
        if f"{m}_x_mm" not in tracks:
            raise CranktrackError(f"the tracks have no plane coordinates for marker {m}; "
                                  "calibrate first")
    repeat = repeated_rows(tracks) if skip_repeats else np.zeros(len(tracks), dtype=bool)
    if repeat.any():
        kept, info = measure_kinematics(tracks[~repeat].reset_index(drop=True), window_s,
                                        order, scale_sigma, skip_repeats=False)
        table = (kept.set_index("frame").reindex(tracks["frame"].to_numpy())
                 .rename_axis("frame").reset_index())
        table["t_s"] = tracks["t_s"].to_numpy(float)
        table["rigid_ok"] = table["rigid_ok"].eq(True)
        return table, replace(info, repeated_frames=int(repeat.sum()))
    t = tracks["t_s"].to_numpy(float)
    theta, theta_sigma = crank_angle(tracks)
    if window_s is None:
        w, scores = choose_window(t, theta, theta_sigma, order)
    else:
        w, scores = window_samples(t, window_s, order), {}

    fit_theta = local_polynomial(t, theta, theta_sigma, w, order, adaptive=True)
    scale = noise_scale(fit_theta.loo, theta_sigma, fit_theta.value_sigma,
                        fit_theta.shifted)

    def diff(y: np.ndarray, s: np.ndarray, d: Derivatives | None = None) -> Derivatives:
        return rates(t, y, s, w, order, scale, d)

    d_theta = diff(theta, theta_sigma, fit_theta)
    has_c = "C_x_mm" in tracks
    B = _xy(tracks, "B")
    sB = tracks["B_sigma_mm"].to_numpy(float)
    dBx, dBy = diff(B[:, 0], sB), diff(B[:, 1], sB)
    if has_c:
        C, sC = _xy(tracks, "C"), tracks["C_sigma_mm"].to_numpy(float)
        L3 = np.hypot(*(B - C).T)
        dL3 = diff(L3, np.hypot(sB, sC))
        L3_rate, L3_rate_sigma = dL3.d1, dL3.d1_sigma
    else:
        L3 = L3_rate = L3_rate_sigma = np.full(len(t), np.nan)
    vx, vy = dBx.d1, dBy.d1
    speed = np.hypot(vx, vy)
    along, across = _travel_sigma(dBx, dBy)
    # Positions report the error the rigid links show too; the rates keep the
    # per-point σ, which their own calibration (``scale``) already corrects.
    rigid = _rigid_links(tracks)
    wide = tracks.copy()
    for m, ex in _excess(rigid).items():
        wide[f"{m}_sigma_mm"] = np.sqrt(wide[f"{m}_sigma_mm"].to_numpy(float) ** 2 + ex)
    L3_sigma = (np.hypot(wide["B_sigma_mm"].to_numpy(float), wide["C_sigma_mm"].to_numpy(float))
                if has_c else np.full(len(t), np.nan))
    sigma = {
        "theta_deg": np.degrees(crank_angle(wide)[1]),
        "omega_rad_s": d_theta.d1_sigma,
        "alpha_rad_s2": d_theta.d2_sigma,
        "vB_x_mm_s": dBx.d1_sigma,
        "vB_y_mm_s": dBy.d1_sigma,
        "vB_mm_s": along,
        "vB_dir_deg": np.degrees(across),
        "L3_mm": L3_sigma,
        "L3_rate_mm_s": L3_rate_sigma,
    }
    # The calibration's scale error is shared by every frame's lengths and speeds.
    for col, value in (("vB_x_mm_s", vx), ("vB_y_mm_s", vy), ("vB_mm_s", speed),
                       ("L3_mm", L3), ("L3_rate_mm_s", L3_rate)):
        sigma[col] = np.hypot(sigma[col], np.abs(value) * scale_sigma)
    table = kinematics_table(t, theta, d_theta.d1, d_theta.d2, np.stack([vx, vy], axis=1), L3,
                             L3_rate, sigma=sigma, frame=tracks["frame"].to_numpy())
    # A direction of travel is only measured while B measurably moves.
    still_B = ~(speed > 2.0 * sigma["vB_mm_s"])
    table.loc[still_B, ["vB_dir_deg", "vB_dir_deg_sigma"]] = np.nan
    rigid_ok = np.isfinite(theta)
    for name in ("L1_mm", "L2_mm"):
        link = rigid.get(name)
        table[name] = np.nan if link is None else link.length
        if link is not None:
            rigid_ok &= ~link.jump
    table["rigid_ok"] = rigid_ok
    links = {name: _link_summary(link) for name, link in rigid.items()}
    # The noise level a model's residual is judged against (``cranktrack fit``): the
    # links' excess is left out, because a camera effect the loop looks for (a tilt)
    # bends the links too and would otherwise hide in the noise.
    table["theta_deg_sigma_tracker"] = np.degrees(theta_sigma)
    step = float(np.median(np.diff(t))) if t.size > 1 else float("nan")
    return table, MeasureInfo(w, w * step, float(np.median(scale)), scores, links,
                              (float(np.min(scale)), float(np.max(scale))),
                              theta_from="A-C" if has_c else "x axis")
