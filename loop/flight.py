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
- ``tilted plane``: a flight in a plane turned towards or away from the camera is a
  parabola seen through a homography (both axes over one shared quadratic); its g
  cannot be read without the tilt, so it only says the bend is perspective's.

The base fit's residual sets the noise (never below the tracker's σ) and how many of
the fixes are independent (:func:`.evidence.effective_samples`); a candidate is
accepted when it lowers the BIC by more than :data:`.evidence.BIC_THRESHOLD`, and
candidates within :data:`.evidence.LOOK_ALIKE_BIC` of the best are named with it: one
flight cannot tell them apart. One effect is added at most.

All fits are made here with ``scipy.optimize.least_squares``; the tests draw their
flights from the equations above, written in the tests.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..calibration.readout import flight_fixes
from .evidence import BIC_THRESHOLD, LOOK_ALIKE_BIC, EffectLoop, one_effect, rounds_text

#: Fewest fixes of a flight: the parabola's six parameters, a candidate's two and a few
#: to judge them by.
MIN_FIXES = 10

#: Sub-steps per frame interval when a quadratic drag's flight is integrated (RK4).
DRAG_SUBSTEPS = 4


@dataclass(frozen=True)
class FlightFit:
    """One model fitted to a flight: its name, values (mm, s), the 1-σ of g (mm/s², NaN
    where the model has no g), the residual (n, 2) mm and the number of parameters."""

    effect: str
    values: dict[str, float]
    g_mm_s2: float
    g_sigma_mm_s2: float
    residual: NDArray[np.float64] = field(repr=False)
    parameters: int

    @property
    def rss(self) -> float:
        return float(np.sum(self.residual**2))

    @property
    def rms_mm(self) -> float:
        """RMS per axis, mm."""
        return float(np.sqrt(np.mean(self.residual**2)))

    def to_dict(self) -> dict:
        return {"values": self.values, "g_mm_s2": self.g_mm_s2,
                "g_sigma_mm_s2": self.g_sigma_mm_s2, "rms_mm": self.rms_mm,
                "parameters": self.parameters}


class FlightLoop(EffectLoop):
    """What the loop found on a flight (:class:`.evidence.EffectLoop`; the noise in mm
    per axis, the samples its fixes)."""


def _quadratic(tc: NDArray, p: NDArray) -> NDArray:
    """p = (x0, y0, vx, vy, ax, ay): positions (n, 2) at centred times ``tc``."""
    return np.c_[p[0] + p[2] * tc + 0.5 * p[4] * tc**2, p[1] + p[3] * tc + 0.5 * p[5] * tc**2]


def _linear_drag(tc: NDArray, p: NDArray) -> NDArray:
    """p = (x0, y0, vx, vy, ax, ay, b) at tc = 0: dv/dt = a − b·v, solved exactly."""
    a, v0, b = p[4:6], p[2:4], p[6]
    if b == 0:
        return _quadratic(tc, p[:6])
    # Expanded near b = 0 through expm1, so a weak drag keeps its precision.
    decay = -np.expm1(-b * tc)  # 1 − e^{−b·t}
    drift = (tc - decay / b) / b  # (t − (1 − e^{−bt})/b)/b → t²/2 as b → 0
    return np.c_[p[0] + v0[0] * decay / b + a[0] * drift, p[1] + v0[1] * decay / b + a[1] * drift]


def _quadratic_drag(tc: NDArray, p: NDArray) -> NDArray:
    """p = (x0, y0, vx, vy, ax, ay, k) at tc = 0: dv/dt = a − k·|v|·v, by RK4 from the
    middle of the flight outwards."""
    a, k = p[4:6], p[6]

    def rate(v: NDArray) -> NDArray:
        return a - k * np.hypot(*v) * v

    out = np.empty((tc.size, 2))
    start = int(np.argmin(np.abs(tc)))
    for direction in (1, -1):
        x, v, t = np.array(p[0:2], float), np.array(p[2:4], float), 0.0
        # Carried from tc = 0 to the fix nearest it, then fix to fix.
        idx = range(start, tc.size) if direction > 0 else range(start, -1, -1)
        for i in idx:
            h = (tc[i] - t) / DRAG_SUBSTEPS
            for _ in range(DRAG_SUBSTEPS):
                k1v, k1x = rate(v), v
                k2v, k2x = rate(v + 0.5 * h * k1v), v + 0.5 * h * k1v
                k3v, k3x = rate(v + 0.5 * h * k2v), v + 0.5 * h * k2v
                k4v, k4x = rate(v + h * k3v), v + h * k3v
                x = x + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
                v = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
            t = tc[i]
            out[i] = x
    return out


def _tilted(tc: NDArray, p: NDArray) -> NDArray:
    """p = 3 + 3 quadratic coefficients over 1 + p6·t + p7·t²: a parabola in a plane
    seen through a homography."""
    r = 1.0 + p[6] * tc + p[7] * tc**2
    return np.c_[p[0] + p[1] * tc + p[2] * tc**2, p[3] + p[4] * tc + p[5] * tc**2] / r[:, None]


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

    fits: dict[str, FlightFit] = {}

    def add(name: str, model: Callable[[NDArray], NDArray], p0: NDArray, keys: tuple[str, ...],
            has_g: bool = True, bounds: tuple = (-np.inf, np.inf)) -> None:
        values, residual, unit_cov = solve_model(model, xy, p0, bounds)
        g, g_unit = _g(values, unit_cov) if has_g else (float("nan"), float("nan"))
        fits[name] = FlightFit(name, dict(zip(keys, map(float, values), strict=True)), g,
                               g_unit, residual, len(values))

    base_keys = ("x0_mm", "y0_mm", "vx_mm_s", "vy_mm_s", "ax_mm_s2", "ay_mm_s2")
    add("parabola", lambda p: _quadratic(tc, p), start, base_keys)
    # The readout in ms over the frame's rows (a parameter of order one, so that the
    # finite differences of its Jacobian are sound), within one frame interval.
    share = rows / max(height_px, 1)
    reach = 1e3 * step
    add("rolling shutter", lambda p: _quadratic(tc + 1e-3 * p[6] * share, p[:6]),
        np.r_[start, 0.0], (*base_keys, "readout_ms"),
        bounds=(np.r_[np.full(6, -np.inf), -reach], np.r_[np.full(6, np.inf), reach]))
    # A drag pulls against the motion: b, k ≥ 0 (on Tracker's toss, left free, both went
    # negative, a push, to mimic the bend a tilted plane gives). Started off zero: at
    # b = 0 the model is the parabola itself, flat in b.
    drag = (np.r_[np.full(6, -np.inf), 0.0], np.full(7, np.inf))
    add("linear drag", lambda p: _linear_drag(tc, p), np.r_[start, 1e-2],
        (*base_keys, "b_per_s"), bounds=drag)
    add("quadratic drag", lambda p: _quadratic_drag(tc, p), np.r_[start, 1e-8],
        (*base_keys, "k_per_mm"), bounds=drag)
    add("tilted plane", lambda p: _tilted(tc, p),
        np.r_[c[2, 0], c[1, 0], c[0, 0], c[2, 1], c[1, 1], c[0, 1], 0.0, 0.0],
        ("px0", "px1", "px2", "py0", "py1", "py2", "r1", "r2"), has_g=False)

    base = fits.pop("parabola")
    verdict = one_effect((base.residual, base.parameters),
                         {k: (f.residual, f.parameters) for k, f in fits.items()}, sigma_mm)

    def judged(f: FlightFit) -> FlightFit:
        """``f`` with g's σ under that noise, and the scale's."""
        sigma = np.hypot(f.g_sigma_mm_s2 * verdict.factor(f.residual, f.parameters),
                         f.g_mm_s2 * scale_sigma)
        return FlightFit(f.effect, f.values, f.g_mm_s2, float(sigma), f.residual,
                         f.parameters)

    return FlightLoop.judged(judged(base), {k: judged(f) for k, f in fits.items()},
                             verdict, len(t), verdict.n_eff / 2, sigma_mm)


def flight_text(loop: FlightLoop, marker: str) -> str:
    """The loop's result for a person: g before and after, each candidate's ΔBIC."""
    b = loop.base
    lines = [f"{marker} in free flight: {loop.samples} fixes ({loop.independent:.0f} "
             f"independent), noise {loop.noise:.3g} mm per axis",
             f"parabola: g = {b.g_mm_s2 / 1e3:.4f} ± {b.g_sigma_mm_s2 / 1e3:.4f} m/s², "
             f"residual {b.rms_mm:.3g} mm RMS",
             "candidate        ΔBIC    residual (mm)  g (m/s²)",
             "---------------  ------  -------------  ------------------"]
    for k, f in loop.candidates.items():
        g = ("(no g: needs the tilt)" if not np.isfinite(f.g_mm_s2)
             else f"{f.g_mm_s2 / 1e3:.4f} ± {f.g_sigma_mm_s2 / 1e3:.4f}")
        lines.append(f"{k:<15}  {loop.delta_bic[k]:6.1f}  {f.rms_mm:13.3g}  {g}")
    if loop.accepted is None:
        lines.append(f"no effect lowers the BIC by more than {BIC_THRESHOLD:g}: the parabola "
                     "is enough")
    else:
        f = loop.final
        said = f"accepted: {loop.accepted}"
        if loop.accepted == "rolling shutter":
            said += f" (a readout of {f.values['readout_ms']:.2f} ms)"
        lines.append(said + f"; residual {b.rms_mm:.3g} → {f.rms_mm:.3g} mm")
        if not np.isfinite(f.g_mm_s2):
            gs = [c.g_mm_s2 / 1e3 for c in loop.candidates.values() if np.isfinite(c.g_mm_s2)
                  and loop.delta_bic[c.effect] > BIC_THRESHOLD]
            if gs:
                lines.append(f"a tilted plane's g needs its tilt; the other effects accepted "
                             f"on their own give g = {min(gs):.4f}–{max(gs):.4f} m/s²")
        if loop.look_alikes:
            lines.append("but " + ", ".join(loop.look_alikes) + " explains the flight as "
                         f"well (ΔBIC within {LOOK_ALIKE_BIC:g}): this flight cannot tell them "
                         "apart, so its g is not settled")
    return "\n".join(lines + rounds_text(loop, lambda on, d: [], "the flight", "mm")[1])
