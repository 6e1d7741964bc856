"""A marker on a body turning about a fixed axis (a wheel, a turntable, an arm): its
rate, and the effects a steady turn lacks.

Seen square-on, a marker on a body turning at a steady rate ω runs round a circle,

    x = cx + R·cos θ(t),  y = cy + R·sin θ(t),  θ(t) = θ₀ + ω·t,

five parameters fitted to x and y together, t from the middle of the track (so that
ω is the rate there). ω needs no scale: a track in px gives it as well as one in mm.
What bends that circle, each one or two parameters more:

- ``steady torque``: dry friction, or a falling mass's pull, changes the rate at a
  constant α: θ = θ₀ + ω·t + α·t²/2;
- ``viscous drag``: a drag torque in proportion to the rate makes it fall as
  e^{−λ·t}: θ = θ₀ + ω·(1 − e^{−λ·t})/λ, with ω the rate at t = 0;
- ``tilted view``: the body's plane turned to the camera shortens the circle across
  one direction into an ellipse, p = c + R·(I + [[a, b], [b, −a]])·(cos θ, sin θ)
  (two parameters; the ellipse's narrow over wide axis is (1 − |(a, b)|) /
  (1 + |(a, b)|), the cosine of the tilt), while θ stays the body's own angle;
- ``moving axis``: the axle or the camera moves steadily, c + d·t (two).

The first two change the rate (a rate that changes is how a torque is measured); the
last two bend the circle. Effects are taken one at a time, the one that explains most
first, while each lowers the BIC by more than :data:`.evidence.BIC_THRESHOLD`
(:func:`.evidence.effects_in_turn`), with the noise what the closest fit leaves (never
below the tracker's σ) and correlated samples counted once per independent stretch.
Everything is fitted here with ``scipy.optimize.least_squares``; the tests draw their
turns by integrating a wheel's equation of motion in the test.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ..errors import CranktrackError
from .evidence import (
    EffectFit,
    EffectLoop,
    combined,
    effects_in_turn,
    on_the_way,
    rounds_text,
)
from .flight import solve_model

#: Fewest fixes of a turn: the circle's five parameters, two effects' and a few more.
MIN_FIXES = 12
#: Least angle (rad) the marker must sweep about the circle's centre: over less, the
#: circle's centre and radius, and with them the rate, are barely held by the fixes.
MIN_SWEEP_RAD = 0.5

#: The effects tried, and the names of their parameters among a fit's values.
EFFECTS: dict[str, tuple[str, ...]] = {
    "steady torque": ("alpha_rad_s2",),
    "viscous drag": ("lambda_per_s",),
    "tilted view": ("tilt_a", "tilt_b"),
    "moving axis": ("vx_per_s", "vy_per_s"),
}


@dataclass(frozen=True)
class RotationFit(EffectFit):
    """One model fitted to a turn (:class:`.evidence.EffectFit`; values in the track's
    unit, rad, s): the rate ω at the track's middle (rad/s, counterclockwise positive in
    the track's own axes) and its 1-σ, the residual (n, 2) in the track's unit and the
    number of parameters."""

    omega_rad_s: float
    omega_sigma_rad_s: float
    residual: NDArray[np.float64] = field(repr=False)
    parameters: int

    @property
    def narrow_over_wide(self) -> float:
        """The ellipse's narrow over wide axis (1: a circle, seen square-on); the
        cosine of the body plane's tilt to the camera."""
        m = float(np.hypot(self.values.get("tilt_a", 0.0), self.values.get("tilt_b", 0.0)))
        return (1 - m) / (1 + m) if m < 1 else float("nan")

    def to_dict(self) -> dict:
        return {"values": self.values, "omega_rad_s": self.omega_rad_s,
                "omega_sigma_rad_s": self.omega_sigma_rad_s, "rms": self.rms,
                "parameters": self.parameters}


class RotationLoop(EffectLoop):
    """What the loop found on a turn (:class:`.evidence.EffectLoop`; the noise in the
    track's unit per axis)."""


def _angle(tc: NDArray, theta0: float, omega: float, alpha: float = 0.0,
           lam: float = 0.0) -> NDArray:
    """The body's angle (rad) at centred times ``tc`` (s): θ₀ + ω·t + α·t²/2, and under a
    viscous drag, rate ω·e^{−λ·t}, the integral ω·(1 − e^{−λ·t})/λ (→ ω·t as λ → 0)."""
    if lam:
        turned = -omega * np.expm1(-lam * tc) / lam
    else:
        turned = omega * tc
    return theta0 + turned + 0.5 * alpha * tc**2


def _place(tc: NDArray, p: NDArray, on: tuple[str, ...]) -> NDArray:
    """p = (cx, cy, R, θ₀, ω, then each effect's parameters in ``on``'s order): the
    marker's place (n, 2) at centred times ``tc``."""
    extra = dict.fromkeys(("alpha_rad_s2", "lambda_per_s", "tilt_a", "tilt_b", "vx_per_s",
                           "vy_per_s"), 0.0)
    keys = [k for e in on for k in EFFECTS[e]]
    extra.update(zip(keys, p[5:], strict=True))
    theta = _angle(tc, p[3], p[4], extra["alpha_rad_s2"], extra["lambda_per_s"])
    a, b = extra["tilt_a"], extra["tilt_b"]
    c, s = np.cos(theta), np.sin(theta)
    return np.c_[p[0] + extra["vx_per_s"] * tc + p[2] * ((1 + a) * c + b * s),
                 p[1] + extra["vy_per_s"] * tc + p[2] * (b * c + (1 - a) * s)]


def _start(tc: NDArray, xy: NDArray) -> tuple[NDArray, float]:
    """(cx, cy, R, θ₀, ω) to start from: the algebraic circle through the fixes, their
    unwrapped angle about its centre and a straight line through that; and the angle
    swept (rad)."""
    A = np.c_[2 * xy, np.ones(len(xy))]
    cx, cy, c = np.linalg.lstsq(A, np.sum(xy**2, axis=1), rcond=None)[0]
    radius = float(np.sqrt(max(c + cx * cx + cy * cy, 0.0)))
    theta = np.unwrap(np.arctan2(xy[:, 1] - cy, xy[:, 0] - cx))
    omega, theta0 = np.polyfit(tc, theta, 1)
    return np.array([cx, cy, radius, theta0, omega]), float(np.ptp(theta))


def _from_angle(tc: NDArray, xy: NDArray, p0: NDArray, on: tuple[str, ...]) -> NDArray:
    """A start for the fit with effects ``on``: the circle of ``p0`` (:func:`_start`), the
    angle about it fitted by the rate effects in ``on`` (θ₀, ω, α, λ), the others 0."""
    theta = np.unwrap(np.arctan2(xy[:, 1] - p0[1], xy[:, 0] - p0[0]))
    rates = [e for e in on if e in ("steady torque", "viscous drag")]

    def angle(q: NDArray) -> NDArray:
        got = dict(zip(rates, q[2:], strict=True))
        return _angle(tc, q[0], q[1], got.get("steady torque", 0.0),
                      got.get("viscous drag", 0.0))

    q0 = np.r_[p0[3:5], [1e-3 if e == "viscous drag" else 0.0 for e in rates]]
    low = np.r_[-np.inf, -np.inf, [0.0 if e == "viscous drag" else -np.inf for e in rates]]
    q = solve_model(lambda q: angle(q)[:, None], theta[:, None], q0, (low, np.inf))[0]
    got = dict(zip(rates, q[2:], strict=True))
    extra = [got.get(e, 0.0) if e in rates else 0.0 for e in on for _ in EFFECTS[e]]
    return np.r_[p0[:3], q[:2], extra]


def fit_rotation(t_s: NDArray, xy: NDArray, sigma: float = 0.0) -> RotationLoop:
    """Fit a marker's turn about a fixed axis and close the loop on it.

    ``t_s`` (n,) frame times, s; ``xy`` (n, 2) its place (any length unit, its own axes;
    NaN: not found); ``sigma`` the tracker's per-axis σ in that unit, the floor of the
    noise.

    Raises
    ------
    CranktrackError
        Fewer than :data:`MIN_FIXES` fixes, times that do not advance, or a turn of less
        than :data:`MIN_SWEEP_RAD` about the circle through them.
    """
    t = np.asarray(t_s, float)
    xy = np.asarray(xy, float)
    ok = np.isfinite(t) & np.all(np.isfinite(xy), axis=1)
    t, xy = t[ok], xy[ok]
    if len(t) < MIN_FIXES:
        raise CranktrackError(f"only {len(t)} fixes of the turn; a fit needs at least "
                              f"{MIN_FIXES}")
    if not np.all(np.diff(t) > 0):
        raise CranktrackError("the fixes' times do not advance from frame to frame")
    tc = t - 0.5 * (t[0] + t[-1])
    p0, swept = _start(tc, xy)
    if not (np.isfinite(swept) and swept >= MIN_SWEEP_RAD and p0[2] > 0):
        raise CranktrackError(f"the marker turns {np.degrees(swept):.0f}° about the circle "
                              f"through its fixes, under the {np.degrees(MIN_SWEEP_RAD):.0f}° "
                              "a rate needs; track longer, or a marker further out")
    base_keys = ("cx", "cy", "radius", "theta0_rad", "omega_rad_s")
    fits: dict[tuple[str, ...], RotationFit] = {}

    def fit(on: tuple[str, ...]) -> tuple[NDArray, int]:
        keys = [k for e in on for k in EFFECTS[e]]
        low = np.full(5 + len(keys), -np.inf)
        if "viscous drag" in on:
            low[5 + keys.index("lambda_per_s")] = 0.0
        # Two starts, the better fit kept: where the fit with one effect fewer ended (a
        # drag from just above its bound of 0, the other effects from nothing), and the
        # algebraic circle with the angle about it fitted by the rates in `on` alone. A
        # wheel slowing from 6 to 0.8 rad/s leaves a steady turn far off (a circle of
        # half the radius), and the rate's effects must not start from there.
        starts = [_from_angle(tc, xy, p0, on)]
        if on:
            starts.append(np.r_[list(fits[on[:-1]].values.values()),
                                [1e-3 if on[-1] == "viscous drag" else 0.0]
                                * len(EFFECTS[on[-1]])])
        tried = [solve_model(lambda p: _place(tc, p, on), xy, start, (low, np.inf))
                 for start in starts]
        values, residual, cov = min(tried, key=lambda v: float(np.sum(v[1] ** 2)))
        fits[on] = RotationFit(combined(on) or "steady turn",
                               dict(zip((*base_keys, *keys), map(float, values), strict=True)),
                               float(values[4]), float(np.sqrt(max(cov[4, 4], 0.0))),
                               residual, len(values))
        return residual, len(values)

    verdict = effects_in_turn(fit, tuple(EFFECTS), sigma)

    def judged(f: RotationFit) -> RotationFit:
        return replace(f, omega_sigma_rad_s=f.omega_sigma_rad_s
                       * verdict.factor(f.residual, f.parameters))

    return RotationLoop.judged(judged(fits[()]),
                               {combined(k): judged(fits[k])
                                for k in on_the_way(list(fits), verdict.taken)}, verdict,
                               len(t), verdict.n_eff / 2, sigma)


def _said(f: RotationFit, y_down: bool) -> str:
    """A fit's rate in words: rad/s, turns a minute, and which way in the picture."""
    w = f.omega_rad_s
    # In the track's own axes counterclockwise is positive; with y down (px), a
    # counterclockwise turn in those axes is clockwise in the picture.
    way = "clockwise" if (w > 0) == y_down else "counterclockwise"
    return (f"ω = {abs(w):.5g} ± {f.omega_sigma_rad_s:.2g} rad/s ({abs(w) * 60 / (2 * np.pi):.4g}"
            f" turns a minute, {way} in the picture)")


def rotation_text(loop: RotationLoop, marker: str, unit: str) -> str:
    """The loop's result for a person: the rate before and after, each round's
    candidates and ΔBIC; ``unit`` is the track's (px: y down, so the turn's sense in
    the picture is the other way round from the track's axes)."""
    y_down = unit == "px"

    b = loop.base
    lines = [f"{marker} turning: {loop.samples} fixes ({loop.independent:.0f} independent), "
             f"noise {loop.noise:.3g} {unit} per axis",
             f"steady turn on a circle of radius {b.values['radius']:.4g} {unit}: "
             f"{_said(b, y_down)}, residual {b.rms:.3g} {unit} RMS"]
    rounds, left = rounds_text(
        loop, "residual  ω (rad/s)",
        lambda f: f"{f.rms:8.3g}  {abs(f.omega_rad_s):.5g} ± {f.omega_sigma_rad_s:.2g}",
        "the turn", unit, "the steady turn",
        lambda f: f"{_said(f, y_down)} at the track's middle")
    lines += rounds
    if loop.accepted is not None:
        v = loop.final.values
        if "alpha_rad_s2" in v:
            lines.append(f"the rate changes by {v['alpha_rad_s2']:+.4g} rad/s² (a steady "
                         "torque over the body's moment of inertia)")
        if "lambda_per_s" in v and v["lambda_per_s"] > 0:
            lines.append(f"the rate falls as e^(−t/{1 / v['lambda_per_s']:.4g} s)")
        if "tilt_a" in v:
            k = loop.final.narrow_over_wide
            lines.append(f"seen as an ellipse {k:.4f} as narrow as it is wide: the body's "
                         f"plane is turned {np.degrees(np.arccos(min(k, 1.0))):.1f}° to the "
                         "camera")
    return "\n".join(lines + left)
