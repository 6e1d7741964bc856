"""The spool bed built from its parts, as truth the fitter shares no code with.

A servo turns a spool at C; the wire wound onto it pulls the crank tip B; a
torsion spring at A pulls the other way. Everything here is written from that
picture — where two circles cross for the linkage, the spool's radius for the
winding, a torque balance for a wire that stretches, Newton's second law for a
crank with inertia — and imports nothing from ``models/`` or ``loop/``. A wrong
formula in the fitter therefore cannot be rendered here and then "found" at the
right value.

Where the physics admits two forms, both are here: slack as lost stroke
(``slack_mm``) and as a pure delay (``delay_s``); friction as a dead band
(``dead_band_deg``) and as a Coulomb torque in the equation of motion
(``coulomb_rad_s2``, with ``ring_hz`` giving the crank its inertia). An eccentric
spool (``eccentricity``) is the fitter's ``drive_ripple_mm``, written here as the
spool's geometry; a dead band (``dead_band_deg``) is the fitter's ``play_deg``. A
servo that stalls mid-stroke (``stall_at_s``, ``stall_s``) is not in the fitter's
library: it must come out as "unexplained", never under another effect's name.

Lengths in mm, angles in rad, times in s (the video's clock, unless said).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import cached_property, lru_cache

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import OdeSolution, solve_ivp
from scipy.optimize import brentq


def crank_angle(L1_mm: float, L2_mm: float, L3_mm: ArrayLike) -> NDArray[np.float64]:
    """Crank angle (rad) where the circle of radius L2 about A = (0, 0) crosses the
    circle of radius L3 about C = (L1, 0), B above the A–C line."""
    L3 = np.asarray(L3_mm, float)
    along = (L1_mm**2 + L2_mm**2 - L3**2) / (2.0 * L1_mm)  # B's x
    across = np.sqrt(np.maximum(L2_mm**2 - along**2, 0.0))  # B's y
    return np.arctan2(across, along)


def wire_length(L1_mm: float, L2_mm: float, theta: ArrayLike) -> NDArray[np.float64]:
    """|BC| (mm) with B = L2·(cos θ, sin θ) and C = (L1, 0)."""
    th = np.asarray(theta, float)
    return np.hypot(L2_mm * np.cos(th) - L1_mm, L2_mm * np.sin(th))


def lever_arm(L1_mm: float, L2_mm: float, theta: ArrayLike) -> NDArray[np.float64]:
    """Distance (mm) from the pivot A to the line of the wire B–C: the arm the
    wire's tension turns the crank with."""
    th = np.asarray(theta, float)
    wx, wy = L2_mm * np.cos(th) - L1_mm, L2_mm * np.sin(th)  # B − C
    cx, cy = -L1_mm, 0.0  # A − C
    return np.abs(wx * cy - wy * cx) / np.hypot(wx, wy)


@dataclass(frozen=True)
class SpoolBed:
    """The rig and its effects (all off by default).

    Rig: ``L1_mm`` (A–C), ``L2_mm`` (A–B), ``L3_0_mm`` (wire at rest),
    ``speed_mm_s`` (the wire's speed leaving a round, bare spool), ``start_s``,
    ``stroke_mm`` (wire wound before the servo stops), ``spool_radius_mm``.

    Effects:

    - ``slack_mm``: that much wire is wound in before it pulls (lost stroke);
    - ``delay_s``: every movement of the drive reaches the crank this much later;
    - ``wire_diameter_mm``: each turn lays wire on the last, so the radius, and the
      wire's speed, grow (:attr:`growth_per_s` is the same as a rate);
    - ``eccentricity``: the spool turns off-centre, so the wire's speed ripples by
      ± this fraction once per spool turn;
    - ``stretch_mm``: the wire is elastic and stretched this much at rest by the
      torsion spring, pre-wound one turn past the rest angle;
    - ``ring_hz``, ``ring_zeta``: the crank has inertia; held by the wire's and the
      spring's stiffness it would ring at this frequency with this damping ratio
      (pivot drag), during the drive and after the stop;
    - ``coulomb_rad_s2``: dry friction at the pivot, as an angular deceleration
      (needs ``ring_hz``: friction acts through the equation of motion);
    - ``dead_band_deg``: play between the wire and the crank; the spring holds the
      crank on one side, so the wire takes the whole band up before the crank moves;
    - ``stall_at_s``, ``stall_s``: the servo stalls at that drive time for that long
      and then goes on (a hiccup of its control loop), still winding the whole stroke.
    """

    L1_mm: float = 160.8
    L2_mm: float = 72.4
    L3_0_mm: float = 105.4
    speed_mm_s: float = 14.0
    start_s: float = 0.5
    stroke_mm: float = 15.0
    spool_radius_mm: float = 3.0
    slack_mm: float = 0.0
    delay_s: float = 0.0
    wire_diameter_mm: float = 0.0
    eccentricity: float = 0.0
    stretch_mm: float = 0.0
    ring_hz: float = 0.0
    ring_zeta: float = 0.1
    coulomb_rad_s2: float = 0.0
    dead_band_deg: float = 0.0
    stall_at_s: float = 0.0
    stall_s: float = 0.0

    @property
    def servo_rad_s(self) -> float:
        """The servo's speed (rad/s)."""
        return self.speed_mm_s / self.spool_radius_mm

    @property
    def turn_hz(self) -> float:
        """Spool turns per second: the eccentric spool's ripple frequency."""
        return self.servo_rad_s / (2.0 * np.pi)

    @property
    def growth_per_s(self) -> float:
        """The fractional growth of the wire's speed per second that ``wire_diameter_mm``
        gives: the radius grows by one diameter per turn, the speed with it."""
        return self.wire_diameter_mm * self.turn_hz / self.spool_radius_mm

    def _wound_at_angle(self, phi: NDArray) -> NDArray:
        """Wire wound (mm) after the spool has turned ``phi`` (rad): ∫ r dφ."""
        r0, e = self.spool_radius_mm, self.eccentricity
        layers = self.wire_diameter_mm / (2.0 * np.pi)  # radius gained per radian
        return r0 * phi + r0 * e * (1.0 - np.cos(phi)) + 0.5 * layers * phi**2

    def wound_mm(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Wire wound onto the spool (mm) at drive time ``t_s`` (s)."""
        t = np.asarray(t_s, float)
        # The servo's own running time: a stall takes its length out of it.
        t = t - np.clip(t - self.stall_at_s, 0.0, self.stall_s)
        phi = np.maximum(t - self.start_s, 0.0) * self.servo_rad_s
        return self._wound_at_angle(np.minimum(phi, self._stop_angle))

    @cached_property
    def _stop_angle(self) -> float:
        """The spool's turn (rad) at which the stroke is wound and the servo stops."""
        return brentq(lambda p: float(self._wound_at_angle(np.array(p))) - self.stroke_mm,
                      0.0, 10.0 * self.stroke_mm / self.spool_radius_mm + 10.0)

    def _stiff_wire_theta(self, t: NDArray) -> NDArray:
        """θ (rad) for an inextensible wire without play or inertia."""
        pulled = np.maximum(self.wound_mm(t - self.delay_s) - self.slack_mm, 0.0)
        return crank_angle(self.L1_mm, self.L2_mm, self.L3_0_mm - pulled)

    def _stretched(self, theta_stiff: NDArray) -> NDArray:
        """θ (rad) where the elastic wire's length balances the spring's torque."""
        L1, L2 = self.L1_mm, self.L2_mm
        th0 = float(crank_angle(L1, L2, self.L3_0_mm))
        wound_up = th0 + 2.0 * np.pi  # the spring's free angle, one turn past rest

        def tension(th: float) -> float:  # per unit spring stiffness
            return (wound_up - th) / float(lever_arm(L1, L2, th))

        per_tension = self.stretch_mm / tension(th0)  # mm of stretch per unit tension
        # The free (unstretched) wire is the rest length minus the rest stretch,
        # shortened by what the stiff model winds in.
        out = np.empty_like(theta_stiff)
        for i, ts in enumerate(theta_stiff):
            free = float(wire_length(L1, L2, ts)) - self.stretch_mm
            out[i] = brentq(lambda th, f=free: float(wire_length(L1, L2, th))
                            - f - per_tension * tension(th), ts - 0.2, ts + 0.2)
        return out

    def theta(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """The crank angle (rad) at drive times ``t_s`` (s)."""
        t = np.asarray(t_s, float)
        if self.coulomb_rad_s2 > 0 and self.ring_hz <= 0:
            raise ValueError("coulomb_rad_s2 needs ring_hz: friction acts through inertia")
        if np.any(t < 0):
            raise ValueError("the bed starts at rest at 0 s; ask for times from 0 on")
        if self.ring_hz > 0:
            theta = _inertia(self, 10.0 * np.ceil(float(t.max()) / 10.0 + 1.0))(t)[0]
        else:
            theta = self._stiff_wire_theta(t)
        if self.dead_band_deg > 0:
            # The wire closes θ; the spring holds the crank against the band's far side,
            # so the crank follows only once the wire has closed the whole band.
            band = np.radians(self.dead_band_deg)
            rest = float(crank_angle(self.L1_mm, self.L2_mm, self.L3_0_mm))
            theta = np.minimum(theta + band, rest)
        if self.stretch_mm > 0:
            theta = self._stretched(theta)
        return theta

    def effects(self) -> dict[str, float]:
        """The effects switched on, by name."""
        rest = SpoolBed()
        rig = {"L1_mm", "L2_mm", "L3_0_mm", "speed_mm_s", "start_s", "stroke_mm",
               "spool_radius_mm", "ring_zeta"}
        return {f.name: getattr(self, f.name) for f in fields(self)
                if f.name not in rig and getattr(self, f.name) != getattr(rest, f.name)}


@lru_cache(maxsize=8)
def _inertia(bed: SpoolBed, until_s: float) -> OdeSolution:
    """The crank with inertia pulled towards the stiff-wire angle, from rest at 0 s
    to ``until_s``: θ'' = −ωn²(θ − θ_wire) − 2ζωn·θ' − μ·sign(θ'), solved once."""
    wn = 2.0 * np.pi * bed.ring_hz
    grid = np.arange(0.0, until_s + 1e-3, 1e-3)
    target = bed._stiff_wire_theta(grid)
    mu = bed.coulomb_rad_s2

    def rhs(s: float, y: NDArray) -> list[float]:
        th, w = y
        torque = -wn**2 * (th - np.interp(s, grid, target)) - 2 * bed.ring_zeta * wn * w
        if mu > 0:
            # Sticks while the other torques cannot overcome the friction.
            torque += (-mu * np.sign(w) if abs(w) > 1e-9
                       else -np.sign(torque) * min(abs(torque), mu))
        return [w, torque]

    return solve_ivp(rhs, (0.0, until_s), [target[0], 0.0], dense_output=True, rtol=1e-9,
                     atol=1e-12, max_step=0.1 / max(bed.ring_hz, 1.0)).sol


def measured_table(theta: NDArray[np.float64], t_s: NDArray[np.float64], sigma_deg: float,
                   seed: int = 0, correlation: float = 0.0,
                   L1_mm: float = 160.8, L2_mm: float = 72.4) -> pd.DataFrame:
    """A kinematics table as ``cranktrack track`` writes it, from true θ (rad).

    The tracker's error is Gaussian with σ ``sigma_deg``; ``correlation`` is its
    lag-1 correlation (AR(1)), as compressed video gives a slowly varying bias.
    The rigid lengths carry the same kind of error.
    """
    rng = np.random.default_rng(seed)

    def noise(n: int, scale: float) -> NDArray:
        e = rng.normal(0.0, scale * np.sqrt(1.0 - correlation**2), n)
        e[0] = rng.normal(0.0, scale)
        for i in range(1, n):
            e[i] += correlation * e[i - 1]
        return e

    n = t_s.size
    link_mm = L2_mm * np.radians(sigma_deg)
    return pd.DataFrame({"frame": np.arange(n), "t_s": t_s,
                         "theta_deg": np.degrees(theta) + noise(n, sigma_deg),
                         "theta_deg_sigma": sigma_deg, "L3_mm": np.nan,
                         "L1_mm": L1_mm + noise(n, link_mm),
                         "L2_mm": L2_mm + noise(n, link_mm)})
