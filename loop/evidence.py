"""The evidence a fit is judged by: noise, independent frames, BIC, whiteness, diagnosis.

Tracker errors on compressed video are mostly a slowly varying bias (the
same marker at the same place gives the same error), so the residual of a
right model is not white. Counting every frame as independent evidence
would then accept effects that merely bend around that bias. The BIC and the
parameter intervals therefore count independent evidence
(:func:`independent_frames`): each stretch where the mechanism stands still
once, moving frames as ``n·(1 − ρ)/(1 + ρ)`` from the lag-1 autocorrelation
ρ (the AR(1) variance inflation).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from statsmodels.stats.diagnostic import acorr_ljungbox

#: ΔBIC an effect must win by. 10 is "very strong" on the Kass–Raftery scale, but
#: tracked renders without any effect reached 15.3 (tracker bias that differs between
#: the two rest positions looks like a little slack; bench/discrepancy.py, 20 null
#: renders), while the weakest real effect detected scored 26: hence 20.
BIC_THRESHOLD = 20.0
#: An accepted effect must change θ by more than this many σ of the noise somewhere.
#: 3σ let a 0.02 mm wire stretch through on one of 40 tracked null renders (imprint
#: 3.7σ, ΔBIC 20.6); the weakest real effect on the benchmark's ladders left 6.9σ.
IMPRINT_SIGMAS = 5.0
#: Two candidates whose ΔBIC differ by less than this explain the residual equally well.
LOOK_ALIKE_BIC = 2.0
#: Ljung–Box p-value below which a residual is called structured.
WHITE_P = 0.01
#: A white residual whose RMS is above this many times the tracker's σ still holds
#: something to explain. Dry friction on the SMA bed leaves such a residual: the base
#: model takes up all but a few stuck frames after each switch, which Ljung–Box does
#: not see (0.015 N·m: RMS 1.34× the tracker's σ, p 0.8). On the nulls the ratio is
#: 1 within a few %.
WHITE_BUT_LARGE = 1.2


#: A final fit that leaves more than this many times the tracker's σ still holds
#: something none of the candidates is (:attr:`EffectLoop.unexplained`): a right model
#: leaves the tracker's own error, about 1×.
UNEXPLAINED = 2.0


def fit_percent(measured: np.ndarray, model: np.ndarray) -> float:
    """``100·(1 − ‖y − ŷ‖ / ‖y − ȳ‖)`` over the samples both have."""
    ok = np.isfinite(measured) & np.isfinite(model)
    y, yh = measured[ok], model[ok]
    spread = np.linalg.norm(y - y.mean())
    return float(100.0 * (1.0 - np.linalg.norm(y - yh) / spread)) if spread > 0 else np.nan


def effective_samples(residual: NDArray[np.float64]) -> float:
    """``n·(1 − ρ)/(1 + ρ)`` with ρ the lag-1 autocorrelation (≥ 0), at least 3."""
    r = residual - residual.mean()
    n = r.size
    denom = float(r @ r)
    rho = float(r[1:] @ r[:-1]) / denom if denom > 0 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    return max(n * (1.0 - rho) / (1.0 + rho), 3.0)


def model_motion(model: NDArray[np.float64], t: NDArray[np.float64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """A model's rate (its unit per s) and the frames where it moves: a rate above a
    millionth of its largest (a kinked drive's rest frames are not quite zero)."""
    rate = np.gradient(model, t)
    top = float(np.max(np.abs(rate))) if rate.size else 0.0
    return rate, np.abs(rate) > 1e-6 * max(top, 1e-12)


def still_segments(model: NDArray[np.float64], tol: float = 1e-9) -> tuple[NDArray, int]:
    """Frames where the modelled mechanism stands still, and how many still stretches.

    Returns (mask of still frames, number of runs of ≥ 2 consecutive still frames).
    """
    flat = np.abs(np.diff(model)) <= tol
    still = np.zeros(model.size, bool)
    still[:-1] |= flat
    still[1:] |= flat
    edges = np.diff(np.concatenate([[0], still.astype(int), [0]]))
    return still, int(np.sum(edges == 1))


def independent_frames(series: list[NDArray[np.float64]], still: NDArray,
                       segments: int) -> float:
    """Independent pieces of evidence among the frames.

    A still mechanism films the same image again and again: the tracker's
    error there is one draw per still stretch, not one per frame. Moving
    frames count ``n·(1 − ρ)/(1 + ρ)``, with the largest ρ any of ``series``
    (residuals, a rigid link's length) shows over the moving frames.
    """
    moving = [np.asarray(x, float)[~still] for x in series]
    moving = [x[np.isfinite(x)] for x in moving]
    counts = [effective_samples(x) for x in moving if x.size >= 12]
    n_moving = min(counts) if counts else float(np.sum(~still))
    return max(n_moving + segments, 3.0)


@dataclass(frozen=True)
class NoiseModel:
    """The measurement error fits are judged against: a per-frame 1-σ of θ and
    the effective number of independent frames among ``n``."""

    sigma_deg: float
    n: int
    n_eff: float
    source: str

    @property
    def inflation(self) -> float:
        """Variance inflation of a mean over the frames, ``n / n_eff``."""
        return self.n / self.n_eff

    @property
    def variance(self) -> float:
        """σ² in rad²."""
        return float(np.radians(self.sigma_deg) ** 2)

    @classmethod
    def from_residual(cls, residual: NDArray[np.float64], k: int, floor_rad: float,
                      source: str) -> NoiseModel:
        """From a fit's residual (rad) with ``k`` free parameters: its RMS, but never
        below the tracker's own σ (``floor_rad``), and its lag-1 correlation."""
        n = residual.size
        s2 = max(float(residual @ residual) / max(n - k, 1), floor_rad**2)
        return cls(float(np.degrees(np.sqrt(s2))), n, effective_samples(residual), source)

    def to_dict(self) -> dict:
        return {"sigma_deg": self.sigma_deg, "frames": self.n,
                "effective_frames": self.n_eff, "source": self.source}


@dataclass(frozen=True)
class ModelFit:
    """One fitted model: its effects, all values, the free ones' unit covariance
    ``(JᵀJ)⁻¹`` (times the error variance it is the covariance), θ model and
    residual (rad)."""

    effects: tuple[str, ...]
    values: dict[str, float]
    free: tuple[str, ...]
    unit_cov: NDArray[np.float64]
    model: NDArray[np.float64]
    residual: NDArray[np.float64]
    #: d(residual)/d(free values) at the fit (frames × free), for what the free
    #: parameters can mimic (:mod:`.discovery` projects it out).
    jacobian: NDArray[np.float64] | None = None

    @property
    def rss(self) -> float:
        return float(self.residual @ self.residual)

    @property
    def rmse_deg(self) -> float:
        return float(np.degrees(np.sqrt(np.mean(self.residual**2))))

    def sigmas(self, noise: NoiseModel) -> dict[str, float]:
        """1-σ of the free parameters under ``noise`` (correlated frames counted once)."""
        var = np.clip(np.diag(self.unit_cov), 0.0, None) * noise.variance * noise.inflation
        return {k: float(v) for k, v in zip(self.free, np.sqrt(var), strict=True)}


def delta_bic(simpler: ModelFit, richer: ModelFit, noise: NoiseModel) -> float:
    """BIC(simpler) − BIC(richer) for Gaussian errors of the noise model's variance,
    with ``n_eff`` independent frames (so ``ΔRSS`` counts ``n_eff / n`` of itself)."""
    dk = len(richer.free) - len(simpler.free)
    return float((simpler.rss - richer.rss) / (noise.variance * noise.inflation)
                 - dk * np.log(noise.n_eff))


@dataclass(frozen=True)
class Step:
    """One round of :func:`effects_in_turn`: each effect tried on top of those already
    taken (``on``, in the order taken) and its ΔBIC against them, the one taken (None:
    those are enough, and the rounds end) and those it cannot be told from."""

    on: tuple[str, ...]
    delta_bic: dict[str, float]
    taken: str | None
    look_alikes: tuple[str, ...]


@dataclass(frozen=True)
class Verdict:
    """The verdict on candidate effects, each one more term on a base model of a track
    (:func:`effects_in_turn`): the noise variance and the independent samples it was
    judged by, the factor that turns a unit covariance's σ into one under that noise,
    and its rounds."""

    noise2: float
    n_eff: float
    sigma_factor: float
    steps: tuple[Step, ...]

    @property
    def taken(self) -> tuple[str, ...]:
        """The effects taken, in the order taken (empty: the base is enough)."""
        return tuple(s.taken for s in self.steps if s.taken is not None)

    def factor(self, residual: NDArray, parameters: int) -> float:
        """What turns a fit's unit covariance σ into its σ (:attr:`sigma_factor` for the
        closest fit): under the larger of the noise and what the fit itself leaves, with
        its own independent samples. A fit that leaves a bend (the base, where an effect
        is taken) is no surer than its residual says."""
        r = residual.reshape(len(residual), -1)
        own = float(np.sum(r**2)) / max(r.size - parameters, 1)
        n_eff = r.shape[1] * min(effective_samples(r[:, i]) for i in range(r.shape[1]))
        return float(np.sqrt(max(own, self.noise2) * r.size / min(n_eff, self.n_eff)))


@dataclass(frozen=True)
class EffectFit:
    """What every fit an effect loop makes has: its name (:func:`combined`, or the base
    model's) and values. Each loop's fit adds its figures, then ``residual`` (n, axes)
    in the track's unit and ``parameters``."""

    effect: str
    values: dict[str, float]

    @property
    def rms(self) -> float:
        """RMS of the residual per axis, the track's unit."""
        return float(np.sqrt(np.mean(self.residual**2)))


def combined(effects: tuple[str, ...]) -> str:
    """The name of a model with ``effects`` on its base, as a loop lists it."""
    return " + ".join(effects)


@dataclass(frozen=True)
class EffectLoop:
    """What an effect loop on a track found (:mod:`.flight`, :mod:`.swing`,
    :mod:`.rotation`): the base
    model's fit, each candidate's (one effect each, under its name, and those with more,
    under :func:`combined` names), the noise it judged them by (the track's unit), the
    samples and how many are independent, each single effect's ΔBIC against the base,
    the fit taken (None: the base is enough) and the first round's look-alikes; then the
    later rounds (:class:`Step`: an effect tried on top of those taken) and the
    tracker's σ (the noise's floor). The fits have ``to_dict()``."""

    base: Any
    candidates: dict[str, Any]
    noise: float
    samples: int
    independent: float
    delta_bic: dict[str, float]
    accepted: str | None
    look_alikes: tuple[str, ...]
    later: tuple[Step, ...] = ()
    floor: float = 0.0

    @property
    def final(self) -> Any:
        """The fit accepted, or the base."""
        return self.base if self.accepted is None else self.candidates[self.accepted]

    @property
    def unexplained(self) -> float:
        """What the final fit leaves, in times the tracker's σ (NaN without one): well
        over 1 where something none of the candidates holds bends the track."""
        rms = float(np.sqrt(np.mean(self.final.residual**2)))
        return rms / self.floor if self.floor > 0 else float("nan")

    def to_dict(self) -> dict:
        return {"base": self.base.to_dict(),
                "candidates": {k: v.to_dict() for k, v in self.candidates.items()},
                "noise": self.noise, "samples": self.samples,
                "independent_samples": self.independent, "delta_bic": self.delta_bic,
                "accepted": self.accepted, "look_alikes": list(self.look_alikes),
                "later_rounds": [{"on": list(s.on), "delta_bic": s.delta_bic,
                                  "taken": s.taken, "look_alikes": list(s.look_alikes)}
                                 for s in self.later],
                "tracker_sigma": self.floor}

    @classmethod
    def judged(cls, base: Any, candidates: dict[str, Any], verdict: Verdict, samples: int,
               independent: float, floor: float) -> EffectLoop:
        """The loop's result from its fits and :func:`effects_in_turn`'s verdict."""
        first = verdict.steps[0]
        return cls(base, candidates, float(np.sqrt(verdict.noise2)), samples, independent,
                   first.delta_bic, combined(verdict.taken) or None, first.look_alikes,
                   verdict.steps[1:], floor)


def effects_in_turn(fit: Callable[[tuple[str, ...]], tuple[NDArray, int]],
                    names: tuple[str, ...], floor: float, most: int | None = None
                    ) -> Verdict:
    """Take effects ``names`` one at a time onto a base model of a track, the one that
    explains most first, while each lowers the BIC by more than :data:`BIC_THRESHOLD`.

    ``fit(effects)`` fits the base with ``effects`` on it (``()``: the base alone) and
    returns its residual (n, axes) and number of parameters. The path is fitted to the
    end (or to ``most`` effects), each round adding the effect that leaves least; then
    every comparison is judged with one noise: what the closest fit on the path leaves
    per degree of freedom, never below ``floor`` (the tracker's σ, the residual's
    unit), its correlated samples counted once per independent stretch (the fewest on
    any axis, times the axes). The base's own residual, where an effect bends it, is no
    noise: its samples would count as one. In each round the others within
    :data:`LOOK_ALIKE_BIC` of the one taken, or leaving no more than it, are named with
    it.
    """
    most = len(names) if most is None else min(most, len(names))
    fits = {(): fit(())}
    n = fits[()][0].size
    path: list[tuple[str, ...]] = [()]
    for _ in range(most):
        on = path[-1]
        for name in names:
            if name not in on:
                fits[(*on, name)] = fit((*on, name))
        tried = [k for k in fits if len(k) == len(on) + 1 and k[:-1] == on]
        path.append(min(tried, key=lambda k: float(np.sum(fits[k][0] ** 2))))

    def per_dof(item: tuple[NDArray, int]) -> float:
        return float(np.sum(item[0] ** 2)) / (n - item[1])

    closest = min(fits.values(), key=per_dof)
    noise2 = max(per_dof(closest), floor**2)
    r = closest[0].reshape(len(closest[0]), -1)
    n_eff = r.shape[1] * min(effective_samples(r[:, i]) for i in range(r.shape[1]))
    scale = noise2 * n / n_eff

    steps = []
    for on in path[:-1]:
        rss0, k0 = float(np.sum(fits[on][0] ** 2)), fits[on][1]
        dbic = {k[-1]: float((rss0 - float(np.sum(fits[k][0] ** 2))) / scale
                             - (fits[k][1] - k0) * np.log(n_eff))
                for k in fits if len(k) == len(on) + 1 and k[:-1] == on}
        best = max(dbic, key=dbic.get)
        taken = best if dbic[best] > BIC_THRESHOLD else None

        # Alike: within LOOK_ALIKE_BIC of the one taken, or leaving no more than it with
        # more parameters (a flight's plane turned to the camera fits a little better
        # than a linear drag, and loses only the price of its second parameter).
        alike = tuple(k for k, v in dbic.items()
                      if taken is not None and k != best
                      and (dbic[best] - v <= LOOK_ALIKE_BIC
                           or np.sum(fits[(*on, k)][0] ** 2) <= np.sum(fits[(*on, best)][0] ** 2)))
        steps.append(Step(on, dbic, taken, alike))
        # A round's ΔBIC ranks as its residuals do when its effects have as many
        # parameters; where one with more wins on ΔBIC, nothing was fitted on top of it.
        if taken is None or (*on, taken) not in path:
            break
    return Verdict(noise2, n_eff, float(np.sqrt(scale)), tuple(steps))


def on_the_way(fitted: list[tuple[str, ...]], taken: tuple[str, ...]
               ) -> list[tuple[str, ...]]:
    """Of the effect sets ``fitted`` by :func:`effects_in_turn`, those a loop lists: each
    effect alone, and each set tried on the way to those ``taken`` (up to the round that
    took none)."""
    return [k for k in fitted if len(k) == 1 or (k and k[:-1] == taken[:len(k) - 1]
                                                 and len(k) <= len(taken) + 1)]


def round_table(loop: EffectLoop, on: tuple[str, ...], delta_bic: dict[str, float],
                heading: str, figures: Callable[[Any], str]) -> list[str]:
    """A round's candidates as a table: each effect added to ``on``, its ΔBIC and
    ``figures(fit)`` under ``heading``."""
    width = max(len("candidate"), *map(len, delta_bic))
    rows = [f"{'candidate':<{width}}  ΔBIC    {heading}",
            f"{'-' * width}  ------  {'-' * len(heading)}"]
    for k, d in delta_bic.items():
        rows.append(f"{k:<{width}}  {d:6.1f}  {figures(loop.candidates[combined((*on, k))])}")
    return rows


def rounds_text(loop: EffectLoop, heading: str, figures: Callable[[Any], str], what: str,
                unit: str, base: str, taken: Callable[[Any], str]
                ) -> tuple[list[str], list[str]]:
    """The lines a loop's text shares with every other's (``what``: "the swing", "the
    turn"; each round a :func:`round_table` of ``heading`` and ``figures``): the first
    round's table, its look-alikes and each later round, then the verdict (``base``,
    "the parabola", is enough; or what was accepted, the residual before and after and
    ``taken(final fit)``); and, to close, what is left where that is over
    :data:`UNEXPLAINED` times the tracker's σ (in ``unit``)."""

    def table(on: tuple[str, ...], dbic: dict[str, float]) -> list[str]:
        return round_table(loop, on, dbic, heading, figures)

    rounds = table((), loop.delta_bic)
    if loop.accepted and loop.look_alikes:
        rounds.append(f"taken: {loop.accepted.split(' + ')[0]}, but "
                      + ", ".join(loop.look_alikes) + f" explains {what} as well (ΔBIC "
                      f"within {LOOK_ALIKE_BIC:g}, or as close a fit with more parameters): "
                      "this track cannot tell them apart")
    for step in loop.later:
        rounds += ["", f"with {combined(step.on)} taken, one more:",
                   *table(step.on, step.delta_bic)]
        if step.look_alikes:
            rounds.append(f"taken: {step.taken}, but " + ", ".join(step.look_alikes)
                          + f" explains {what} as well")
    if loop.accepted is None:
        rounds.append(f"no effect lowers the BIC by more than {BIC_THRESHOLD:g}: {base} "
                      "is enough")
    else:
        rounds += ["", f"accepted: {loop.accepted}; residual {loop.base.rms:.3g} → "
                   f"{loop.final.rms:.3g} {unit}; {taken(loop.final)}"]
    left = []
    if loop.unexplained > UNEXPLAINED:
        left.append(f"what is left is {loop.unexplained:.1f}× the tracker's σ "
                    f"({loop.floor:.3g} {unit}): something none of these effects holds "
                    f"still bends {what}")
    return rounds, left


def ljung_box_p(residual: NDArray[np.float64], lags: int | None = None) -> float:
    """Ljung–Box p-value of a residual (small: structured, not white)."""
    n = residual.size
    if n < 12:
        return float("nan")
    lags = lags or int(min(10, n // 5))
    return float(acorr_ljungbox(residual - residual.mean(), lags=[lags])["lb_pvalue"].iloc[0])


def diagnose(fit: ModelFit, measured_deg: NDArray[np.float64], t: NDArray[np.float64],
             context: dict[str, NDArray[np.float64]] | None = None) -> dict:
    """Figures and correlations of a fit's residual.

    ``context`` adds series (same length) to correlate with, e.g. a marker's
    image row. Returns ``rmse_deg``, ``max_deg``, ``fit_percent``,
    ``ljung_box_p``, ``lag1_autocorrelation``, ``correlations`` (Pearson r,
    largest first) and ``phases`` (RMS before the drive, moving, after it).
    """
    r = np.degrees(fit.residual)
    model_deg = np.degrees(fit.model)
    omega, moving = model_motion(fit.model, t)
    series = {"time": t, "theta": model_deg, "omega": omega, "sign(omega)": np.sign(omega),
              **(context or {})}
    corr = {}
    for name, x in series.items():
        ok = np.isfinite(x)
        if ok.sum() > 3 and np.std(x[ok]) > 0 and np.std(r[ok]) > 0:
            corr[name] = float(np.corrcoef(x[ok], r[ok])[0, 1])
    moved = np.flatnonzero(moving)
    phases = {}
    if moved.size:
        parts = {"before": slice(0, moved[0]), "moving": slice(moved[0], moved[-1] + 1),
                 "after": slice(moved[-1] + 1, r.size)}
        for name, s in parts.items():
            if r[s].size:
                phases[name] = {"rmse_deg": float(np.sqrt(np.mean(r[s] ** 2))),
                                "frames": int(r[s].size)}
    rc = r - r.mean()
    lag1 = float(rc[1:] @ rc[:-1] / (rc @ rc)) if rc @ rc > 0 else 0.0
    return {
        "rmse_deg": float(np.sqrt(np.mean(r**2))),
        "max_deg": float(np.max(np.abs(r))),
        "fit_percent": fit_percent(measured_deg, model_deg),
        "ljung_box_p": ljung_box_p(r),
        "lag1_autocorrelation": lag1,
        "correlations": dict(sorted(corr.items(), key=lambda kv: -abs(kv[1]))),
        "phases": phases,
    }


def link_evidence(measured: pd.DataFrame, tracker_sigma_deg: float) -> dict:
    """What the rigid links say: a camera effect (lens distortion, tilt, a wrong
    calibration) bends rigid lengths as the mechanism moves across the image; a
    mechanism effect does not. The crank |AB| is suspect when it varies by more than
    twice what the tracker's σ allows and follows θ (|r| > 0.7)."""
    if "L2_mm" not in measured or "theta_deg" not in measured:
        return {}
    out: dict = {}
    theta = measured["theta_deg"].to_numpy(float)
    for name in ("L1_mm", "L2_mm"):
        if name not in measured:
            continue
        x = measured[name].to_numpy(float)
        ok = np.isfinite(x) & np.isfinite(theta)
        if ok.sum() < 12:
            continue
        r = (float(np.corrcoef(x[ok], theta[ok])[0, 1])
             if np.std(x[ok]) > 0 and np.std(theta[ok]) > 0 else 0.0)
        out[name] = {"median_mm": float(np.median(x[ok])), "std_mm": float(np.std(x[ok])),
                     "r_with_theta": r}
    crank = out.get("L2_mm")
    if crank:
        expected = crank["median_mm"] * np.radians(tracker_sigma_deg)
        suspect = crank["std_mm"] > 2.0 * expected and abs(crank["r_with_theta"]) > 0.7
        out["crank_std_expected_mm"] = float(expected)
        out["camera_effect_suspected"] = bool(suspect)
        if suspect:
            out["reading"] = (f"the rigid crank |AB| varies by {crank['std_mm']:.3f} mm (σ; the "
                              f"tracker allows {expected:.3f}) and follows θ (r = "
                              f"{crank['r_with_theta']:.2f}): a camera effect such as lens "
                              "distortion or tilt, not the mechanism — calibrate the camera "
                              "(`cranktrack calibrate camera`, then `calibrate plane`)")
    return out
