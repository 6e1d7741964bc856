"""The spool drive of the rigid test bed (thesis §2.5.2, Table 2.2).

A servo winds nylon wire onto a spool at C at constant surface speed, so the
slider length L3 shortens linearly from ``L3_0`` once the drive starts, until
the commanded stroke is wound in; then it holds. A torsion spring at A keeps
the wire taut, which this kinematic model takes as given (the dynamics at the
stop are an effect the model lacks, thesis Fig. 2.36).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq
from scipy.signal import lfilter

from ..errors import CranktrackError
from .crank_slider import CrankSlider, SliderState, crank_state, l3_from_theta

#: Thesis Table 2.2, mm and mm/s.
TABLE_2_2 = {"L1": 160.8, "L2": 72.4, "L3_0": 105.4, "speed_mm_s": 14.0}


@dataclass(frozen=True)
class SpoolDrive:
    """Constant-speed wire winding.

    Parameters
    ----------
    L1, L2, L3_0 : float
        Frame, crank and initial wire length, mm (defaults: thesis Table 2.2).
    speed_mm_s : float
        Winding speed, mm/s (> 0 shortens the wire).
    start_s : float
        Time the drive starts, s.
    stroke_mm : float
        Wire wound in before the drive stops, mm. Must stay below
        ``L3_0 − |L1 − L2|`` (17.0 mm for Table 2.2), where θ reaches 0.
    """

    L1: float = TABLE_2_2["L1"]
    L2: float = TABLE_2_2["L2"]
    L3_0: float = TABLE_2_2["L3_0"]
    speed_mm_s: float = TABLE_2_2["speed_mm_s"]
    start_s: float = 0.5
    stroke_mm: float = 15.0

    def __post_init__(self) -> None:
        limit = self.bed.max_stroke(self.L3_0)
        if not 0 <= self.stroke_mm < limit:
            raise CranktrackError(
                f"a stroke of {self.stroke_mm} mm is not possible: it must be at least 0 and "
                f"below {limit:.2f} mm, where the crank angle reaches 0"
            )
        if self.speed_mm_s <= 0:
            raise CranktrackError(f"the spool speed must be positive, not {self.speed_mm_s} mm/s")

    @property
    def bed(self) -> CrankSlider:
        """The linkage (branch +1: B on the positive-y side)."""
        return CrankSlider(self.L1, self.L2)

    @property
    def stop_s(self) -> float:
        """Time the drive stops, s."""
        return self.start_s + self.stroke_mm / self.speed_mm_s

    def slider(self, t_s: ArrayLike) -> SliderState:
        """L3, L3' and L3'' at times ``t_s`` (s).

        The rate steps at the start and stop instants, where it has no value:
        exactly there L3' and L3'' are NaN (and so are ω, α and v_B derived
        from them), rather than one side's value by convention.
        """
        t = np.asarray(t_s, dtype=float)
        moving = (t > self.start_s) & (t < self.stop_s)
        wound = np.clip(t - self.start_s, 0.0, self.stroke_mm / self.speed_mm_s)
        L3 = self.L3_0 - self.speed_mm_s * wound
        kink = (t == self.start_s) | (t == self.stop_s)
        rate = np.where(kink, np.nan, np.where(moving, -self.speed_mm_s, 0.0))
        accel = np.where(kink, np.nan, 0.0)
        return SliderState(L3=L3, L3_rate=rate, L3_accel=accel)


def stretched_theta(drive: SpoolDrive, theta: NDArray[np.float64], stretch_mm: float
                    ) -> NDArray[np.float64]:
    """θ (rad) when the wire stretches under the return spring's pull.

    The spring is taken as pre-wound one turn past θ0, so the wire's tension is
    ∝ (θ0 + 2π − θ) / arm(θ) with arm = dL3/dθ = L1·L2·sin θ / L3, and the stretch
    ∝ tension, ``stretch_mm`` at θ0 (already inside ``L3_0``). The wire's actual
    length is the kinematic one (from ``theta``) plus the change in stretch; a fixed
    point, since the stretch is small beside the wire. It is found by Steffensen's
    iteration (Aitken's Δ² on each pair of plain steps): the plain steps contract by
    only ⅓ a step at 1 mm of stretch, and 30 of them took half the spool loop's time
    on a minute of θ; 7–11 maps now reach the same θ to 1e-15 rad (2e-11 at 2 mm,
    where 30 plain steps had not converged).
    """
    d = drive
    th0 = float(d.bed.theta(d.L3_0))
    th_t = th0 + 2.0 * np.pi
    arm0 = d.L1 * d.L2 * np.sin(th0) / d.L3_0

    def stretch(th: NDArray) -> NDArray:
        arm = d.L1 * d.L2 * np.sin(th) / l3_from_theta(th, d.L1, d.L2)
        return stretch_mm * ((th_t - th) / arm) / ((th_t - th0) / arm0)

    L3_kin = l3_from_theta(theta, d.L1, d.L2)

    def step(th: NDArray) -> NDArray:
        return d.bed.theta(L3_kin - stretch_mm + stretch(th))

    out = np.asarray(theta, float)
    for _ in range(15):
        one = step(out)
        two = step(one)
        d1, d2 = one - out, two - one
        bend = d2 - d1
        usable = np.abs(bend) > 1e-300
        new = np.where(usable, two - d2 * d2 / np.where(usable, bend, 1.0), two)
        done = np.max(np.abs(new - out)) < 1e-13
        out = new
        if done:
            break
    return step(out)


def crank_inertia(theta: NDArray[np.float64], dt_s: float, hz: float, zeta: float
                  ) -> NDArray[np.float64]:
    """θ (rad) of a crank with inertia that the wire and spring pull towards ``theta``.

    ``theta`` is the massless crank's angle on a uniform grid of step ``dt_s`` (s),
    at rest at its first value. The crank answers as a second-order system,
    θ'' + 2ζωn·θ' + ωn²·θ = ωn²·θ_massless with ωn = 2π·``hz`` and damping ratio
    ``zeta``: it lags a little while the drive runs and rings at each change of the
    drive's speed — the start as much as the stop (thesis Fig. 2.36 shows the stop).
    The system is discretised by the bilinear transform, pre-warped at ωn so the
    ring's frequency is exact (written out: ``scipy.signal.cont2discrete`` costs
    0.7 ms a call, most of a fit's time).
    """
    wn = 2.0 * np.pi * hz
    k = wn / np.tan(0.5 * wn * dt_s)
    den = [k**2 + 2 * zeta * wn * k + wn**2, 2 * (wn**2 - k**2), k**2 - 2 * zeta * wn * k + wn**2]
    u = np.asarray(theta, float) - theta[0]
    return theta[0] + lfilter(wn**2 * np.array([1.0, 2.0, 1.0]), den, u)


@njit(cache=True, nogil=True)
def _driven_step(th: float, om: float, h: float, u0: float, u1: float, wn: float,
                 zeta: float, drag: float) -> tuple[float, float]:
    """One RK4 step of θ'' = ωn²(u − θ) − 2ζωn·θ' − drag, u going linearly u0 → u1."""
    um = 0.5 * (u0 + u1)
    a1 = wn * wn * (u0 - th) - 2.0 * zeta * wn * om - drag
    t2, w2 = th + 0.5 * h * om, om + 0.5 * h * a1
    a2 = wn * wn * (um - t2) - 2.0 * zeta * wn * w2 - drag
    t3, w3 = th + 0.5 * h * w2, om + 0.5 * h * a2
    a3 = wn * wn * (um - t3) - 2.0 * zeta * wn * w3 - drag
    t4, w4 = th + h * w3, om + h * a3
    a4 = wn * wn * (u1 - t4) - 2.0 * zeta * wn * w4 - drag
    return (th + h / 6.0 * (om + 2.0 * w2 + 2.0 * w3 + w4),
            om + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4))


@njit(cache=True, nogil=True)
def _crank_friction(target: np.ndarray, h: float, wn: float, zeta: float,
                    mu: float) -> np.ndarray:
    out = np.empty(target.size)
    th, om = target[0], 0.0
    out[0] = th
    for k in range(target.size - 1):
        u0, u1 = target[k], target[k + 1]
        s = 0.0  # time into this step: a step may hold a stop and a break-away
        for _ in range(8):
            ua = u0 + (u1 - u0) * s / h
            if om == 0.0:
                pull = wn * wn * (u1 - th)  # the wire's and spring's pull by the step's end
                if abs(pull) <= mu:
                    break  # stuck to the step's end: friction holds whatever they do
                sense = 1.0 if pull > 0.0 else -1.0
                # It breaks away where the pull, linear over the step, reaches μ.
                before = wn * wn * (ua - th) * sense
                if before < mu:
                    s += (h - s) * (mu - before) / (pull * sense - before)
                    ua = u0 + (u1 - u0) * s / h
            else:
                sense = 1.0 if om > 0.0 else -1.0
            rest = h - s
            new_th, new_om = _driven_step(th, om, rest, ua, u1, wn, zeta, mu * sense)
            if new_om * sense >= 0.0:
                th, om = new_th, new_om
                break
            # Friction cannot push: the crank stops within the step. Where, by bisection
            # on the time (the friction's sign is fixed until then); then it sticks or
            # turns back for the rest of the step.
            lo, hi = 0.0, rest
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                w = _driven_step(th, om, mid, ua, ua + (u1 - ua) * mid / rest, wn, zeta,
                                 mu * sense)[1]
                if w * sense > 0.0:
                    lo = mid
                else:
                    hi = mid
            th = _driven_step(th, om, lo, ua, ua + (u1 - ua) * lo / rest, wn, zeta,
                              mu * sense)[0]
            om = 0.0
            s += lo
        out[k + 1] = th
    return out


def crank_friction(theta: NDArray[np.float64], dt_s: float, hz: float, zeta: float,
                   coulomb_rad_s2: float) -> NDArray[np.float64]:
    """θ (rad) of a crank with inertia and dry friction at its pivot, pulled towards
    ``theta`` as in :func:`crank_inertia`.

    θ'' = ωn²(θ_massless − θ) − 2ζωn·θ' − μ·sign(θ'), with μ = ``coulomb_rad_s2``
    (the friction torque per unit inertia): while the crank stands, it stays put as
    long as the wire's and the spring's pull is within μ. Fourth-order Runge–Kutta on
    the massless angle's grid (step ``dt_s``, the target linear within a step), each
    stop found by bisection within its step; compiled, as a fit runs it hundreds of times.
    """
    return _crank_friction(np.ascontiguousarray(theta, dtype=np.float64), float(dt_s),
                           2.0 * np.pi * hz, float(zeta), float(coulomb_rad_s2))


def _first_reach(wound: Callable[[NDArray], NDArray], stroke_mm: float, near_s: float,
                 period_s: float) -> float:
    """The first drive time (s) at which ``wound`` reaches ``stroke_mm``: a rippled
    wound length (ripple period ``period_s``) need not rise monotonically, so it is
    sought on a grid of 1/40 period to twice ``near_s``, then refined by Brent's method."""
    grid = np.linspace(0.0, 2.0 * near_s + 1e-9, int(80.0 * near_s / period_s) + 64)
    over = np.flatnonzero(wound(grid) >= stroke_mm)
    if over.size == 0 or over[0] == 0:
        return near_s
    return float(brentq(lambda s: float(wound(np.array(s))) - stroke_mm,
                        float(grid[over[0] - 1]), float(grid[over[0]]), xtol=1e-12))


def spool_motion(drive: SpoolDrive, t_s: ArrayLike, slack_mm: float = 0.0,
                 growth_per_s: float = 0.0, ring_hz: float = 0.0, ring_zeta: float = 0.1,
                 rates: bool = True, stretch_mm: float = 0.0, ripple_mm: float = 0.0,
                 ripple_turn_mm: float = 10.0, ripple_phase_deg: float = 0.0,
                 coulomb_rad_s2: float = 0.0
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """θ, ω, α (rad, rad/s, rad/s²) of the spool bed with effects the plain model lacks.

    ``slack_mm``: the first slack of wire is wound in without pulling.
    ``growth_per_s``: the wire speed grows by this fraction per second (the
    spool's radius grows as wire layers on it); the drive still winds
    ``stroke_mm`` and so stops sooner. ``ring_hz``, ``ring_zeta``: the crank has
    inertia (:func:`crank_inertia`) and rings at the drive's start and stop; then
    only θ is given. With all at 0 this is the
    plain model. ``rates=False`` skips ω and α (returned as NaN) for a fit
    that needs only θ, at a third of the cost. ``stretch_mm``: the wire
    stretches under the return spring (:func:`stretched_theta`); then only θ is
    given and ω, α are NaN (difference θ(t) for them). ``ripple_mm``: the spool
    turns off-centre by this much, so the wound length gains
    ``ripple·(cos φ0 − cos(φ0 + 2π·wound/ripple_turn_mm))`` (φ0 =
    ``ripple_phase_deg``, the spool's angle at the start; ``ripple_turn_mm`` the
    wire one turn winds): the wire's speed ripples once per spool turn; the drive
    still stops when ``stroke_mm`` is wound. ``coulomb_rad_s2``: dry friction at the
    pivot (:func:`crank_friction`), which acts through the crank's inertia and so needs
    ``ring_hz``.
    """
    t = np.asarray(t_s, dtype=float)
    d, g = drive, growth_per_s
    if coulomb_rad_s2 > 0 and not ring_hz > 0:
        raise CranktrackError("dry friction at the pivot needs the crank's inertia "
                              "(ring_hz): without it nothing resists the wire but the spring")
    if not 0 <= slack_mm < d.stroke_mm:
        raise CranktrackError(f"slack_mm must be at least 0 and below the stroke "
                              f"({d.stroke_mm} mm)")
    k, phi0 = 2.0 * np.pi * d.speed_mm_s / ripple_turn_mm, np.radians(ripple_phase_deg)

    def wound(tau: NDArray) -> NDArray:
        out = d.speed_mm_s * (tau + 0.5 * g * tau**2)
        if ripple_mm:  # the spool's turn goes with time, not with what it has wound
            out = out + ripple_mm * (np.cos(phi0) - np.cos(phi0 + k * tau))
        return out

    tau_stop = (d.stroke_mm / d.speed_mm_s if g == 0
                else float((-1.0 + np.sqrt(1.0 + 2.0 * g * d.stroke_mm / d.speed_mm_s)) / g))
    if ripple_mm:
        tau_stop = _first_reach(wound, d.stroke_mm, tau_stop, ripple_turn_mm / d.speed_mm_s)

    def length(tau: NDArray) -> NDArray:  # L3 (mm), all a θ-only fit needs
        return d.L3_0 - np.maximum(wound(tau) - slack_mm, 0.0)

    def slider(tau: NDArray, moving: NDArray) -> SliderState:
        L3 = length(tau)
        rate = -d.speed_mm_s * (1.0 + g * tau)
        accel = np.full_like(tau, -d.speed_mm_s * g)
        if ripple_mm:
            rate = rate - ripple_mm * k * np.sin(phi0 + k * tau)
            accel = accel - ripple_mm * k**2 * np.cos(phi0 + k * tau)
        return SliderState(L3, np.where(moving, rate, 0.0), np.where(moving, accel, 0.0))

    tau = np.clip(t - d.start_s, 0.0, tau_stop)
    moving = (t > d.start_s) & (t < d.start_s + tau_stop) & (wound(tau) > slack_mm)
    if rates:
        state = crank_state(d.bed, slider(tau, moving))
        theta, omega, alpha = state.theta.copy(), state.omega.copy(), state.alpha.copy()
    else:
        theta = d.bed.theta(length(tau))
        omega = alpha = np.full_like(theta, np.nan)
    if ring_hz > 0:
        # The crank's inertia: its massless angle on a grid fine beside the ring's
        # period, from rest, filtered, then read at the asked times.
        step = min(0.025 / ring_hz, 2e-3)
        grid = np.arange(min(float(t.min()), d.start_s) - step, float(t.max()) + 2 * step, step)
        g_tau = np.clip(grid - d.start_s, 0.0, tau_stop)
        massless = d.bed.theta(length(g_tau))
        crank = (crank_friction(massless, step, ring_hz, ring_zeta, coulomb_rad_s2)
                 if coulomb_rad_s2 > 0 else crank_inertia(massless, step, ring_hz, ring_zeta))
        theta = np.interp(t, grid, crank)
        omega = alpha = np.full_like(theta, np.nan)
    if stretch_mm > 0:
        theta = stretched_theta(d, theta, stretch_mm)
        omega = alpha = np.full_like(theta, np.nan)
    return theta, omega, alpha
