"""The crank-slider's equation of motion (thesis chapter 3).

A crank of inertia ``I`` pulled by a linear-spring wire (stiffness ``k_s``,
free length ``L3_0``) against a torsional bias spring (``k_l``, rest angle
``theta0``), with viscous damping ``k_d`` (eqs. 3.17, 3.18 and 3.27, 3.28)::

    θ'' = (k_l/I)(θ0 − θ) − k_d·θ' − (k_s/I)·L1·L2·sin θ·(1 − L3_0/L3(θ))

This is what the potential energy of eq. 3.2 gives with dL3/dθ =
+L1·L2·sin θ/L3; the printed eqs. 3.10, 3.12 and 3.16 carry sign slips (eq.
3.16 written as ``Iθ'' + k_l(θ0 − θ) − … = 0`` would make the bias spring push
away from θ0). Eq. 3.18 as printed is the one used, and it reproduces
Table 3.1. As the thesis's analysis does, ``L3_0 = (1 − ε)·L3(θ0)``: the
wire starts stretched by ε. Note that ``k_d`` multiplies θ' directly (eq.
3.28), not divided by I.

Units are whatever consistent set the parameters are in (the thesis's
chapter 3 uses normalised values: ``L2 = 1`` and the others 1 unless varied).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .crank_slider import l3_from_theta

#: Largest integration step of :func:`free_response`, s. RK4 at 4 ms is within 3e-6° of
#: the independent rig (``synthetic/free_swing.py``, DOP853 at rtol 1e-11) over the free
#: scenario's minute, with dry friction or play (1 ms: 2e-8°, four times the work); it
#: stays stable up to ωn ≈ 700 rad/s (k_l ≈ 5e5 1/s², above the fit's bound of 1e5).
FREE_STEP_S = 4e-3


@njit(cache=True)
def _accel(th: float, om: float, sense: float, k_l: float, k_s: float, k_d: float,
           L1: float, L2: float, th0: float, L3_0: float, half: float, neutral: float,
           mu: float) -> float:
    # With play the wire pulls a lever that turns ±half about the crank: it floats at
    # the wire's neutral angle while that lies within the band, else rests on a stop.
    tw = th - min(max(th - neutral, -half), half) if half > 0.0 else th
    L3 = math.sqrt(L1 * L1 + L2 * L2 - 2.0 * L1 * L2 * math.cos(tw))
    wire = k_s * L1 * L2 * math.sin(tw) * (1.0 - L3_0 / L3)
    return k_l * (th0 - th) - k_d * om - wire - mu * sense


@njit(cache=True)
def _rk4(th: float, om: float, h: float, sense: float, p: tuple) -> tuple[float, float]:
    a1 = _accel(th, om, sense, *p)
    a2 = _accel(th + 0.5 * h * om, om + 0.5 * h * a1, sense, *p)
    a3 = _accel(th + 0.5 * h * (om + 0.5 * h * a1), om + 0.5 * h * a2, sense, *p)
    a4 = _accel(th + h * (om + 0.5 * h * a2), om + h * a3, sense, *p)
    th1 = th + h * om + h * h / 6.0 * (a1 + a2 + a3)
    om1 = om + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return th1, om1


@njit(cache=True)
def _rk4_across(th: float, om: float, h: float, sense: float, p: tuple
                ) -> tuple[float, float]:
    """:func:`_rk4` over ``h``, split where θ crosses an edge of the play's band
    (``p[7]`` half-width about ``p[8]``), found by bisection: the wire's torque has a
    kink there, and a step across it would lose RK4's order (0.0012° at 4 ms steps)."""
    half, neutral = p[7], p[8]
    rest = h
    for _ in range(4):  # at most both edges and back within one step
        th1, om1 = _rk4(th, om, rest, sense, p)
        if half <= 0.0:
            return th1, om1
        first = rest
        for edge in (neutral - half, neutral + half):
            if (th - edge) * (th1 - edge) < 0.0:
                lo, hi = 0.0, rest
                for _ in range(40):
                    mid = 0.5 * (lo + hi)
                    if (_rk4(th, om, mid, sense, p)[0] - edge) * (th - edge) > 0.0:
                        lo = mid
                    else:
                        hi = mid
                first = min(first, hi)
        if first >= rest:
            return th1, om1
        th, om = _rk4(th, om, first, sense, p)
        rest -= first
    return _rk4(th, om, rest, sense, p)


@njit(cache=True)
def _free_response(t: np.ndarray, th: float, om: float, p: tuple,
                   max_step: float) -> tuple[np.ndarray, np.ndarray]:
    """θ and θ' at times ``t`` under eq. 3.28 per unit inertia, with stick–slip dry friction
    ``mu = p[-1]``: moving, it decelerates by mu against the motion; where the
    crank stops (found by bisection within the step) it stays, for good, unless
    the springs pull harder than mu (the system is autonomous, so a stuck crank
    never breaks loose again)."""
    mu = p[-1]
    out, rate = np.empty(t.size), np.empty(t.size)
    out[0], rate[0] = th, om
    stuck = False
    for i in range(1, t.size):
        steps = max(1, math.ceil((t[i] - t[i - 1]) / max_step))
        h = (t[i] - t[i - 1]) / steps
        for _ in range(steps):
            if stuck:
                break
            rest = _accel(th, 0.0, 0.0, *p)  # the springs alone
            if om == 0.0 and abs(rest) <= mu:
                stuck = True
                break
            sense = math.copysign(1.0, om if om != 0.0 else rest)
            th1, om1 = _rk4_across(th, om, h, sense, p)
            if mu > 0.0 and om1 * sense < 0.0:
                lo, hi = 0.0, h  # it stopped within this step: find where
                for _ in range(40):
                    mid = 0.5 * (lo + hi)
                    if _rk4(th, om, mid, sense, p)[1] * sense > 0.0:
                        lo = mid
                    else:
                        hi = mid
                th, om = _rk4(th, om, hi, sense, p)[0], 0.0
                rest = _accel(th, 0.0, 0.0, *p)
                if abs(rest) <= mu:
                    stuck = True
                    break
                th, om = _rk4(th, 0.0, h - hi, math.copysign(1.0, rest), p)
            else:
                th, om = th1, om1
        out[i], rate[i] = th, om
    return out, rate


def free_response(dyn: CrankDynamics, t_s: ArrayLike, theta_init: float,
                  omega_init: float = 0.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """θ (rad) and θ' (rad/s) at times ``t_s`` (s, increasing; the initial state is at
    ``t_s[0]``), with the dry friction ``dyn.coulomb`` as a true stick–slip (compiled
    RK4, steps of at most :data:`FREE_STEP_S`). Raises ``FloatingPointError`` if the swing runs off
    to infinity (parameters a fit should not choose)."""
    t = np.ascontiguousarray(t_s, dtype=float)
    p = (dyn.k_l / dyn.I, dyn.k_s / dyn.I, dyn.k_d, dyn.L1, dyn.L2, dyn.theta0, dyn.L3_0,
         0.5 * dyn.play, dyn.neutral, dyn.coulomb)
    theta, omega = _free_response(t, float(theta_init), float(omega_init), p, FREE_STEP_S)
    if not np.all(np.isfinite(theta)):
        raise FloatingPointError("the free response diverged")
    return theta, omega


@dataclass(frozen=True)
class CrankDynamics:
    """Parameters of eq. 3.28 (thesis baseline: all 1, ε = 0.05, no damping)."""

    I: float = 1.0  # noqa: E741 - the thesis names the inertia I
    k_l: float = 1.0
    k_s: float = 1.0
    k_d: float = 0.0
    L1: float = 1.0
    L2: float = 1.0
    theta0: float = np.pi
    eps: float = 0.05
    #: Dry (Coulomb) friction at the pivot, as an angular deceleration (rad/s²):
    #: ``− coulomb·sign(θ')`` while the crank turns, and a stick where it stops unless
    #: the springs overcome it (:func:`free_response`). Not in the thesis; an effect
    #: real pivots have (0: none). A tanh(θ'/0.01) stand-in used before let a
    #: stopped crank creep on: against a true stick-slip render
    #: (``synthetic/free_swing.py``) it left 4× the noise unexplained.
    coulomb: float = 0.0
    #: Play between the wire and the crank, rad (the whole dead band; 0: none): the
    #: wire pulls a lever that turns that much freely about the crank, so the wire is
    #: idle while the crank is within half of it of :attr:`neutral`. Not in the thesis.
    #: Only :meth:`accel` and :func:`free_response` include it.
    play: float = 0.0

    @property
    def L3_0(self) -> float:
        """Free length of the wire spring: (1 − ε)·L3(θ0)."""
        return float((1.0 - self.eps) * l3_from_theta(self.theta0, self.L1, self.L2))

    @property
    def neutral(self) -> float:
        """The crank angle at which the wire is at its free length, rad (law of cosines)."""
        c = (self.L1**2 + self.L2**2 - self.L3_0**2) / (2.0 * self.L1 * self.L2)
        return float(np.arccos(np.clip(c, -1.0, 1.0)))

    @property
    def stiffness_ratio(self) -> float:
        """SR = k_s·L1·L2·ε / k_l (thesis §3.3); > 1 turns θ = π into a saddle."""
        return self.k_s * self.L1 * self.L2 * self.eps / self.k_l

    def accel(self, theta: ArrayLike, omega: ArrayLike = 0.0) -> NDArray[np.float64]:
        """θ'' of eq. 3.28 at (θ, θ')."""
        th = np.asarray(theta, float)
        half = 0.5 * self.play
        tw = th - np.clip(th - self.neutral, -half, half) if half > 0 else th
        L3 = l3_from_theta(tw, self.L1, self.L2)
        with np.errstate(divide="ignore", invalid="ignore"):
            wire = self.k_s / self.I * self.L1 * self.L2 * np.sin(tw) * (1.0 - self.L3_0 / L3)
        om = np.asarray(omega, float)
        friction = self.coulomb * np.sign(om) if self.coulomb else 0.0  # while sliding
        return self.k_l / self.I * (self.theta0 - th) - self.k_d * om - wire - friction

    def daccel_dtheta(self, theta: ArrayLike) -> NDArray[np.float64]:
        """∂θ''/∂θ, analytic (the Jacobian's lower-left entry)."""
        th = np.asarray(theta, float)
        L3 = l3_from_theta(th, self.L1, self.L2)
        dL3 = self.L1 * self.L2 * np.sin(th) / L3
        c = self.k_s / self.I * self.L1 * self.L2
        return (-self.k_l / self.I
                - c * (np.cos(th) * (1.0 - self.L3_0 / L3) + np.sin(th) * self.L3_0 * dL3 / L3**2))

    def energy(self, theta: ArrayLike, omega: ArrayLike) -> NDArray[np.float64]:
        """Total energy ½Iθ'² + ½k_l(θ0 − θ)² + ½k_s(L3 − L3_0)² (eq. 3.1, 3.2)."""
        th, om = np.asarray(theta, float), np.asarray(omega, float)
        L3 = l3_from_theta(th, self.L1, self.L2)
        return (0.5 * self.I * om**2 + 0.5 * self.k_l * (self.theta0 - th) ** 2
                + 0.5 * self.k_s * (L3 - self.L3_0) ** 2)

    def equilibria(self, lo: float = 1e-6, hi: float = 2 * np.pi - 1e-6, n: int = 4001
                   ) -> NDArray[np.float64]:
        """All θ in (lo, hi) where θ'' = 0 at rest, found by sign changes and Brent's method."""
        grid = np.linspace(lo, hi, n)
        f = self.accel(grid)
        roots = [float(grid[i]) for i in np.flatnonzero(f == 0)]
        for i in np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0):
            roots.append(brentq(lambda x: float(self.accel(x)), grid[i], grid[i + 1],
                                xtol=1e-14))
        return np.unique(np.round(np.array(roots), 12))

    def jacobian(self, theta_e: float) -> NDArray[np.float64]:
        """Linearisation of (θ, θ')' about an equilibrium (eq. 3.25)."""
        return np.array([[0.0, 1.0], [float(self.daccel_dtheta(theta_e)), -self.k_d]])

    def eigenvalues(self, theta_e: float) -> NDArray[np.complex128]:
        """Eigenvalues of :meth:`jacobian`, sorted by imaginary then real part."""
        ev = np.linalg.eigvals(self.jacobian(theta_e)).astype(complex)
        return ev[np.lexsort((ev.real, ev.imag))]

    def simulate(self, t_s: ArrayLike, theta_init: float, omega_init: float = 0.0,
                 rtol: float = 1e-10, atol: float = 1e-12) -> tuple[NDArray, NDArray]:
        """θ(t), θ'(t) from Dormand–Prince (RK45) at tight tolerances; with dry
        friction or play, from :func:`free_response` (its stick is an event RK45 cannot
        see, and the play's stops are kinks)."""
        t = np.asarray(t_s, float)
        if self.coulomb or self.play:
            return free_response(self, t, theta_init, omega_init)
        sol = solve_ivp(lambda _, y: [y[1], float(self.accel(y[0], y[1]))], (t[0], t[-1]),
                        [theta_init, omega_init], method="RK45", t_eval=t, rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError(f"integration failed: {sol.message}")
        return sol.y[0], sol.y[1]


def classify(eigenvalues: ArrayLike, tol: float = 1e-9) -> str:
    """Equilibrium type from the eigenvalues of a 2×2 system.

    Returns ``"centre"``, ``"saddle"``, ``"stable node"``, ``"unstable node"``,
    ``"stable focus"``, ``"unstable focus"`` or ``"degenerate"``.
    """
    ev = np.asarray(eigenvalues, complex)
    re, im = ev.real, ev.imag
    if np.all(np.abs(re) <= tol) and np.all(np.abs(im) > tol):
        return "centre"
    if np.all(np.abs(im) <= tol):
        if re.min() < -tol and re.max() > tol:
            return "saddle"
        if np.all(re < -tol):
            return "stable node"
        if np.all(re > tol):
            return "unstable node"
        return "degenerate"
    return "stable focus" if re.max() < 0 else "unstable focus"
