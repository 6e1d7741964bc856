"""A pendulum's swing: its period (and g, given the string's length), and the effect a
damped sinusoid lacks.

A bob on a string, filmed from the front, moves sideways as a damped sinusoid,

    x(t) = c + A·e^{−γt}·cos(ωt + φ),

whose period 2π/ω is the lab's figure: with the string's length L it gives
g = L·(ω² + γ²) (the undamped rate from the damped one) for a small swing. What the
sinusoid lacks bends its residual; each candidate here is one more parameter:

- ``quadratic drag``: air at the bob's speed takes amplitude in proportion to it, so
  the envelope falls as ``A·e^{−γt} / (1 + κ·A·(1 − e^{−γt})/γ)`` rather than as an
  exponential alone;
- ``large swing``: a pendulum is slower the wider it swings, ω(A) = ω₀·(1 − β·A²),
  with β = 1/(16 L²) for a point bob on a string of length L, so the rate rises as
  the swing dies down;
- ``drift``: the stand or the camera moves, c + d·t.
- ``turned plane``: a swing in a plane turned about the vertical by α is nearer the
  camera on one side: a pinhole sees its place u as u / (1 + τ·u), τ = tan α / f (f
  the focal length in the track's unit), so one side of the swing looks wider than
  the other by the factor (1 + τA) / (1 − τA);
- ``elliptical swing``: a bob that also swings towards and away from the camera, a
  quarter period on (a spherical pendulum's ellipse), is seen as u / (1 + μ·q), q the
  place a quarter period on; μ·A is the ellipse's narrow width over the camera's
  distance.

The last two bend the sinusoid at twice its rate; the first three, slowly. A real
swing can do several at once (Tracker's pendulum clip: a turned plane and an ellipse),
so effects are taken one at a time while each lowers the BIC by more than
:data:`.evidence.BIC_THRESHOLD` (:func:`.evidence.effects_in_turn`). The noise is what
the closest fit leaves (never below the tracker's σ), correlated samples count once per
independent stretch, and those within :data:`.evidence.LOOK_ALIKE_BIC` of an effect
taken are named with it. With a large swing taken, the period and g are the small
swing's (β's ω₀). Everything is fitted here with
``scipy.optimize.least_squares``; the tests draw their swings by integrating the
pendulum's equation of motion in the test.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from scipy.special import ellipk

from ..errors import CranktrackError
from ..tracker.outline import fit_circle
from .evidence import (
    EffectFit,
    EffectLoop,
    combined,
    effects_in_turn,
    on_the_way,
    rounds_text,
)
from .flight import solve_model

#: Fewest samples of a swing: two periods at a few frames each, at the least.
MIN_SAMPLES = 20


@dataclass(frozen=True)
class SwingFit(EffectFit):
    """One model fitted to a swing (:class:`.evidence.EffectFit`; values in the track's
    unit, s): the period (s) and its 1-σ, the residual and the number of parameters."""

    period_s: float
    period_sigma_s: float
    residual: NDArray[np.float64] = field(repr=False)
    parameters: int
    #: The swing's amplitude at each sample (the track's unit), for the period of a wide
    #: swing.
    envelope: NDArray[np.float64] = field(repr=False, default_factory=lambda: np.empty(0))

    def to_dict(self) -> dict:
        return {"values": self.values, "period_s": self.period_s,
                "period_sigma_s": self.period_sigma_s, "rms": self.rms,
                "parameters": self.parameters}

    def g(self, length: float) -> tuple[float, float]:
        """g (the track's unit per s², with ``length`` in that unit) and its 1-σ.

        A swing of angle θ is slower than a small one by (2/π)·K(sin²(θ/2)); the
        fitted rate is the mean over the swing's samples, so it is taken back to a
        small swing's by the mean of that factor over them (θ from the envelope and
        the length: sideways amplitude = L·sin θ). The ``large swing`` model fits the
        small swing's rate itself. Then ω₀² = ω² + γ² (the undamped rate) times the
        length."""
        w = 2 * np.pi / self.period_s
        if "large swing" not in self.effect.split(" + ") and self.envelope.size:
            theta = np.arcsin(np.clip(np.abs(self.envelope) / length, 0.0, 1.0))
            w *= float(np.mean(2.0 / np.pi * ellipk(np.sin(theta / 2) ** 2)))
        gamma = self.values.get("gamma_per_s", 0.0)
        g = length * (w**2 + gamma**2)
        return float(g), float(length * 2 * w * w * self.period_sigma_s / self.period_s)


class SwingLoop(EffectLoop):
    """What the loop found on a swing (:class:`.evidence.EffectLoop`)."""


def _envelope(t: NDArray, a: float, gamma: float, kappa: float = 0.0) -> NDArray:
    """The amplitude at ``t``: ``a·e^{−γt}``, divided by ``1 + κ·a·(1 − e^{−γt})/γ``
    under a quadratic drag (``κ·a·t`` as γ → 0)."""
    decay = np.exp(-gamma * t)
    spent = t if abs(gamma) < 1e-12 else -np.expm1(-gamma * t) / gamma
    return a * decay / (1.0 + kappa * a * spent)


#: The effects tried, each one more parameter on the damped sinusoid, and the name of
#: that parameter among a fit's values.
EFFECTS: dict[str, str] = {"quadratic drag": "kappa", "large swing": "beta",
                           "drift": "drift_per_s", "turned plane": "turn_per_unit",
                           "elliptical swing": "across_per_unit"}


def _swing(t: NDArray, p: NDArray, kappa: float = 0.0, beta: float = 0.0,
           drift: float = 0.0, turn: float = 0.0, across: float = 0.0) -> NDArray:
    """p = (c, A, γ, ω, φ): the sideways place at ``t`` (s from the first sample). With
    ``beta`` the rate follows the envelope, ω·(1 − β·A(t)²), and the phase is its
    integral (trapezoids over the samples). The place in the swing's plane, u, is seen
    as u / (1 + turn·u + across·q), q the quarter-period-on place A(t)·sin(phase): the
    depth a plane turned to the camera and a swing across it (an ellipse) add."""
    c, a, gamma, w, phi = p[:5]
    amp = _envelope(t, a, gamma, kappa)
    if beta:
        rate = w * (1.0 - beta * amp**2)
        phase = np.r_[0.0, np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))]
    else:
        phase = w * t
    u = amp * np.cos(phase + phi)
    if turn or across:
        u = u / (1.0 + turn * u + across * amp * np.sin(phase + phi))
    return c + drift * t + u


def _start(t: NDArray, x: NDArray) -> NDArray:
    """(c, A, γ, ω, φ) to start from: the strongest frequency of the samples on an even
    grid, its amplitude and phase by linear least squares, no damping."""
    step = float(np.median(np.diff(t)))
    grid = np.arange(t[0], t[-1], step)
    xs = np.interp(grid, t, x) - np.mean(x)
    spectrum = np.abs(np.fft.rfft(xs * np.hanning(len(xs))))
    freqs = np.fft.rfftfreq(len(xs), step)
    k = int(np.argmax(spectrum[1:]) + 1)
    w = 2 * np.pi * freqs[k]
    M = np.c_[np.ones_like(t), np.cos(w * t), np.sin(w * t)]
    c, a, b = np.linalg.lstsq(M, x, rcond=None)[0]
    return np.array([c, np.hypot(a, b), 0.0, w, np.arctan2(-b, a)])


#: With the string's length L known, a ``large swing``'s β is held within the β of a
#: string this many times longer and shorter than L: β = 1/(16 L²) is geometry, not a
#: free slope. On a real clip (bartekpacia/pendulum) a free β took a 0.3 % rise of the
#: rate over 30 s, as the swing narrowed by 15 %, for a swing on a 153 px string, where
#: the bob's path is an arc of 650 px (774 px on today's tracks, the rim's circle held
#: at its learned radius): its small-swing period came out 1.6 % short of the
#: sinusoid's, and g 3 % above it.
LENGTH_BAND = 1.5


#: The bob's path is taken for an arc about a pivot when the circle through it has a
#: radius whose 1-σ is under this share of it.
ARC_RADIUS_REL_SIGMA = 0.2


def arc_radius(xy: NDArray) -> float | None:
    """The radius (px) of the circle through a bob's path ``xy`` (n, 2 px), or None where
    the path is too straight or short for one (its radius's σ over
    :data:`ARC_RADIUS_REL_SIGMA` of it, or the centre below the path: a pivot hangs
    above its bob, image y down)."""
    p, cov, _ = fit_circle(xy)
    if not (np.all(np.isfinite(p)) and np.isfinite(cov[2, 2]) and p[2] > 0):
        return None
    if np.sqrt(max(cov[2, 2], 0.0)) > ARC_RADIUS_REL_SIGMA * p[2] or p[1] > np.mean(xy[:, 1]):
        return None
    return float(p[2])


def fit_swing(t_s: NDArray, x: NDArray, sigma: float = 0.0, length: float | None = None
              ) -> SwingLoop:
    """Fit a pendulum's sideways track ``x`` (any length unit; NaN: not found) at times
    ``t_s`` (s) and close the loop on it; ``sigma`` is the tracker's σ in ``x``'s unit,
    the floor of the noise. Effects are taken one at a time, the one that explains most
    first (:func:`.evidence.effects_in_turn`): a real swing can turn its plane to the
    camera and swing across it at once. ``length``: the string's length in ``x``'s unit
    (pivot to bob) where it is known, which bounds a wide swing's β
    (:data:`LENGTH_BAND`).

    Raises
    ------
    CranktrackError
        Fewer than :data:`MIN_SAMPLES` samples, times that do not advance, or no swing
        to find (under two periods in the samples).
    """
    t = np.asarray(t_s, float)
    xv = np.asarray(x, float)
    ok = np.isfinite(t) & np.isfinite(xv)
    t, xv = t[ok], xv[ok]
    if len(t) < MIN_SAMPLES:
        raise CranktrackError(f"only {len(t)} samples of the swing; a fit needs at least "
                              f"{MIN_SAMPLES}")
    if not np.all(np.diff(t) > 0):
        raise CranktrackError("the samples' times do not advance from frame to frame")
    t = t - t[0]
    p0 = _start(t, xv)
    if length is not None and not (np.isfinite(length) and length > 0):
        raise CranktrackError(f"a string of length {length:g} is not a positive length")
    if not 2 * 2 * np.pi / p0[3] <= t[-1]:
        raise CranktrackError(f"the track spans {t[-1]:.3g} s, under two swings of the "
                              f"{2 * np.pi / p0[3]:.3g} s it seems to have; track longer")
    keys = ("c", "amplitude", "gamma_per_s", "omega_rad_s", "phase_rad")
    arguments = dict(zip(EFFECTS, ("kappa", "beta", "drift", "turn", "across"), strict=True))
    fits: dict[tuple[str, ...], SwingFit] = {}

    def fit(on: tuple[str, ...]) -> tuple[NDArray, int]:
        # Started where the fit with one effect fewer ended (the sinusoid's start for
        # the base); a new effect from nothing, a drag from just above its bound of 0.
        start = (p0 if not on else
                 np.r_[list(fits[on[:-1]].values.values()),
                       1e-6 if on[-1] == "quadratic drag" else 0.0])
        low, high = np.full(start.size, -np.inf), np.full(start.size, np.inf)
        if "quadratic drag" in on:
            low[5 + on.index("quadratic drag")] = 0.0
        if "large swing" in on and length is not None:
            i = 5 + on.index("large swing")
            low[i], high[i] = (1.0 / (16.0 * (f * length) ** 2)
                               for f in (LENGTH_BAND, 1.0 / LENGTH_BAND))
            start[i] = np.clip(start[i], low[i], high[i]) if start[i] else \
                1.0 / (16.0 * length**2)

        def model(p: NDArray) -> NDArray:
            return _swing(t, p[:5], **{arguments[e]: v for e, v in zip(on, p[5:],
                                                                        strict=True)})[:, None]

        values, residual, cov = solve_model(model, xv[:, None], start, (low, high))
        w, sw = values[3], np.sqrt(max(cov[3, 3], 0.0))
        kappa = values[5 + on.index("quadratic drag")] if "quadratic drag" in on else 0.0
        fits[on] = SwingFit(combined(on) or "damped",
                            dict(zip((*keys, *(EFFECTS[e] for e in on)),
                                     map(float, values), strict=True)),
                            float(2 * np.pi / w), float(2 * np.pi * sw / w**2),
                            residual[:, 0], len(values),
                            _envelope(t, values[1], values[2], kappa))
        return fits[on].residual, fits[on].parameters

    verdict = effects_in_turn(fit, tuple(EFFECTS), sigma)

    def judged(f: SwingFit) -> SwingFit:
        return replace(f, period_sigma_s=f.period_sigma_s
                       * verdict.factor(f.residual, f.parameters))

    return SwingLoop.judged(judged(fits[()]), {combined(k): judged(fits[k])
                                               for k in on_the_way(list(fits), verdict.taken)},
                            verdict, len(t), verdict.n_eff, sigma)


def effect_said(f: SwingFit) -> str:
    """What a fit's shape effects say of the swing in words ("" for the others): how
    much wider one side looks (a turned plane), and the ellipse's width over the
    camera's distance."""
    a, said = abs(f.values["amplitude"]), []
    turn = f.values.get(EFFECTS["turned plane"])
    if turn is not None and abs(turn * a) < 1:
        wider = (1 + abs(turn) * a) / (1 - abs(turn) * a) - 1
        said.append(f"one side of the swing looks {100 * wider:.1f} % wider than the other")
    across = f.values.get(EFFECTS["elliptical swing"])
    if across is not None:
        said.append(f"it swings across by {100 * abs(across) * a:.2g} % of the camera's "
                    "distance")
    return "; ".join(said)


def swing_text(loop: SwingLoop, marker: str, unit: str, length_mm: float | None = None
               ) -> str:
    """The loop's result for a person: the period (and g, with the string's length in
    mm) before and after, each round's candidates and ΔBIC; ``unit`` is the track's."""
    def g_of(f: SwingFit) -> str:
        if length_mm is None:
            return ""
        g, s = f.g(length_mm)
        return f", g = {g / 1e3:.4f} ± {s / 1e3:.4f} m/s²"

    b = loop.base
    lines = [f"{marker} swinging: {loop.samples} samples ({loop.independent:.0f} "
             f"independent), noise {loop.noise:.3g} {unit}"
             + ("" if length_mm is None or b.envelope.size else
                "; with no scale or arc its width is not known, so g is a small "
                "swing's"),
             f"damped sinusoid: period {b.period_s:.5f} ± {b.period_sigma_s:.5f} s"
             f"{g_of(b)}, residual {b.rms:.3g} {unit} RMS"]
    rounds, left = rounds_text(
        loop, "residual  period (s)",
        lambda f: f"{f.rms:8.3g}  {f.period_s:.5f} ± {f.period_sigma_s:.5f}{g_of(f)}",
        "the swing", unit, "the damped sinusoid",
        lambda f: f"period {f.period_s:.5f} ± {f.period_sigma_s:.5f} s{g_of(f)}")
    lines += rounds
    if loop.accepted is not None and effect_said(loop.final):
        lines.append(effect_said(loop.final))
    return "\n".join(lines + left)
