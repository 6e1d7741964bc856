"""The free response of the crank, built from its parts for renders (independent truth).

The fitter's dynamic model (:mod:`cranktrack.models.dynamics`) writes the
thesis's eq. 3.28 in closed form and smooths dry friction with a tanh so its
integrator never meets the switch. This module imports nothing from
``models/`` and writes the same bed the way the mechanism is built:

- the crank tip B is at L2·(cos θ, sin θ) from the pivot A, the wire's far
  end C at (L1, 0); the wire's pull on B is a vector along B→C, and its
  torque about A is the cross product B × F;
- the wire is a spring of free length (1 − ε)·|BC| at the bias spring's rest
  angle (the thesis's pre-stretch), the torsion spring at A pulls towards
  that angle, and viscous damping acts at the pivot;
- play between the wire and the crank (``play_rad``): the wire is hooked to a
  light lever that turns freely through the play about the crank, between two
  stops. With no mass of its own the lever settles where the wire is at its
  free length, unless a stop holds it away from there; then the wire pulls
  through that stop;
- dry friction is a true stick–slip: while the crank turns it decelerates by
  μ against the motion; each time it stops, it stays stopped for good if the
  springs' torque is less than μ·I (nothing else drives it), and otherwise
  slides off the other way. The integrator (DOP853) stops at each halt.

Where the physics is the same — no dry friction — it agrees with the fitter's
model to the integrators' tolerance (``tests/test_open_world.py``); with dry
friction it differs where the crank comes to rest, as a real pivot would.
Units: lengths mm, angles rad, time s; the spring constants are per unit
inertia's units as the thesis's normalised eq. 3.28 has them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp


@dataclass(frozen=True)
class SwingingCrank:
    """A crank of inertia ``inertia`` between a torsion spring and a wire spring.

    ``bias_k`` and ``wire_k`` are the torsion spring's and the wire's stiffness,
    ``damping_per_s`` the viscous term's θ'' per unit θ' (eq. 3.28's k_d, not
    divided by the inertia), ``friction_rad_s2`` the dry friction's
    deceleration while sliding. ``rest_rad`` is where the torsion spring rests,
    ``prestretch`` the wire's stretch ε there.
    """

    L1_mm: float
    L2_mm: float
    inertia: float
    bias_k: float
    wire_k: float
    rest_rad: float
    prestretch: float
    damping_per_s: float = 0.0
    friction_rad_s2: float = 0.0
    play_rad: float = 0.0

    def _tip(self, theta: float) -> tuple[float, float]:
        return self.L2_mm * math.cos(theta), self.L2_mm * math.sin(theta)

    @property
    def wire_free_mm(self) -> float:
        """The wire spring's free length: (1 − ε)·|BC| with the crank at rest angle, mm."""
        bx, by = self._tip(self.rest_rad)
        return (1.0 - self.prestretch) * math.hypot(self.L1_mm - bx, -by)

    @cached_property
    def _wire_slack_angle(self) -> float:
        """Where the lever sits with the wire at its free length, rad: |BC| grows from
        L1 − L2 to L1 + L2 as the angle goes from 0 to π, so bisection finds it."""
        lo, hi = 0.0, math.pi
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            bx, by = self._tip(mid)
            if math.hypot(self.L1_mm - bx, -by) < self.wire_free_mm:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    def _lever(self, theta: float) -> float:
        """The angle of the lever the wire pulls, rad: free within the play, or on a stop."""
        if self.play_rad <= 0:
            return theta
        free = self._wire_slack_angle
        half = 0.5 * self.play_rad
        if theta - half <= free <= theta + half:
            return free
        return theta + half if free > theta else theta - half

    def spring_accel(self, theta: float) -> float:
        """θ'' from the two springs alone (rad/s²), torques taken as cross products."""
        bx, by = self._tip(self._lever(theta))
        dx, dy = self.L1_mm - bx, -by  # B → C
        length = math.hypot(dx, dy)
        tension = self.wire_k * (length - self.wire_free_mm)
        fx, fy = tension * dx / length, tension * dy / length
        wire_torque = bx * fy - by * fx
        return (self.bias_k * (self.rest_rad - theta) + wire_torque) / self.inertia

    def swing(self, t_s: ArrayLike, theta_init: float, omega_init: float = 0.0
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """θ, θ', θ'' (rad, rad/s, rad/s²) at times ``t_s`` (s, from 0, increasing)."""
        t = np.asarray(t_s, float)
        theta, omega = np.full(t.size, np.nan), np.full(t.size, np.nan)
        mu, c = self.friction_rad_s2, self.damping_per_s
        start, y = 0.0, [float(theta_init), float(omega_init)]
        t_end = float(t.max()) if t.size else 0.0
        stuck = False
        direction = _direction(omega_init, self.spring_accel(y[0]))
        while start < t_end and not stuck:
            def rhs(_t: float, s: list[float], sign: float = direction) -> list[float]:
                return [s[1], self.spring_accel(s[0]) - c * s[1] - mu * sign]

            def halt(_t: float, s: list[float]) -> float:
                return s[1]

            halt.terminal = mu > 0
            halt.direction = -direction  # ω falls through 0 moving forward, rises moving back
            sol = solve_ivp(rhs, (start, t_end), y, method="DOP853", dense_output=True,
                            events=halt if mu > 0 else None, rtol=1e-11, atol=1e-13)
            if not sol.success:
                raise RuntimeError(f"the free swing's integration failed: {sol.message}")
            stop = float(sol.t[-1])
            here = (t >= start) & (t <= stop)
            theta[here], omega[here] = sol.sol(t[here])
            if stop >= t_end:
                break
            y = [float(sol.y[0, -1]), 0.0]
            pull = self.spring_accel(y[0])
            if abs(pull) <= mu:  # the springs cannot break it loose: at rest for good
                stuck = True
                after = t > stop
                theta[after], omega[after] = y[0], 0.0
            start, direction = stop, _direction(0.0, pull)
        alpha = np.array([self.spring_accel(a) for a in theta]) - c * omega
        moving = omega != 0
        alpha[moving] -= mu * np.sign(omega[moving])
        alpha[~moving & (mu > 0)] = 0.0
        return theta, omega, alpha


def _direction(omega: float, pull: float) -> float:
    """+1 or −1: which way the crank moves (its speed, or from rest, the pull's side)."""
    return math.copysign(1.0, omega if omega != 0 else pull)
