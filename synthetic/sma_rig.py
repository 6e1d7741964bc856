"""The SMA-actuated bed built from its parts, for renders (independent truth).

The fitter's SMA model (``models/heat.py``, ``models/sma_bed.py``) integrates
the wire's temperature with the latent heat folded into an effective heat
capacity, and balances the crank's torques without its inertia. This module
imports nothing from ``models/`` and builds the same rig another way:

- **Heat, as enthalpy.** The wire's enthalpy above ambient,
  H = m·c_p·(T − T∞) + m·Δh·(1 − ξ), rises with the Joule heat I²R and falls
  with convection h·A_s·(T − T∞). H is what is integrated (Heun's method on a
  0.5 ms grid); temperature and martensite fraction are read back from it,
  since along the active branch H grows strictly with T.
- **Hysteresis, as memory.** While the enthalpy rises the wire is heating and ξ
  can only fall, along the cosine curve between A_s and A_f; while it falls, ξ
  can only rise, along the curve between M_f and M_s. A branch starts from the
  ξ the wire had when the direction turned.
- **A strain that lags its transformation** (``thermal_lag_s``): the fraction
  that sets the wire's length relaxes towards ξ at that time constant. Or, the
  other form of a lag, a dead time (``strain_delay_s``): the length follows ξ
  as it was that long before.
- **The crank with inertia**, against the torsion spring, the damper and the
  wire, whose pull on B is a vector along B→C (it cannot push). The wire's
  natural length is L_A·(1 + ε_L·ξ) and its modulus the two phases in series.
  The trapezoidal rule integrates it, implicitly (the stiff wire rings at a
  few hundred hertz).
- **Dry friction at the pivot** (``coulomb_Nm``), as stick and slip: a crank at
  rest stays at rest while the other torques are within ±the friction; a moving
  one is braked by the friction against its motion, and where its speed passes
  through zero within a step it stops there (found by the speed's linear
  interpolation over the step) and is judged again from rest.

Where the physics is the same it agrees with the fitter's model to well below
a tracker's noise (``tests/test_open_world.py``). Units: SI inside; lengths in
the public fields are mm, angles rad, temperatures °C.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicHermiteSpline


def current_step(amps: float, on_s: float, off_s: float) -> Callable[[float], float]:
    """The current (A) at time t (s): ``amps`` from ``on_s`` until ``off_s``, else 0."""
    return lambda t: amps if on_s <= t < off_s else 0.0


@dataclass(frozen=True)
class SMAWireParts:
    """The wire as a lab sheet gives it (defaults: thesis Tables 4.2/4.4).

    The same numbers as ``models.heat.SMAWire``'s, listed again on purpose: this
    module takes nothing from the fitter's side, not even its parameter record.
    """

    diameter_m: float = 250e-6
    length_m: float = 0.115
    density_kg_m3: float = 6450.0
    cp_J_kgK: float = 250.0
    h_W_m2K: float = 625.0
    R_ohm: float = 2.3
    dh_J_kg: float = 30000.0
    T_amb_C: float = 23.0
    As_C: float = 55.0
    Af_C: float = 70.0
    Ms_C: float = 50.0
    Mf_C: float = 25.0


@dataclass(frozen=True)
class SMARig:
    """The bed: geometry (mm), the wire, the bias spring, the crank.

    The wire is fastened at C = (L1, 0) and at the crank tip B, L2 from the
    pivot A = (0, 0); at θ0 the all-martensite wire holds the crank against the
    bias spring with tension ``preload_N``. The wire's thermal length is its
    length at θ0 (R scales with it).
    """

    L1_mm: float
    L2_mm: float
    theta0_rad: float
    recovery_strain: float
    E_austenite_Pa: float
    E_martensite_Pa: float
    bias_k_Nm_rad: float
    preload_N: float
    inertia_kg_m2: float
    damping_Nms_rad: float
    wire: SMAWireParts
    thermal_lag_s: float = 0.0
    coulomb_Nm: float = 0.0
    strain_delay_s: float = 0.0

    # --- geometry -------------------------------------------------------------
    def _tip(self, theta: float) -> tuple[float, float]:
        return self.L2_mm * math.cos(theta), self.L2_mm * math.sin(theta)

    def wire_length_mm(self, theta: float) -> float:
        bx, by = self._tip(theta)
        return math.hypot(self.L1_mm - bx, by)

    @property
    def _area_m2(self) -> float:
        return math.pi * self.wire.diameter_m**2 / 4.0

    @property
    def _austenite_mm(self) -> float:
        """The wire's natural length all austenite: the martensite wire at θ0 is
        stretched elastically by the preload on top of its recoverable strain."""
        elastic = self.preload_N / (self.E_martensite_Pa * self._area_m2)
        return self.wire_length_mm(self.theta0_rad) / ((1 + self.recovery_strain)
                                                        * (1 + elastic))

    def _wire_pull_torque(self, theta: float, xi: float) -> float:
        """Torque of the wire on the crank about A, N·m (negative: it closes θ)."""
        bx, by = self._tip(theta)
        dx, dy = self.L1_mm - bx, -by
        length = math.hypot(dx, dy)
        natural = self._austenite_mm * (1 + self.recovery_strain * xi)
        if length <= natural:
            return 0.0
        modulus = 1.0 / (xi / self.E_martensite_Pa + (1 - xi) / self.E_austenite_Pa)
        tension = modulus * self._area_m2 * (length / natural - 1.0)
        fx, fy = tension * dx / length, tension * dy / length
        return 1e-3 * (bx * fy - by * fx)  # mm × N → N·m

    @property
    def bias_rest_rad(self) -> float:
        """Where the bias spring rests: it balances the preload's torque at θ0."""
        th0 = self.theta0_rad
        bx, by = self._tip(th0)
        dx, dy = self.L1_mm - bx, -by
        length = math.hypot(dx, dy)
        torque = 1e-3 * (bx * dy - by * dx) / length * self.preload_N
        return th0 - torque / self.bias_k_Nm_rad

    # --- heat -----------------------------------------------------------------
    @property
    def _thermal(self) -> tuple[float, float, float]:
        """Mass (kg), h·A_s (W/K) and resistance (Ω) of the wire at its length on the bed."""
        w = self.wire
        length_m = 1e-3 * self.wire_length_mm(self.theta0_rad)
        mass = w.density_kg_m3 * self._area_m2 * length_m
        return mass, w.h_W_m2K * math.pi * w.diameter_m * length_m, w.R_ohm * length_m / w.length_m

    def _xi_on_branch(self, T: float, xi_start: float, heating: bool) -> float:
        w = self.wire
        lo, hi = (w.As_C, w.Af_C) if heating else (w.Mf_C, w.Ms_C)
        s = min(max((T - lo) / (hi - lo), 0.0), 1.0)
        curve = 0.5 * (1 + math.cos(math.pi * s))
        return min(xi_start, curve) if heating else max(xi_start, curve)

    def _state_of(self, H: float, xi_start: float, heating: bool, T_guess: float
                  ) -> tuple[float, float]:
        """(T °C, ξ) with enthalpy H (J above ambient, all martensite) on a branch.
        H(T) is strictly increasing there, so bisection on a bracket finds T."""
        w = self.wire
        mass = self._thermal[0]

        def enthalpy(T: float) -> float:
            xi = self._xi_on_branch(T, xi_start, heating)
            return mass * (w.cp_J_kgK * (T - w.T_amb_C) + w.dh_J_kg * (1 - xi))

        lo, hi = T_guess - 1.0, T_guess + 1.0
        while enthalpy(lo) > H:
            lo -= 2 * (hi - lo)
        while enthalpy(hi) < H:
            hi += 2 * (hi - lo)
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if enthalpy(mid) < H:
                lo = mid
            else:
                hi = mid
        T = 0.5 * (lo + hi)
        return T, self._xi_on_branch(T, xi_start, heating)

    def wire_history(self, current: Callable[[float], float], t_end: float,
                     step_s: float = 5e-4
                     ) -> tuple[NDArray, NDArray, NDArray]:
        """Times (s), temperature (°C) and the fraction that sets the wire's length,
        from rest at ambient and all martensite, under ``current(t)`` (A)."""
        _, hA, R = self._thermal
        w = self.wire
        n = math.ceil(t_end / step_s) + 1
        t = np.arange(n) * step_s
        T_out, xi_out = np.empty(n), np.empty(n)
        H, T, xi, xi_start, heating, strain_xi = 0.0, w.T_amb_C, 1.0, 1.0, True, 1.0
        for k in range(n):
            T_out[k], xi_out[k] = T, strain_xi
            if k == n - 1:
                break
            amps_now, amps_next = current(t[k]), current(t[k] + step_s)
            # Heun: the Joule heat at each end of the step, convection at each end's T.
            rate0 = amps_now**2 * R - hA * (T - w.T_amb_C)
            if (rate0 > 0) != heating and rate0 != 0:
                heating, xi_start = rate0 > 0, xi  # turned: a new branch from here
            T1, _ = self._state_of(H + step_s * rate0, xi_start, heating, T)
            rate1 = amps_next**2 * R - hA * (T1 - w.T_amb_C)
            H += 0.5 * step_s * (rate0 + rate1)
            T, xi = self._state_of(H, xi_start, heating, T1)
            if self.thermal_lag_s > 0:
                strain_xi = xi + (strain_xi - xi) * math.exp(-step_s / self.thermal_lag_s)
            else:
                strain_xi = xi
        if self.strain_delay_s > 0:  # the length follows ξ as it was that long before
            xi_out = np.interp(t - self.strain_delay_s, t, xi_out, left=xi_out[0])
        return t, T_out, xi_out

    # --- the crank ------------------------------------------------------------
    def response(self, t_s: ArrayLike, current: Callable[[float], float]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """θ, θ', θ'' (rad, rad/s, rad/s²) at times ``t_s`` (s, from 0, increasing).

        The trapezoidal rule on the wire's 0.5 ms grid, implicit (a Newton solve per
        step) because the stiff wire makes the crank ring at a few hundred hertz; it
        is A-stable, so that ringing is damped as the damper damps it rather than
        blowing up. Frames between grid points are read off a cubic Hermite curve.
        """
        t = np.asarray(t_s, float)
        grid, _, xi = self.wire_history(current, float(t.max()) + 1e-3)
        theta_b, k_b = self.bias_rest_rad, self.bias_k_Nm_rad
        c, inertia, mu = self.damping_Nms_rad, self.inertia_kg_m2, self.coulomb_Nm

        def drive(theta: float, x: float) -> float:
            """The springs' and the wire's torque, N·m: what friction has to hold."""
            return k_b * (theta_b - theta) + self._wire_pull_torque(theta, x)

        def accel(theta: float, omega: float, x: float, sense: float) -> float:
            return (drive(theta, x) - c * omega - mu * sense) / inertia

        n = grid.size
        theta, omega, alpha = np.empty(n), np.empty(n), np.empty(n)
        th, om = self.theta0_rad, 0.0
        # Which way friction brakes: the motion's sense, 0 while the crank is at rest.
        sense = 0.0
        a = accel(th, om, xi[0], sense)
        theta[0], omega[0], alpha[0] = th, om, a
        for k in range(1, n):
            dt = grid[k] - grid[k - 1]
            if mu > 0 and sense == 0.0:
                pull = drive(th, xi[k])
                if abs(pull) <= mu:  # held: nothing moves this step
                    theta[k], omega[k], alpha[k] = th, 0.0, 0.0
                    a = 0.0
                    continue
                sense = math.copysign(1.0, pull)
                a = accel(th, 0.0, xi[k - 1], sense)  # it breaks loose from rest
            # (Sliding, the sense stays: a step whose speed changes sign ends at rest.)

            def residual(th1: float, th=th, om=om, a=a, dt=dt, x=xi[k], s=sense) -> float:
                om1 = 2.0 * (th1 - th) / dt - om
                return om1 - om - 0.5 * dt * (a + accel(th1, om1, x, s))

            th1 = th + dt * om
            for _ in range(20):
                r = residual(th1)
                h = 1e-9
                step = r * h / (residual(th1 + h) - r)
                th1 -= step
                if abs(step) < 1e-14:
                    break
            om1 = 2.0 * (th1 - th) / dt - om
            if mu > 0 and om1 * sense < 0.0:
                # The speed passed through zero in this step: stop where it did (the
                # speed taken as linear over the step) and judge the crank from rest.
                part = om / (om - om1) if om != om1 else 0.0
                th, om, sense = th + 0.5 * part * dt * om, 0.0, 0.0
                a = 0.0
            else:
                th, om = th1, om1
                a = accel(th, om, xi[k], sense)
            theta[k], omega[k], alpha[k] = th, om, a
        th_of = CubicHermiteSpline(grid, theta, omega)
        om_of = CubicHermiteSpline(grid, omega, alpha)
        return th_of(t), om_of(t), om_of(t, 1)
