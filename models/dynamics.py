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

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .crank_slider import l3_from_theta

#: Angular speed (rad/s) over which the Coulomb friction term changes sign.
COULOMB_SMOOTHING = 0.01


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
    #: ``− coulomb·tanh(θ'/ω_c)`` with ω_c = 0.01 rad/s, a smooth stand-in for
    #: sign(θ') so the integrator need not chase the switch. Not in the thesis;
    #: an effect real pivots have (0: none).
    coulomb: float = 0.0

    @property
    def L3_0(self) -> float:
        """Free length of the wire spring: (1 − ε)·L3(θ0)."""
        return float((1.0 - self.eps) * l3_from_theta(self.theta0, self.L1, self.L2))

    @property
    def stiffness_ratio(self) -> float:
        """SR = k_s·L1·L2·ε / k_l (thesis §3.3); > 1 turns θ = π into a saddle."""
        return self.k_s * self.L1 * self.L2 * self.eps / self.k_l

    def accel(self, theta: ArrayLike, omega: ArrayLike = 0.0) -> NDArray[np.float64]:
        """θ'' of eq. 3.28 at (θ, θ')."""
        th = np.asarray(theta, float)
        L3 = l3_from_theta(th, self.L1, self.L2)
        with np.errstate(divide="ignore", invalid="ignore"):
            wire = self.k_s / self.I * self.L1 * self.L2 * np.sin(th) * (1.0 - self.L3_0 / L3)
        om = np.asarray(omega, float)
        friction = self.coulomb * np.tanh(om / COULOMB_SMOOTHING) if self.coulomb else 0.0
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

    def solution(self, t_end: float, theta_init: float, omega_init: float = 0.0,
                 rtol: float = 1e-10, atol: float = 1e-12):
        """A dense RK45 solution from t = 0 to ``t_end``: call it with times, get
        rows (θ, θ'). Cached, so a renderer asking frame by frame integrates once."""
        return _dense(self, float(t_end), float(theta_init), float(omega_init), rtol, atol)

    def simulate(self, t_s: ArrayLike, theta_init: float, omega_init: float = 0.0,
                 rtol: float = 1e-10, atol: float = 1e-12) -> tuple[NDArray, NDArray]:
        """θ(t), θ'(t) from Dormand–Prince (RK45) at tight tolerances."""
        t = np.asarray(t_s, float)
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


@lru_cache(maxsize=32)
def _dense(dyn: CrankDynamics, t_end: float, theta_init: float, omega_init: float,
           rtol: float, atol: float):
    sol = solve_ivp(lambda _, y: [y[1], float(dyn.accel(y[0], y[1]))], (0.0, t_end),
                    [theta_init, omega_init], method="RK45", dense_output=True, rtol=rtol,
                    atol=atol)
    if not sol.success:
        raise RuntimeError(f"integration failed: {sol.message}")
    return sol.sol
