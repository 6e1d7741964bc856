"""Discovery: an equation for the term the effect library lacks, by sparse regression.

When no candidate explains the residual, the loop still owes the user a
proposal. :func:`discover` regresses what the base model leaves (measured −
model θ) on a library of functions of the model's own θ, ω and α, of time and
of the drive (a step where the model starts to move, the sign of ω, a ripple at
the leftover's strongest frequency), and keeps the few terms the data need:
stepwise sparse regression (SSR), one of SINDy's sparse regressions, from
PySINDy.

Two choices make the proposal honest:

- The base model's own parameters took what they could of the missing term
  before the residual was formed (a later start, a shorter crank). The library
  and the residual are therefore both taken orthogonal to the base fit's
  Jacobian first, so a term is kept only for what no base parameter can mimic,
  and "after" is the linearised refit of base plus term.
- How many terms is not a tuning knob: along SSR's elimination path, from one
  term up, each added term must win the loop's own :data:`.evidence.BIC_THRESHOLD`
  (independent frames, not frames) and take :data:`MIN_SHARE` of the residual.

Angles in degrees, times in s.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .evidence import BIC_THRESHOLD, effective_samples, model_motion

#: Term → how it reads in the equation (the coefficient's unit is in it); the ripple's
#: sine and cosine are read together as one amplitude and phase.
TERMS = {
    "offset": "{c}°",
    "after start": "{c}°·[t ≥ {t0:.3g} s]",
    "theta": "{c}·(θ − {mean:.4g}°)",
    "theta^2": "{c}·(θ − {mean:.4g}°)²",
    "omega": "{c} s·ω",
    "alpha": "{c} s²·α",
    "sign(omega)": "{c}°·sign(ω)",
    "time": "{c}°/s·(t − {t_first:.3g} s)",
}


#: The least share of the residual's sum of squares a term must take to be proposed.
MIN_SHARE = 0.05
#: The largest condition number of the kept terms (columns at unit RMS): beyond it two
#: terms nearly cancel (an offset and θ where the model hardly moves) and their
#: coefficients are large, opposite and meaningless.
MAX_CONDITION = 30.0
#: A term is left out when the base parameters can mimic all but this fraction of its RMS.
MIMICKED = 0.1


@dataclass(frozen=True)
class Discovery:
    """A proposed equation for the missing term, and the error before and after it.

    ``terms`` maps each kept library term (:data:`TERMS`) to its coefficient in
    deg per unit of the term; ``equation`` reads them as one line; the RMSEs are
    of θ (deg), after is the linearised refit of the base model with the terms.
    """

    terms: dict[str, float]
    equation: str
    rmse_before_deg: float
    rmse_after_deg: float
    delta_bic: float
    ripple_hz: float | None

    def to_dict(self) -> dict:
        return {"terms": self.terms, "equation": self.equation,
                "rmse_before_deg": self.rmse_before_deg, "rmse_after_deg": self.rmse_after_deg,
                "delta_bic": self.delta_bic, "ripple_hz": self.ripple_hz,
                "method": "stepwise sparse regression (PySINDy SSR) of the residual, orthogonal "
                          "to the base model's parameters; each term wins ΔBIC 20 and 5 %"}


def library(t_s: NDArray, model_deg: NDArray, ripple_hz: float | None = None,
            ripple_while_moving: bool = True) -> tuple[dict[str, NDArray], dict]:
    """The candidate functions at each frame, and the constants the equation names.

    ``model_deg`` is the base model's θ; ω (deg/s) and α (deg/s²) are its
    derivatives; the step starts at the model's first moving frame. A ripple at
    ``ripple_hz`` adds a sine and a cosine, zero outside the moving frames when
    ``ripple_while_moving``.
    """
    t = np.asarray(t_s, float)
    m = np.asarray(model_deg, float)
    omega, moving = model_motion(m, t)
    alpha = np.gradient(omega, t)
    first = int(np.argmax(moving)) if moving.any() else 0
    mean = float(m.mean())
    cols = {"offset": np.ones_like(t), "theta": m - mean, "theta^2": (m - mean) ** 2,
            "time": t - t[0]}
    if moving.any():
        cols.update({"after start": (np.arange(t.size) >= first).astype(float),
                     "omega": omega, "alpha": alpha})
        if np.unique(np.sign(omega[moving])).size > 1:  # reversals exist
            cols["sign(omega)"] = np.sign(omega)
    if ripple_hz:
        gate = moving if ripple_while_moving else np.ones_like(moving)
        cols["ripple sin"] = np.sin(2 * np.pi * ripple_hz * t) * gate
        cols["ripple cos"] = np.cos(2 * np.pi * ripple_hz * t) * gate
    consts = {"t0": float(t[first]), "mean": mean, "t_first": float(t[0]),
              "ripple_hz": ripple_hz, "while_moving": ripple_while_moving}
    return cols, consts


def _elimination_path(X: NDArray, y: NDArray) -> list[tuple[int, ...]]:
    """Supports (kept columns) from all of ``X``'s columns down to one, each step
    dropping the column whose loss costs the least fit: PySINDy's stepwise sparse
    regression (SSR, "model_residual"), a greedy best-subset path."""
    import pysindy as ps  # ~1 s to import: only when something is unexplained

    opt = ps.SSR(alpha=1e-9, max_iter=X.shape[1], criteria="model_residual", unbias=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        opt.fit(X, y)
    path = {tuple(int(i) for i in np.flatnonzero(np.ravel(c))) for c in opt.history_}
    path.discard(())
    return sorted(path, key=len)


def discover(t_s: NDArray, residual_deg: NDArray, model_deg: NDArray, noise_deg: float,
             base_jacobian: NDArray | None = None, ripple_hz: float | None = None,
             ripple_while_moving: bool = True) -> Discovery | None:
    """The shortest equation for the residual whose every term earns its place, or None.

    ``residual_deg`` is measured − model θ (deg) of the base fit, ``model_deg``
    its θ, ``noise_deg`` the tracker's σ of θ; ``base_jacobian`` (frames × free
    base parameters, any units) the base fit's sensitivities, projected out of
    both sides. Going along the elimination path from one term up, a term is
    added only while it wins :data:`BIC_THRESHOLD` and takes at least
    :data:`MIN_SHARE` of the residual's sum of squares: a proposal is for a person
    to read, and a tenth term that shaves 1 % off a large residual says nothing.
    None when no single term passes.
    """
    r = np.asarray(residual_deg, float)
    q = (np.linalg.qr(np.asarray(base_jacobian, float))[0]
         if base_jacobian is not None and base_jacobian.size else np.zeros((r.size, 0)))

    def beyond_base(a: NDArray) -> NDArray:  # what base parameters can mimic is theirs
        return a - q @ (q.T @ a)

    cols, consts = library(t_s, model_deg, ripple_hz, ripple_while_moving)
    names = list(cols)
    raw = np.column_stack([cols[k] for k in names])
    X, r = beyond_base(raw), beyond_base(r)
    scale = np.sqrt(np.mean(X**2, axis=0))
    # A term the base parameters mimic almost wholly (an offset, with the rest angle
    # free) is theirs: what is left of it is a sliver whose coefficient means nothing.
    keep = scale > MIMICKED * np.sqrt(np.mean(raw**2, axis=0))
    names = [n for n, k in zip(names, keep, strict=True) if k]
    X, scale = X[:, keep] / scale[keep], scale[keep]
    sigma = max(float(noise_deg), 1e-12)
    y = r / sigma
    rss0 = float(y @ y)
    chosen, last_rss, total_dbic = None, rss0, 0.0
    for support in _elimination_path(X, y):
        if chosen is not None and len(support) != len(chosen[0]) + 1:
            continue
        if np.linalg.cond(X[:, support]) > MAX_CONDITION:
            break  # terms that nearly cancel each other: their coefficients mean nothing
        coef, *_ = np.linalg.lstsq(X[:, support], y, rcond=None)
        rest = y - X[:, support] @ coef
        rss = float(rest @ rest)
        # Independent frames of what is left, as the loop's BIC counts them.
        n_eff = effective_samples(rest)
        dbic = (last_rss - rss) * n_eff / y.size - np.log(n_eff)
        if dbic <= BIC_THRESHOLD or last_rss - rss < MIN_SHARE * rss0:
            break
        chosen, last_rss, total_dbic = (support, coef, rest), rss, total_dbic + dbic
    if chosen is None:
        return None
    support, coef, rest = chosen
    terms = {names[i]: float(c * sigma / scale[i]) for i, c in zip(support, coef, strict=True)}
    return Discovery(terms, equation(terms, consts), float(np.sqrt(np.mean(r**2))),
                     float(sigma * np.sqrt(np.mean(rest**2))), float(total_dbic), ripple_hz)


def equation(terms: dict[str, float], consts: dict) -> str:
    """The kept terms as one line: ``missing θ ≈ …`` (deg)."""
    parts = []
    sin, cos = terms.get("ripple sin", 0.0), terms.get("ripple cos", 0.0)
    for name, c in terms.items():
        if name.startswith("ripple"):
            continue
        parts.append(TERMS[name].format(c=f"{c:+.3g}", **consts))
    if sin or cos:
        amp, phase = float(np.hypot(sin, cos)), float(np.degrees(np.arctan2(cos, sin)))
        gate = "·[while moving]" if consts["while_moving"] else ""
        parts.append(f"{amp:+.3g}°·sin(2π·{consts['ripple_hz']:.3g} Hz·t {phase:+.0f}°){gate}")
    return "missing θ ≈ " + " ".join(parts)
