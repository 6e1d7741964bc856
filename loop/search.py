"""Close the loop between measured θ(t) and a model: residual, missing effect, before/after.

Three base models (:data:`MODELS`): ``spool`` (the rigid bed of thesis §2.5.2),
``dynamic`` (the free response of eq. 3.28) and ``sma`` (the current-heated bed of
§2.5.3 with the heat model of chapter 4), each with its own effect library.

1. The base model is fitted by simulation (output error): least squares of
   measured minus simulated θ over every parameter the user did not fix
   (``known``), from several starts.
2. Its residual is diagnosed: RMS, largest, fit%, Ljung–Box whiteness, and
   what it correlates with (time, θ, ω, the sign of ω, the drive's phases,
   the marker's place in the image).
3. Every candidate effect of the model (e.g. :data:`CANDIDATES` for the
   spool, each a model extension with its own physical parameters) is fitted
   on top of the current model.
4. A candidate passes only if ΔBIC > 20 (:data:`BIC_THRESHOLD`), its
   parameter's 95 % interval excludes "no effect", the value is physically
   plausible and its imprint on θ rises above the noise; the passing one
   with the largest ΔBIC is accepted (any that fit as well or better but
   fail are named beside it), then the rest are tried again on top of it,
   until nothing more is accepted or the residual is white and within
   :data:`~.evidence.WHITE_BUT_LARGE` of the tracker's noise. A later effect
   must keep its value fitted alone (it is not there only to soak up what the
   first left); a lens or tilt must show the bend of the rigid crank it
   predicts (:func:`_link_veto`); a readout must be shorter than a frame.
5. Open world: when the residual stays structured above 1.5× the tracker's
   noise, the accepted effects are not named (``tentative``), the leftover
   is described instead (:mod:`.leftover`) and a sparse regression proposes an
   equation for the missing term (:mod:`.discovery`).

The BIC and the parameter intervals count independent evidence, not frames
(:mod:`.evidence` says why and how).

Candidates a model cannot tell apart are handled openly: an effect that
needs a known value to be separable (a dead time is a later start unless the
start time is known) is not fitted without it and the report says which
value would separate it; candidates that fit equally well are reported as a
group with the experiment that would tell them apart.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..errors import CranktrackError
from .camera_view import CameraView, camera_link_mm, with_camera
from .candidates import CAMERA_CANDIDATES, CAMERA_PARAMETERS, READOUT, Candidate, Parameter
from .discovery import discover
from .evidence import (
    BIC_THRESHOLD,
    IMPRINT_SIGMAS,
    LOOK_ALIKE_BIC,
    WHITE_BUT_LARGE,
    WHITE_P,
    ModelFit,
    NoiseModel,
    delta_bic,
    diagnose,
    effective_samples,
    independent_frames,
    link_evidence,
    ljung_box_p,
    still_segments,
)
from .leftover import signature
from .result import CandidateScore, LoopResult
from .simulate import MODELS, ModelSpec

#: Model evaluations per least-squares start: kinked models (a drive that starts and
#: stops) can crawl along a valley for thousands of steps without gaining anything.
MAX_EVALUATIONS = 200
#: Grid points of a profiled parameter (:meth:`_Fitter._profile`): 30 over a range of 90
#: are 17 % apart, closer than the valleys of dry friction or a ripple's turn length.
PROFILE_POINTS = 30


def _fit(t: NDArray, theta: NDArray, simulate: Callable, fixed: dict[str, float],
         free: list[Parameter], starts: list[list[float]], effects: tuple[str, ...],
         diff_step: float = 1e-7, max_evaluations: int = MAX_EVALUATIONS
         ) -> ModelFit | None:
    """Least squares of ``theta − simulate(values, t)`` from each start; the best, or None."""
    def values_of(x: NDArray) -> dict[str, float]:
        return {**fixed, **{p.name: float(v) for p, v in zip(free, x, strict=True)}}

    def residual(x: NDArray) -> NDArray:
        try:
            return theta - simulate(values_of(x), t)
        except (CranktrackError, ValueError, FloatingPointError):
            return np.full(t.size, 10.0)  # a linkage that cannot close: far from any fit

    lo = np.array([p.lower for p in free])
    hi = np.array([p.upper for p in free])
    width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    best = None
    for x0 in starts:
        x0 = np.clip(np.asarray(x0, float), lo + 1e-9 * width, hi - 1e-9 * width)
        if np.all(residual(x0) == 10.0):
            continue
        with np.errstate(all="ignore"):
            sol = least_squares(residual, x0, bounds=(lo, hi), x_scale="jac", method="trf",
                                diff_step=diff_step, max_nfev=max_evaluations)
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None or np.all(best.fun == 10.0):
        return None
    unit_cov = np.linalg.pinv(best.jac.T @ best.jac)
    return ModelFit(effects, values_of(best.x), tuple(p.name for p in free), unit_cov,
                    theta - best.fun, best.fun, best.jac)


def _switched_off(c: Candidate) -> dict[str, float]:
    """Values that make the simulation leave the effect out (a ring of 0 Hz is none)."""
    return {c.parameters[0].name: 0.0 if np.isinf(c.off) else c.off}


def _score(c: Candidate, rnd: int, current: ModelFit, alt: ModelFit, noise: NoiseModel,
           t: NDArray, simulate: Callable, nyquist_hz: float) -> CandidateScore:
    """ΔBIC, interval, plausibility and imprint of ``alt`` = ``current`` + ``c``."""
    sig = alt.sigmas(noise)
    p = c.parameters[0].name
    v, s = alt.values[p], sig[p]
    if not (np.isfinite(s) and s > 0):
        excludes = False
    elif np.isinf(c.off):  # a ring: resolved only if its whole interval is below Nyquist
        excludes = v + 1.96 * s < nyquist_hz
    else:
        excludes = abs(v - c.off) > 1.96 * s

    def free_of_bounds(q: Parameter) -> bool:
        x, tol = alt.values[q.name], 1e-6 * max(1.0, abs(q.lower), abs(q.upper))
        return q.lower + tol < x < q.upper - tol

    lo, hi = c.plausible
    plausible = lo <= v <= hi and all(free_of_bounds(q) for q in c.parameters)
    try:
        without = simulate({**alt.values, **_switched_off(c)}, t)
        imprint = float(np.degrees(np.max(np.abs(alt.model - without))))
    except CranktrackError:
        imprint = float("nan")
    return CandidateScore(c.name, rnd, delta_bic(current, alt, noise), alt.rmse_deg,
                          {q.name: alt.values[q.name] for q in c.parameters},
                          {q.name: sig[q.name] for q in c.parameters}, imprint,
                          bool(excludes), bool(plausible),
                          bool(imprint > IMPRINT_SIGMAS * noise.sigma_deg))


def _tryable(candidates: dict[str, Candidate], known: dict[str, float], dt: float
             ) -> tuple[list[Candidate], list[dict]]:
    """The candidates that can be told from the base model with what is ``known``, and
    what the report says of the others; ``dt`` is the frame interval, s."""

    def separable(c: Candidate) -> bool:
        return not c.needs_known or any(k in known for k in c.needs_known)

    not_separable = [{"name": c.name, "needs": list(c.needs_known), "shows_as": c.shows_as,
                      "why": f"without {' or '.join(c.needs_known)} known, {c.name} is the same "
                             "as a change in the base model's own parameters"}
                     for c in candidates.values() if not separable(c)]
    # A rolling shutter reads the frame out within one frame interval.
    tryable = [replace(c, plausible=(-dt, dt)) if c.name == READOUT else c
               for c in candidates.values() if separable(c)]
    return tryable, not_separable


def close_loop(measured: pd.DataFrame, known: dict[str, float] | None = None,
               model: str = "spool", context: dict[str, NDArray] | None = None,
               candidates: dict[str, Candidate] | None = None,
               view: CameraView | None = None,
               on_fit: Callable[[tuple[str, ...]], None] | None = None) -> LoopResult:
    """Fit the base model to measured θ(t), then add effects while the evidence says so.

    Parameters
    ----------
    measured : DataFrame
        A kinematics table: ``t_s``, ``theta_deg`` (per frame, not smoothed),
        ``theta_deg_sigma`` (or ``theta_deg_sigma_tracker``, preferred: the
        noise level without the rigid links' widening), ``L3_mm``;
        ``L1_mm``/``L2_mm`` seed the lengths.
    known : dict
        Values the user knows from the rig, held fixed (the model's base names:
        :data:`SPOOL_BASE`, :data:`DYNAMIC_BASE`).
    model : str
        The base model, a key of :data:`MODELS` (``"spool"``, ``"dynamic"``).
    context : dict, optional
        Extra series, one value per row of ``measured``, to correlate the
        residual with (e.g. ``"B image row"``).
    candidates : dict, optional
        The effect library (default: the model's own, plus the camera effects
        :data:`CAMERA_CANDIDATES` when ``view`` is given).
    view : CameraView, optional
        The run's image geometry, which the camera candidates need.
    on_fit : callable, optional
        Called with the effects of each model about to be fitted (``()`` for the
        base model), for a progress display: a loop runs tens of fits.

    Raises
    ------
    CranktrackError
        Another model, too few frames, or known values no model can meet.
    """
    spec = MODELS.get(model)
    if spec is None:
        raise CranktrackError(f"the {model!r} model cannot be fitted yet; available: "
                              f"{', '.join(MODELS)}")
    known = dict(known or {})
    if candidates is None:
        candidates = {**spec.candidates, **(CAMERA_CANDIDATES if view is not None else {})}
    simulate = with_camera(spec.simulate, view)
    for col in ("t_s", "theta_deg"):
        if col not in measured:
            raise CranktrackError(f"the kinematics table has no {col} column")
    t_all = measured["t_s"].to_numpy(float)
    deg_all = measured["theta_deg"].to_numpy(float)
    ok = np.isfinite(t_all) & np.isfinite(deg_all)
    if ok.sum() < 12:
        raise CranktrackError("fewer than 12 frames have a measured crank angle; too few to fit "
                              "a model and judge its residual")
    t, deg = t_all[ok], deg_all[ok]
    theta = np.radians(deg)
    ctx = {k: np.asarray(v, float)[ok] for k, v in (context or {}).items()}
    extra, messages = spec.hold(measured, known)
    held = {**known, **extra}
    # The tracker's own σ, without the rigid links' widening where the table has it:
    # a camera effect bends the links, and the loop must not count it as noise.
    noise_col = next((c for c in ("theta_deg_sigma_tracker", "theta_deg_sigma")
                      if c in measured), None)
    sig = measured[noise_col].to_numpy(float)[ok] if noise_col else np.full(t.size, np.nan)
    tracker_deg = float(np.nanmedian(sig)) if np.isfinite(sig).any() else 0.0
    fitter = _Fitter(t, theta, simulate, spec, held, candidates,
                     spec.guesses(t, theta, measured, held), on_fit)
    base = fitter.fit((), fitter.guess)
    if base is None:
        raise CranktrackError(f"no {model} model with these known values reproduces the "
                              "measured angles; check the --known values")

    tryable, not_separable = _tryable(candidates, known, float(np.median(np.diff(t))))
    links = measured["L2_mm"].to_numpy(float)[ok] if "L2_mm" in measured else None
    rigid = link_evidence(measured, tracker_deg)
    noise = _judge_noise(fitter, base, tryable, tracker_deg, links, deg)
    veto = _link_veto(theta, links, view)
    current, steps, scores, groups = _add_effects(fitter, base, tryable, noise, veto,
                                                  np.radians(tracker_deg))
    before = diagnose(base, deg, t, ctx)
    after = diagnose(current, deg, t, ctx)
    # Structure well above the tracker's noise that the accepted effects leave:
    # they improved the fit without explaining it, so none is named.
    level = tracker_deg or noise.sigma_deg
    tentative, leftover = (), None
    if after["rmse_deg"] > 1.5 * level and after["ljung_box_p"] < WHITE_P:
        tentative = current.effects
        if tentative:
            scores = [replace(sc, accepted=False, note=sc.note + (
                "; " if sc.note else "") + "improved the fit but left a structured residual "
                f"of {after['rmse_deg']:.3g}° (noise {level:.3g}°), so not named")
                if sc.accepted else sc for sc in scores]
            current, steps, after = base, [], before
        leftover = signature(t, np.degrees(base.residual), np.degrees(base.model), ctx)
        ripple = next((s for s in leftover["shapes"] if s["kind"] == "periodic"), None)
        found = discover(t, np.degrees(base.residual), np.degrees(base.model), level,
                         base.jacobian, ripple and ripple["hz"],
                         bool(ripple and ripple["while_moving_only"]))
        leftover["discovery"] = found.to_dict() if found else None
    return LoopResult(model, known, base, current, steps, scores, not_separable, groups,
                      before, after, noise, tracker_deg, rigid, messages,
                      tentative=tuple(tentative), leftover=leftover)


class _Fitter:
    """The base model with any set of effects fitted to one run's θ(t) (rad) at times t (s).

    The same request twice (the reference fit is round 1's when there is one
    candidate) is fitted once.
    """

    def __init__(self, t: NDArray, theta: NDArray, simulate: Callable, spec: ModelSpec,
                 held: dict[str, float], candidates: dict[str, Candidate],
                 guesses: list[dict],
                 on_fit: Callable[[tuple[str, ...]], None] | None = None) -> None:
        self.t, self.theta, self.simulate, self.spec = t, theta, simulate, spec
        self.on_fit = on_fit
        self.held, self.candidates = held, candidates
        self.guesses, self.guess = guesses, guesses[0]
        span = float(t[-1] - t[0])
        self.base_free = [replace(p, lower=t[0] - span, upper=t[-1]) if k == "start_s" else p
                          for k, p in spec.base.items() if k not in held]
        self.nyquist = 0.5 / float(np.median(np.diff(t)))
        self._cache: dict[tuple, ModelFit | None] = {}

    def fit(self, effects: tuple[str, ...], start_from: dict[str, float]) -> ModelFit | None:
        """The model with ``effects`` fitted from ``start_from`` (and the data's guesses)."""
        key = (tuple(sorted(effects)), tuple(sorted(start_from.items())))
        if key not in self._cache:
            if self.on_fit:
                self.on_fit(effects)
            self._cache[key] = self._fit(effects, start_from)
        fit = self._cache[key]
        return None if fit is None else replace(fit, effects=effects)

    def _fit(self, effects: tuple[str, ...], start_from: dict[str, float]) -> ModelFit | None:
        free = list(self.base_free)
        lists = []
        for name in effects:
            c = self.candidates[name]
            # A parameter two effects share (the crank's ring, which dry friction acts
            # through) is fitted once, where it first comes.
            mine = [i for i, p in enumerate(c.parameters) if p.name not in
                    {q.name for q in free}]
            ps = [replace(p, upper=min(p.upper, 0.9 * self.nyquist)) if p.unit == "Hz" else p
                  for p in (c.parameters[i] for i in mine)]
            free += ps
            have = [start_from.get(p.name) for p in ps]
            # The library's starts, and any the data's guesses give for this effect.
            own = [tuple(g[p.name] for p in ps) for g in self.guesses[:1]
                   if all(p.name in g for p in ps)]
            lists.append([tuple(have)] if all(h is not None for h in have)
                         else [*(tuple(st[i] for i in mine) for st in c.starts), *own])
        # Each effect's starting values in turn (the longest list sets how many).
        width = max((len(x) for x in lists), default=1)
        effect_starts = [sum((x[i % len(x)] for x in lists), ()) for i in range(width)]
        # The base fit tries every guess; an effect's fit starts where the base ended
        # and from the data's own first guess (a base fit that bent its lengths to
        # mimic an effect can sit in a valley the effect cannot leave).
        guess = self.guess
        # Effects fitted together start where each ended alone, so the data's other
        # guesses are for an effect's first fit (they cost the free swing's loop a
        # minute on a minute of θ when two effects were fitted together from each).
        extra = self.spec.effect_guesses if len(effects) == 1 else 1
        origins = (self.guesses if start_from is guess and not effects
                   else [start_from] if start_from is guess
                   else [start_from, *self.guesses[:extra]])
        starts = [[o[p.name] for p in self.base_free] + list(es)
                  for es in effect_starts for o in origins]
        scanned = [n for n in effects if self.candidates[n].scan is not None
                   and self.candidates[n].scan[0] not in start_from]
        if len(scanned) == 1 and len(effects) == 1:
            starts = self._profile(self.candidates[scanned[0]], start_from) + starts
        return _fit(self.t, self.theta, self.simulate, self.held, free, starts, effects,
                    self.spec.diff_step)

    def _profile(self, c: Candidate, origin: dict[str, float]) -> list[list[float]]:
        """Starts for an effect whose fit has a valley per class of motion: its
        :attr:`Candidate.scan` parameter on a geometric grid (from a thirtieth of the
        data's guess to three times it, or over the scan's range), the base and the
        effect's other parameters refitted briefly at each on at most ~300 frames; the
        two best, as full starts (base values, then the effect's in its order)."""
        name, lo, hi = c.scan
        guess = next((g[name] for g in self.guesses if name in g), None)
        if guess and guess > 0:
            lo, hi = guess / 30.0, 3.0 * guess
        step = max(1, self.t.size // 300)
        t, theta = self.t[::step], self.theta[::step]
        others = [p for p in c.parameters if p.name != name]
        # One start: the other parameters, free in each brief fit, find their own way.
        x0 = ([origin[p.name] for p in self.base_free]
              + [v for p, v in zip(c.parameters, c.starts[0], strict=True) if p.name != name])
        profile = []
        for v in np.geomspace(lo, hi, PROFILE_POINTS):
            quick = _fit(t, theta, self.simulate, {**self.held, name: float(v)},
                         self.base_free + others, [x0], (c.name,), self.spec.diff_step, 15)
            if quick is not None:
                values = {**quick.values, name: float(v)}
                profile.append((quick.rss, [values[p.name] for p in self.base_free]
                                + [values[p.name] for p in c.parameters]))
        profile.sort(key=lambda p: p[0])
        return [x for _, x in profile[:2]]


def _judge_noise(fitter: _Fitter, base: ModelFit, tryable: list[Candidate],
                 tracker_deg: float, links: NDArray | None, theta_deg: NDArray) -> NoiseModel:
    """The noise every candidate is judged against, with its count of independent frames.

    It is judged on the richest model (the candidates together): its residual is
    as close to the measurement error as the library can get, so a second effect
    still in the data does not pass for noise while the first is tried. Only
    effects that could pass join it: a fit whose drop in RSS is under
    BIC_THRESHOLD tracker variances cannot (the noise is never below the
    tracker's σ, nor the evidence more than the frames). It starts where each of
    them alone ended (round 1 fits them anyway, and the cache keeps them) and from
    each one's first start; the lowest residual of all these fits is the one judged.
    """
    floor2 = np.radians(tracker_deg) ** 2
    alone, first, fits, joining = {}, {}, [], []
    for c in tryable:
        single = fitter.fit((c.name,), base.values)
        if single is None:
            continue
        fits.append(single)
        if floor2 == 0 or (base.rss - single.rss) / floor2 > BIC_THRESHOLD:
            joining.append(c.name)
            first.update(zip((p.name for p in c.parameters), c.starts[0], strict=True))
            alone.update({p.name: single.values[p.name] for p in c.parameters})
    if len(joining) > 1:
        fits += [f for f in (fitter.fit(tuple(joining), {**base.values, **alone}),
                             fitter.fit(tuple(joining), {**base.values, **first}))
                 if f is not None]
    ref = min(fits, key=lambda f: f.rss, default=base)
    ref = ref if ref.rss < base.rss else base
    noise = NoiseModel.from_residual(ref.residual, len(ref.free), np.radians(tracker_deg),
                                     "the base model" if ref is base
                                     else "the best-fitting candidate model")
    # How many independent pieces of evidence the frames hold. The crank |AB| is
    # rigid, so its measured length is the tracker's error seen directly, free of any
    # model; a rich reference model whitens its residual by absorbing some of that
    # error, so the more correlated of the two is the honest count.
    evidence = [ref.residual] + ([links] if links is not None else [])
    still, segments = still_segments(base.model)
    return replace(noise, n_eff=independent_frames(evidence, still, segments),
                   source=noise.source + "; moving frames counted by the lag-1 correlation of "
                   "that residual and of the |AB| link, each still stretch once")


def _link_veto(theta: NDArray, links: NDArray | None, view: CameraView | None
               ) -> Callable[[str, dict[str, float]], str]:
    """A check of a lens or tilt at its fitted values against the rigid crank.

    Such an effect bends the measured |AB| as the crank crosses the image, by an
    amount the camera model predicts (:func:`.camera_view.camera_link_mm`). The
    measured |AB| is regressed on that predicted bend: a real effect shows with a
    slope near 1. It is vetoed when the slope is clearly below one half (its upper
    95 % bound, frames counted by their lag-1 correlation): the bend it implies is
    not there, so the effect could only be soaking up something else.
    """
    ok = None if links is None else np.isfinite(links)

    def check(name: str, values: dict[str, float]) -> str:
        if name not in CAMERA_PARAMETERS or view is None or ok is None or ok.sum() < 12:
            return ""
        predicted = camera_link_mm(theta[ok], values, view)
        p = predicted - predicted.mean()
        o = links[ok] - links[ok].mean()
        pp = float(p @ p)
        if pp <= 0:
            return ""
        slope = float(p @ o) / pp
        rest = o - slope * p
        sigma = float(np.std(rest)) / np.sqrt(pp) * np.sqrt(rest.size / effective_samples(rest))
        if slope + 1.96 * sigma < 0.5:
            return (f"the rigid crank |AB| does not bend as it would ({np.std(p):.3g} mm σ "
                    f"predicted, slope {slope:.2f} ± {sigma:.2f} of it measured)")
        return ""

    return check


def _stands_alone(c: Candidate, together: CandidateScore, single: CandidateScore | None
                  ) -> bool:
    """Whether an effect fitted beside others agrees with itself fitted alone."""
    if single is None or not single.plausible:
        return False
    p = c.parameters[0].name
    off = 0.0 if np.isinf(c.off) else c.off
    a, b = single.values[p] - off, together.values[p] - off
    return bool(a * b > 0 and max(abs(a), abs(b)) <= 3.0 * min(abs(a), abs(b)))


def _add_effects(fitter: _Fitter, base: ModelFit, tryable: list[Candidate], noise: NoiseModel,
                 veto: Callable[[str, dict[str, float]], str], floor_rad: float = 0.0
                 ) -> tuple[ModelFit, list[ModelFit], list[CandidateScore], list[dict]]:
    """Rounds of candidates on top of the current model until none passes or the residual
    is white and no larger than :data:`WHITE_BUT_LARGE` × ``floor_rad`` (the tracker's
    σ, rad; 0: whiteness alone): (final fit, accepted steps, every score, groups that
    fit alike).

    ``veto(name, values)`` says why a fitted candidate cannot be ("" if it can). From
    round 2 on, an
    effect must also stand on its own: alone on the base model it must have been
    plausible, with the same sign and within a factor of 3 of the value it takes
    beside the others — an effect that is only there to soak up what another
    left, at a value it does not have alone, is not a second effect.
    """
    current, steps, scores, groups = base, [], [], []
    alone: dict[str, CandidateScore] = {}
    for rnd in range(1, len(tryable) + 1):
        rms = float(np.sqrt(np.mean(current.residual**2)))
        within = floor_rad <= 0 or rms <= WHITE_BUT_LARGE * floor_rad
        if ljung_box_p(current.residual) >= WHITE_P and within:
            break  # nothing structured, nor more than the noise, left to explain
        tried = []
        for c in tryable:
            if c.name in current.effects:
                continue
            alt = fitter.fit((*current.effects, c.name), current.values)
            if alt is None:
                continue
            sc = _score(c, rnd, current, alt, noise, fitter.t, fitter.simulate,
                        fitter.nyquist)
            if rnd == 1:
                alone[c.name] = sc
            why = veto(c.name, alt.values)
            if rnd > 1 and not why and not _stands_alone(c, sc, alone.get(c.name)):
                why = "alone on the base model it has another value or none at all"
            tried.append((replace(sc, veto=why), alt))
        if not tried:
            break
        tried.sort(key=lambda sa: -sa[0].delta_bic)
        # The best candidate that passes every test; one that fits a little better but
        # fails one (an imprint under 5σ, a value on a bound) does not block it — it is
        # named beside it, as is any that fits as well.
        at = next((i for i, (sc, _) in enumerate(tried) if sc.passes), None)
        if at is not None:
            best, alt = tried[at]
            like = [sc.name for i, (sc, _) in enumerate(tried) if i != at and sc.delta_bic > 0
                    and (i < at or best.delta_bic - sc.delta_bic < LOOK_ALIKE_BIC)]
            note = ""
            if like:
                note = f"fits as well as {', '.join(like)}"
                ways = dict.fromkeys(fitter.candidates[n].separated_by
                                     for n in (best.name, *like))
                groups.append({"effects": [best.name, *like], "round": rnd,
                               "separated_by": "; or ".join(w for w in ways if w)
                               or "a known value or a measurement only one of them changes"})
            tried[at] = (replace(best, accepted=True, note=note), alt)
        scores += [sc if sc.accepted or sc.note else replace(sc, note=sc.why_not())
                   for sc, _ in tried]
        if at is None:
            break
        current = alt
        steps.append(alt)
    return current, steps, scores, groups
