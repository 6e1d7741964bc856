"""The SMA-actuated crank-slider of thesis §2.5.3 (Table 2.3), heat transfer and dynamics coupled.

A current through the wire B–C heats it (:mod:`.heat`, Table 4.1); the
martensite fraction ξ shortens its natural length by up to the recovery
strain ε_L and stiffens it (martensite → austenite modulus); the crank
follows through its equation of motion against a pre-loaded torsional bias
spring at A, with inertia and viscous damping::

    I·θ'' = k_b·(θ_b − θ) − c·θ' − F(θ, ξ)·dL3/dθ,   dL3/dθ = L1·L2·sin θ / L3

    F = E(ξ)·A_w·max(L3/L_n(ξ) − 1, 0),   L_n(ξ) = L_A·(1 + ε_L·ξ),
    1/E(ξ) = ξ/E_M + (1 − ξ)/E_A          (the two phases in series)

The wire cannot push (F ≥ 0). The bias spring's rest angle θ_b is set so
that the martensite wire holds the crank at θ0 with tension ``preload_N``.
The coupling is one way — temperature sets ξ, ξ sets the force — since the
stress dependence of the transformation temperatures is not in the thesis's
model; on cooling the bias spring is assumed strong enough to detwin the
wire back (the thesis re-stretches it by hand between tests, §4.6.4).

Defaults: Table 2.3's geometry (L1 = 305 mm, L2 = 24.1 mm, θ0 = 125°), the
250 µm wire of Tables 4.2/4.4 with ε_L = 3.25 % (§2.3.3); the moduli
(E_A = 75 GPa, E_M = 28 GPa) are typical Nitinol values, the thesis gives
none; the spring, inertia and damping are chosen for a small printed crank.
Units: SI inside (m, N, s); lengths in the public fields are mm.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from itertools import pairwise

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter, lfiltic

from ..errors import CranktrackError
from .crank_slider import l3_from_theta
from .heat import CurrentSteps, SMAWire, simulate_wire

#: Thesis Table 2.3: geometry, start and final angle of the SMA-actuated mechanism.
TABLE_2_3 = {"L1": 305.0, "L2": 24.1, "theta0_deg": 125.0, "thetaf_deg": 98.0,
             "dtheta_theory_deg": 25.0, "dtheta_experiment_deg": 27.0}


@dataclass(frozen=True)
class SMABed:
    """Parameters of the SMA-actuated bed (see the module docstring)."""

    L1: float = TABLE_2_3["L1"]
    L2: float = TABLE_2_3["L2"]
    theta0_deg: float = TABLE_2_3["theta0_deg"]
    recovery_strain: float = 0.0325
    E_austenite_Pa: float = 75e9
    E_martensite_Pa: float = 28e9
    bias_k_Nm_rad: float = 0.01
    preload_N: float = 2.0
    inertia_kg_m2: float = 2e-6
    damping_Nms_rad: float = 5e-3
    thermal: SMAWire = field(default_factory=SMAWire)
    #: An effect the lumped model lacks (0: none): the wire's strain follows its
    #: martensite fraction through a first-order lag of this time constant, s (heat
    #: drawn off at the clamps, a temperature that is not uniform along the wire).
    thermal_lag_s: float = 0.0

    def __post_init__(self) -> None:
        if not 0 < self.theta0_deg < 180:
            raise CranktrackError("theta0_deg must lie between 0 and 180")
        for name in ("L1", "L2", "recovery_strain", "E_austenite_Pa", "E_martensite_Pa",
                     "bias_k_Nm_rad", "preload_N", "inertia_kg_m2"):
            if not getattr(self, name) > 0:
                raise CranktrackError(f"{name} must be positive")

    @property
    def L3_0(self) -> float:
        """Wire length at θ0, mm."""
        return float(l3_from_theta(np.radians(self.theta0_deg), self.L1, self.L2))

    @property
    def wire_area_m2(self) -> float:
        return np.pi * self.thermal.diameter_m**2 / 4.0

    @property
    def austenite_length_mm(self) -> float:
        """L_A: natural length of the fully austenitic wire, mm."""
        stretch = 1.0 + self.preload_N / (self.E_martensite_Pa * self.wire_area_m2)
        return self.L3_0 / ((1.0 + self.recovery_strain) * stretch)

    @property
    def wire(self) -> SMAWire:
        """The thermal wire at this bed's length (R scales with it; temperatures do not)."""
        length = self.L3_0 * 1e-3
        w = self.thermal
        return replace(w, length_m=length, R_ohm=w.R_ohm * length / w.length_m)

    def moment_arm_m(self, theta: NDArray) -> NDArray:
        """dL3/dθ, m/rad."""
        L3 = l3_from_theta(theta, self.L1, self.L2)
        return 1e-3 * self.L1 * self.L2 * np.sin(theta) / L3

    def wire_force_N(self, theta: NDArray, xi: NDArray) -> NDArray:
        L3 = l3_from_theta(theta, self.L1, self.L2)
        natural = self.austenite_length_mm * (1.0 + self.recovery_strain * xi)
        E = 1.0 / (xi / self.E_martensite_Pa + (1.0 - xi) / self.E_austenite_Pa)
        return E * self.wire_area_m2 * np.maximum(L3 / natural - 1.0, 0.0)

    @property
    def bias_rest_rad(self) -> float:
        """θ_b: where the bias spring would rest, rad (it holds the preload at θ0)."""
        th0 = np.radians(self.theta0_deg)
        return th0 + self.preload_N * float(self.moment_arm_m(np.array(th0))) / self.bias_k_Nm_rad

    def accel(self, theta: NDArray, omega: NDArray, xi: NDArray) -> NDArray:
        """θ'' from the equation of motion, rad/s²."""
        torque = (self.bias_k_Nm_rad * (self.bias_rest_rad - theta)
                  - self.damping_Nms_rad * omega
                  - self.wire_force_N(theta, xi) * self.moment_arm_m(theta))
        return torque / self.inertia_kg_m2


def lagged(x: NDArray[np.float64], t: NDArray[np.float64], tau_s: float) -> NDArray[np.float64]:
    """First-order lag of a signal sampled at ``t`` (exact for a signal linear between
    samples); ``tau_s`` = 0 returns it unchanged."""
    if tau_s <= 0:
        return x
    dt = np.diff(t)
    if dt.size and np.allclose(dt, dt[0], rtol=1e-9, atol=0.0):
        # A uniform grid makes it a fixed first-order filter: run in C by lfilter,
        # started at rest at x[0] (a fit calls this on 12 000 samples thousands of times).
        a = float(np.exp(-dt[0] / tau_s))
        b = tau_s / dt[0] * (1.0 - a) - a
        num, den = [1.0 - a - b, b], [1.0, -a]
        return lfilter(num, den, x, zi=lfiltic(num, den, [x[0]], [x[0]]))[0]
    out = np.empty_like(x)
    out[0] = x[0]
    a = np.exp(-dt / tau_s)
    # y' = (x − y)/τ with x linear on each step: y1 = a·y0 + (1 − a)·x1 − (x1 − x0)·b
    b = tau_s / dt * (1.0 - a) - a
    for k in range(1, x.size):
        out[k] = a[k - 1] * out[k - 1] + (1.0 - a[k - 1]) * x[k] - (x[k] - x[k - 1]) * b[k - 1]
    return out


def _constants(bed: SMABed) -> tuple[float, ...]:
    """The bed as the plain floats :func:`_torque` reads."""
    return (bed.L1, bed.L2, bed.bias_k_Nm_rad, bed.bias_rest_rad, bed.austenite_length_mm,
            bed.recovery_strain, bed.wire_area_m2, 1.0 / bed.E_martensite_Pa,
            1.0 / bed.E_austenite_Pa)


@njit(cache=True, nogil=True)
def _torque(theta: float, xi: float, bed: tuple[float, ...]) -> float:
    """Bias spring minus wire about A, N·m: :meth:`SMABed.accel` without inertia and
    damper, in plain floats (the integrator and the balance call it ~10⁵ times a fit)."""
    L1, L2, k_b, theta_b, LA, eps, area, inv_EM, inv_EA = bed
    L3 = math.sqrt(L1 * L1 + L2 * L2 - 2.0 * L1 * L2 * math.cos(theta))
    stretch = L3 / (LA * (1.0 + eps * xi)) - 1.0
    force = area * stretch / (xi * inv_EM + (1.0 - xi) * inv_EA) if stretch > 0 else 0.0
    return k_b * (theta_b - theta) - force * 1e-3 * L1 * L2 * math.sin(theta) / L3


@njit(cache=True, nogil=True)
def _balance(xi: NDArray, lo: float, hi: float, bed: tuple[float, ...], target: float = 0.0
             ) -> tuple[NDArray, NDArray]:
    """θ (rad) where :func:`_torque` equals ``target`` (N·m; 0: the balance) for each ξ,
    by 45 halvings between a slack wire (``lo``: the spring wins) and ``hi`` (the wire
    wins), and the torque's stiffness there, −dτ/dθ (N·m/rad, central difference over
    2 µrad)."""
    theta, stiffness = np.empty(xi.size), np.empty(xi.size)
    for i in range(xi.size):
        a, b = lo, hi
        for _ in range(45):  # 2.5 rad / 2⁴⁵: within 1e-13 rad
            mid = 0.5 * (a + b)
            if _torque(mid, xi[i], bed) > target:  # the balance is at a larger θ
                a = mid
            else:
                b = mid
        theta[i] = 0.5 * (a + b)
        stiffness[i] = -(_torque(theta[i] + 1e-6, xi[i], bed)
                         - _torque(theta[i] - 1e-6, xi[i], bed)) / 2e-6
    return theta, stiffness


@njit(cache=True, nogil=True)
def _stick(lower: NDArray, upper: NDArray, start: float) -> NDArray:
    """θ of a crank held by dry friction: it stays where it is while that lies between
    ``lower`` and ``upper`` (the angles where the torque reaches ±the friction) and is
    dragged along by whichever it would otherwise cross."""
    out = np.empty(lower.size)
    theta = start
    for i in range(lower.size):
        theta = min(max(theta, lower[i]), upper[i])
        out[i] = theta
    return out


@njit(cache=True, nogil=True)
def _relax(x: NDArray, t: NDArray, tau: NDArray) -> NDArray:
    """y' = (x − y)/τ from rest at x[0], exact for x linear between samples and τ
    (s) held over each step at its value at the step's end."""
    y = np.empty(x.size)
    y[0] = x[0]
    for k in range(1, x.size):
        dt = t[k] - t[k - 1]
        a = math.exp(-dt / tau[k])
        b = tau[k] / dt * (1.0 - a) - a
        y[k] = a * y[k - 1] + (1.0 - a) * x[k] - (x[k] - x[k - 1]) * b
    return y


def quasi_static_theta(bed: SMABed, xi: NDArray[np.float64],
                       t_s: NDArray[np.float64] | None = None,
                       coulomb_Nm: float = 0.0) -> NDArray[np.float64]:
    """θ (rad) where the torques balance, for each martensite fraction.

    The crank's inertia is left out (its own frequency against the stiff wire is
    hundreds of Hz): bisection between a slack wire (the spring wins) and θ0 + 0.3
    rad (the wire wins), 45 halvings, on 257 values of ξ spanning those asked for.
    With the times ``t_s`` the damper makes the crank relax towards that balance with
    time constant c/k, k the torque's stiffness in θ (a few ms with the bed's own
    damper, a tenth of a degree at full speed).

    ``coulomb_Nm`` is dry friction at the pivot (N·m; an effect the lumped model
    lacks): the crank sticks while the springs' and the wire's torque is within ±it,
    and while it slides it sits where that torque is exactly the friction, so it
    trails the balance by about friction / stiffness and, when the current turns,
    waits until the torque has changed by twice the friction. The crank starts at
    the balance of the first ξ (nothing has moved it yet).
    """
    xi = np.asarray(xi, float)
    # The balance depends on ξ alone, so it is solved on a grid of ξ and read off
    # by interpolation: a fit asks for thousands of frames, all on one smooth curve
    # (257 nodes put the linear interpolation within 1e-4° of the solve).
    # Where ξ is constant the nodes coincide, and the interpolation gives their one balance.
    nodes = np.linspace(float(np.min(xi)), float(np.max(xi)), 257)
    bracket = (0.05, np.radians(bed.theta0_deg) + 0.3, _constants(bed))
    on_nodes, stiff_nodes = _balance(nodes, *bracket)
    theta = np.interp(xi, nodes, on_nodes)
    if coulomb_Nm > 0:
        # The torque falls as θ grows, so +friction is reached below the balance.
        lower = np.interp(xi, nodes, _balance(nodes, *bracket, coulomb_Nm)[0])
        upper = np.interp(xi, nodes, _balance(nodes, *bracket, -coulomb_Nm)[0])
        theta = _stick(lower, upper, float(theta[0]))
    if t_s is None or bed.damping_Nms_rad == 0:
        return theta
    # Without inertia the damper makes the crank relax towards the balance:
    # c·θ' = k·(θ_balance − θ), a first-order lag of time constant c/k. (The lag
    # taken to first order, θ − c·θ'/k, was 2° off the rig at 0.1 N·m·s/rad.)
    stiffness = np.interp(xi, nodes, stiff_nodes)
    return _relax(theta, np.asarray(t_s, float),
                  bed.damping_Nms_rad / np.maximum(stiffness, 1e-12))


def _scalar_accel(bed: SMABed) -> Callable[[float, float, float], float]:
    """:meth:`SMABed.accel` for one state in plain floats: the integrator calls it
    hundreds of thousands of times, where numpy's per-call cost dominates."""
    constants, c, inertia = _constants(bed), bed.damping_Nms_rad, bed.inertia_kg_m2

    def accel(theta: float, omega: float, xi: float) -> float:
        return (_torque(theta, xi, constants) - c * omega) / inertia

    return accel


@dataclass(frozen=True)
class SMAMotion:
    """θ, ω, α (rad, rad/s, rad/s²) with the wire's temperature (°C), ξ and force (N)."""

    t_s: NDArray[np.float64]
    theta: NDArray[np.float64]
    omega: NDArray[np.float64]
    alpha: NDArray[np.float64]
    T_C: NDArray[np.float64]
    xi: NDArray[np.float64]
    force_N: NDArray[np.float64]


def simulate_bed(bed: SMABed, current: CurrentSteps, t_s: ArrayLike,
                 thermal_step_s: float = 1e-3) -> SMAMotion:
    """The bed's response to a current profile at times ``t_s`` (s, from 0).

    The heat model is integrated first on a fine grid (``thermal_step_s``);
    ξ(t) from it drives the equation of motion, integrated with LSODA (the
    stiff wire makes the crank's own frequency hundreds of Hz).
    """
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise CranktrackError("times must be an increasing array of at least 2")
    fine = np.arange(0.0, t[-1] + 2 * thermal_step_s, thermal_step_s)
    heat = simulate_wire(bed.wire, current, fine)
    heat = replace(heat, xi=lagged(heat.xi, fine, bed.thermal_lag_s))
    # Between current switches ξ(t) is smooth: a cubic spline through the thermal
    # samples keeps the solver from stumbling on the kinks of a linear interpolant.
    edges = sorted({0.0, float(t[-1]), *[s for s in current.times_s if 0.0 < s < t[-1]]})
    y = np.array([np.radians(bed.theta0_deg), 0.0])
    theta, omega = np.empty(t.size), np.empty(t.size)
    theta[0], omega[0] = y
    accel = _scalar_accel(bed)
    for a, b in pairwise(edges):
        near = (fine >= a - 1e-12) & (fine <= b + thermal_step_s)
        xi_of = CubicSpline(fine[near], heat.xi[near])

        def rhs(time: float, state: NDArray, xi_of: CubicSpline = xi_of) -> list[float]:
            return [state[1], accel(state[0], state[1], min(max(float(xi_of(time)), 0.0), 1.0))]

        inside = (t > a) & (t <= b)
        wanted = np.union1d(t[inside], [b])
        sol = solve_ivp(rhs, (a, b), y, method="LSODA", t_eval=wanted, rtol=1e-8, atol=1e-11)
        if not sol.success:
            raise CranktrackError(f"the SMA bed's integration failed: {sol.message}")
        pick = np.searchsorted(wanted, t[inside])
        theta[inside], omega[inside] = sol.y[0][pick], sol.y[1][pick]
        y = sol.y[:, -1]
    xi = np.interp(t, fine, heat.xi)
    return SMAMotion(t, theta, omega, bed.accel(theta, omega, xi), np.interp(t, fine, heat.T_C),
                     xi, bed.wire_force_N(theta, xi))
