"""A body in free flight: its g from a parabola, and the effect a parabola lacks.

A ball tossed or dropped before a ruler flies a parabola in the plane of its flight:
constant acceleration, g. What a camera and the air add bends that parabola, and the
fit's residual then has a shape rather than noise. Each candidate effect here is one
more parameter (or two) on the parabola:

- ``rolling shutter``: the camera reads its rows one after another, so a fix in row
  y was taken ρ·y after the frame's time (``ρ·height`` is the readout).
- ``linear drag``: a pull against the velocity, ``a − b·v`` with b ≥ 0 (slow, small
  bodies).
- ``quadratic drag``: ``a − k·|v|·v`` with k ≥ 0 (a ball through air at speed).
- ``tilted plane``: a flight in a plane turned towards or away from the camera is
  nearer it on one side, so a pinhole sees the place P as P_m + (P − P_m) / (1 +
  h·(P − P_m)), P_m the place at the flight's middle (two more, h). The ruler's scale
  is taken to hold there, the same assumption the parabola makes everywhere, so g is
  read at the flight's middle.

The effects compose: each is a change to the time (the shutter), the motion (the
drags, together by RK4) or the view (the tilt). They are taken one at a time, the one
that explains most first, while each lowers the BIC by more than
:data:`.evidence.BIC_THRESHOLD` (:func:`.evidence.effects_in_turn`); the noise is what
the closest fit leaves (never below the tracker's σ), correlated fixes counted once per
independent stretch (:func:`.evidence.effective_samples`), and those within
:data:`.evidence.LOOK_ALIKE_BIC` of an effect taken are named with it: that flight
cannot tell them apart.

All fits are made here with ``scipy.optimize.least_squares``; the tests draw their
flights from the equations above, written in the tests.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..calibration.readout import flight_fixes
from .evidence import (
    EffectFit,
    EffectLoop,
    combined,
    effects_in_turn,
    on_the_way,
    rounds_text,
)

#: Fewest fixes of a flight: the parabola's six parameters, a candidate's two and a few
#: to judge them by.
MIN_FIXES = 10

#: Sub-steps per frame interval when a quadratic drag's flight is integrated (RK4).
DRAG_SUBSTEPS = 4


@dataclass(frozen=True)
class FlightFit(EffectFit):
    """One model fitted to a flight (:class:`.evidence.EffectFit`; values in mm, s): g
    and its 1-σ (mm/s²), the residual (n, 2) mm and the number of parameters."""

    g_mm_s2: float
    g_sigma_mm_s2: float
    residual: NDArray[np.float64] = field(repr=False)
    parameters: int

    @property
    def rms_mm(self) -> float:
        """RMS per axis, mm."""
        return self.rms

    def to_dict(self) -> dict:
        return {"values": self.values, "g_mm_s2": self.g_mm_s2,
                "g_sigma_mm_s2": self.g_sigma_mm_s2, "rms_mm": self.rms_mm,
                "parameters": self.parameters}


class FlightLoop(EffectLoop):
    """What the loop found on a flight (:class:`.evidence.EffectLoop`; the noise in mm
    per axis, the samples its fixes)."""


#: The effects tried, and the names of their parameters among a fit's values.
EFFECTS: dict[str, tuple[str, ...]] = {"rolling shutter": ("readout_ms",),
                                       "linear drag": ("b_per_s",),
                                       "quadratic drag": ("k_per_mm",),
                                       "tilted plane": ("hx_per_m", "hy_per_m")}


def _quadratic(tc: NDArray, p: NDArray) -> NDArray:
    """p = (x0, y0, vx, vy, ax, ay): positions (n, 2) at centred times ``tc``."""
    return np.c_[p[0] + p[2] * tc + 0.5 * p[4] * tc**2, p[1] + p[3] * tc + 0.5 * p[5] * tc**2]


def _linear_drag(tc: NDArray, p: NDArray, b: float) -> NDArray:
    """p = (x0, y0, vx, vy, ax, ay) at tc = 0: dv/dt = a − b·v, solved exactly."""
    a, v0 = p[4:6], p[2:4]
    if b == 0:
        return _quadratic(tc, p)
    # Expanded near b = 0 through expm1, so a weak drag keeps its precision.
    decay = -np.expm1(-b * tc)  # 1 − e^{−b·t}
    drift = (tc - decay / b) / b  # (t − (1 − e^{−bt})/b)/b → t²/2 as b → 0
    return np.c_[p[0] + v0[0] * decay / b + a[0] * drift, p[1] + v0[1] * decay / b + a[1] * drift]


@njit(cache=True, nogil=True)
def _dragged_compiled(tc: NDArray, p: NDArray, b: float, k: float, substeps: int
                      ) -> NDArray:  # pragma: no cover - compiled
    out = np.empty((tc.size, 2))
    start = int(np.argmin(np.abs(tc)))
    for direction in (1, -1):
        x0, x1, v0, v1, t = p[0], p[1], p[2], p[3], 0.0
        i = start
        while 0 <= i < tc.size:
            h = (tc[i] - t) / substeps
            for _ in range(substeps):
                # RK4 on (x, v) with dv/dt = a − b·v − k·|v|·v.
                s = np.hypot(v0, v1)
                a0, a1 = p[4] - (b + k * s) * v0, p[5] - (b + k * s) * v1
                w0, w1 = v0 + 0.5 * h * a0, v1 + 0.5 * h * a1
                s = np.hypot(w0, w1)
                b0, b1 = p[4] - (b + k * s) * w0, p[5] - (b + k * s) * w1
                u0, u1 = v0 + 0.5 * h * b0, v1 + 0.5 * h * b1
                s = np.hypot(u0, u1)
                c0, c1 = p[4] - (b + k * s) * u0, p[5] - (b + k * s) * u1
                z0, z1 = v0 + h * c0, v1 + h * c1
                s = np.hypot(z0, z1)
                d0, d1 = p[4] - (b + k * s) * z0, p[5] - (b + k * s) * z1
                x0 += h / 6 * (v0 + 2 * w0 + 2 * u0 + z0)
                x1 += h / 6 * (v1 + 2 * w1 + 2 * u1 + z1)
                v0 += h / 6 * (a0 + 2 * b0 + 2 * c0 + d0)
                v1 += h / 6 * (a1 + 2 * b1 + 2 * c1 + d1)
            t = tc[i]
            out[i, 0], out[i, 1] = x0, x1
            i += direction
    return out


def _dragged(tc: NDArray, p: NDArray, b: float, k: float) -> NDArray:
    """p = (x0, y0, vx, vy, ax, ay) at tc = 0: dv/dt = a − b·v − k·|v|·v, by RK4
    (:data:`DRAG_SUBSTEPS` steps between fixes) from the middle of the flight outwards,
    to each fix's time in whatever order they come. Compiled: a least-squares fit runs
    it hundreds of times."""
    return _dragged_compiled(np.ascontiguousarray(tc, dtype=np.float64),
                             np.ascontiguousarray(p[:6], dtype=np.float64), float(b), float(k),
                             DRAG_SUBSTEPS)


def _flight(tc: NDArray, p: NDArray, on: tuple[str, ...], share: NDArray) -> NDArray:
    """p = the parabola's six (at tc = 0), then each effect's parameters in ``on``'s
    order: the places (n, 2) mm seen at centred frame times ``tc`` (s), ``share`` each
    fix's row over the frame's height (for the shutter)."""
    got = dict(zip([k for e in on for k in EFFECTS[e]], p[6:], strict=True))
    t = tc + 1e-3 * got.get("readout_ms", 0.0) * share
    b, k = got.get("b_per_s", 0.0), got.get("k_per_mm", 0.0)
    seen = _dragged(t, p, b, k) if k else _linear_drag(t, p, b)
    if "tilted plane" in on:
        h = 1e-3 * np.array([got["hx_per_m"], got["hy_per_m"]])
        d = seen - p[0:2]
        seen = p[0:2] + d / (1.0 + d @ h)[:, None]
    return seen


def _g(values: NDArray, cov: NDArray, ia: int = 4) -> tuple[float, float]:
    """|a| (mm/s²) from the values' entries ``ia``, ``ia + 1``, and its 1-σ."""
    a = values[ia:ia + 2]
    g = float(np.hypot(*a))
    grad = a / g if g > 0 else np.zeros(2)
    return g, float(np.sqrt(max(grad @ cov[ia:ia + 2, ia:ia + 2] @ grad, 0.0)))


def solve_model(model: Callable[[NDArray], NDArray], xy: NDArray, start: NDArray,
           bounds: tuple = (-np.inf, np.inf)) -> tuple[NDArray, NDArray, NDArray]:
    """Least squares of ``model(p) − xy``: the values, the residual and (JᵀJ)⁻¹."""
    fit = least_squares(lambda p: (model(p) - xy).ravel(), start, bounds=bounds,
                        x_scale="jac")
    # A parameter held at its bound (a drag of 0) is fixed there: the covariance is that
    # of the others.
    free = fit.active_mask == 0
    cov = np.zeros((start.size, start.size))
    jac = fit.jac[:, free]
    cov[np.ix_(free, free)] = np.linalg.pinv(jac.T @ jac)
    return fit.x, xy - model(fit.x), cov


def fit_flight(t_s: NDArray, xy_mm: NDArray, row_px: NDArray, height_px: int,
               sigma_mm: float = 0.0, scale_sigma: float = 0.0) -> FlightLoop:
    """Fit a free flight and close the loop on it.

    ``t_s`` (n,) frame times, s; ``xy_mm`` (n, 2) the body's place in the plane, mm
    (y up); ``row_px`` (n,) the image row it was seen in (for the rolling shutter);
    ``height_px`` the frame's rows; ``sigma_mm`` the tracker's per-axis σ, the floor
    of the noise; ``scale_sigma`` the calibration's relative 1-σ, which every g shares
    (added to g's σ: a ruler's ends placed to half a pixel).

    Raises
    ------
    CranktrackError
        Fewer than :data:`MIN_FIXES` fixes, or times that do not advance.
    """
    t, xy, rows = flight_fixes(t_s, xy_mm, MIN_FIXES, "a fit", row_px)
    tc = t - t.mean()
    step = float(np.median(np.diff(t)))
    X = np.vander(tc, 3)
    c = np.linalg.lstsq(X, xy, rcond=None)[0]  # rows: t², t, 1
    start = np.r_[c[2], c[1], 2 * c[0]]

    share = rows / max(height_px, 1)
    # The readout in ms over the frame's rows (a parameter of order one, so that the
    # finite differences of its Jacobian are sound), within one frame interval. A drag
    # pulls against the motion: b, k ≥ 0 (on Tracker's toss, left free, both went
    # negative, a push, to mimic the bend a tilted plane gives), started off zero: at 0
    # the model is the parabola itself, flat in them.
    reach = 1e3 * step
    bounds = {"readout_ms": (-reach, reach), "b_per_s": (0.0, np.inf),
              "k_per_mm": (0.0, np.inf)}
    first = {"readout_ms": 0.0, "b_per_s": 1e-2, "k_per_mm": 1e-8, "hx_per_m": 0.0,
             "hy_per_m": 0.0}
    base_keys = ("x0_mm", "y0_mm", "vx_mm_s", "vy_mm_s", "ax_mm_s2", "ay_mm_s2")
    fits: dict[tuple[str, ...], FlightFit] = {}

    def fit(on: tuple[str, ...]) -> tuple[NDArray, int]:
        keys = [k for e in on for k in EFFECTS[e]]
        # Started where the fit with one effect fewer ended.
        p0 = (np.r_[list(fits[on[:-1]].values.values()), [first[k] for k in EFFECTS[on[-1]]]]
              if on else start)
        low = np.r_[np.full(6, -np.inf), [bounds.get(k, (-np.inf,))[0] for k in keys]]
        high = np.r_[np.full(6, np.inf), [bounds.get(k, (0, np.inf))[1] for k in keys]]
        values, residual, unit_cov = solve_model(lambda p: _flight(tc, p, on, share), xy, p0,
                                                 (low, high))
        g, g_unit = _g(values, unit_cov)
        fits[on] = FlightFit(combined(on) or "parabola",
                             dict(zip((*base_keys, *keys), map(float, values), strict=True)),
                             g, g_unit, residual, len(values))
        return residual, len(values)

    verdict = effects_in_turn(fit, tuple(EFFECTS), sigma_mm)

    def judged(f: FlightFit) -> FlightFit:
        """``f`` with g's σ under that noise, and the scale's."""
        sigma = np.hypot(f.g_sigma_mm_s2 * verdict.factor(f.residual, f.parameters),
                         f.g_mm_s2 * scale_sigma)
        return replace(f, g_sigma_mm_s2=float(sigma))

    return FlightLoop.judged(judged(fits[()]),
                             {combined(k): judged(fits[k])
                              for k in on_the_way(list(fits), verdict.taken)},
                             verdict, len(t), verdict.n_eff / 2, sigma_mm)


def flight_text(loop: FlightLoop, marker: str) -> str:
    """The loop's result for a person: g before and after, each round's candidates and
    ΔBIC."""
    b = loop.base
    lines = [f"{marker} in free flight: {loop.samples} fixes ({loop.independent:.0f} "
             f"independent), noise {loop.noise:.3g} mm per axis",
             f"parabola: g = {b.g_mm_s2 / 1e3:.4f} ± {b.g_sigma_mm_s2 / 1e3:.4f} m/s², "
             f"residual {b.rms_mm:.3g} mm RMS"]
    rounds, left = rounds_text(
        loop, "residual (mm)  g (m/s²)",
        lambda f: f"{f.rms_mm:13.3g}  {f.g_mm_s2 / 1e3:.4f} ± {f.g_sigma_mm_s2 / 1e3:.4f}",
        "the flight", "mm", "the parabola",
        lambda f: f"g = {f.g_mm_s2 / 1e3:.4f} ± {f.g_sigma_mm_s2 / 1e3:.4f} m/s²")
    lines += rounds
    if loop.accepted is not None:
        f = loop.final
        if "readout_ms" in f.values:
            lines.append(f"a readout of {f.values['readout_ms']:.2f} ms over the frame's rows")
        if "hx_per_m" in f.values:
            lines.append("the flight's plane is turned to the camera: g is read where the "
                         "flight is at its middle, and the ruler's scale is taken to hold "
                         "there")
        if loop.look_alikes:
            lines.append("so g is not settled: the look-alikes above give "
                         + ", ".join(f"{loop.candidates[k].g_mm_s2 / 1e3:.4f}"
                                     for k in loop.look_alikes) + " m/s²")
    return "\n".join(lines + left)
