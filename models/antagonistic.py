"""The antagonistic SMA mechanism of thesis chapter 5: two wires, one rocker.

Geometry (Fig. 5.1 leaves the details open; this is the simplest layout
with the features the text names). A rocker turns about A. Two pins sit on
it at radius ``arm_mm``, square to the A–C axis at the symmetric position;
a wire runs from each pin, parallel to the axis, to its anchor on the slide
table at C, ``arm_mm`` off the axis on the same side. The mechanism is
symmetric about A–C. Turning the rocker by ψ lengthens one wire and
shortens the other by about ``arm_mm``·ψ, so heating one wire stretches the
other. The red marker B sits on the rocker at radius ``marker_mm``, at
``rest_deg`` from A→C when ψ = 0 (Fig. 5.6 starts near 131°), so the angle
the camera sees is θ = rest + ψ.

Pre-stress: the slide table sits ``table_mm`` out from where the wires,
fastened by hand with ``slack_mm`` of slack, would just be taut at their
austenite length (the thesis moves the table in 2.5 mm steps from 0 to
12.5 mm, §5.3.2). Below that the wires are slack and part of a contraction
only takes up slack; far above it the cold wire is stretched past its
detwinning strain into the stiff detwinned-martensite branch and blocks the
hot one. Between them the rocking angle peaks — the finding of Fig. 5.7.

Each wire: temperature and martensite fraction ξ from the heat model of
chapter 4 (:mod:`.heat`) with its own current; stress from its strain ε
(% of its austenite length) as the phase mixture of the two isotherms of
the §2.3 envelope (:mod:`.sma_material`)::

    σ(ε, ξ) = ξ·σ_M(ε) + (1 − ξ)·σ_A(ε)

σ_M is the isotherm at M_f, continued past the 3.25 % detwinning strain by
the detwinned-martensite modulus (the thesis's "second modulus", Fig. 2.10;
28 GPa is our choice) but never above σ_A, the isotherm at A_f: past
about 5.3 % both phases sit on the austenite plateau, the wire is near
yield and heating it no longer pulls. A slack wire carries nothing.

The rocker is overdamped — its inertia is negligible beside the bearing's
drag at these speeds::

    c·ψ' = τ_plus(ψ, ξ_plus) + τ_minus(ψ, ξ_minus) − k_c·ψ

With both wires taut the torques balance within milliseconds, so ψ follows
the heating quasi-statically; with both cold on their nearly flat detwinning
plateaus nothing holds the rocker but the weak centring spring k_c (the
leads' and bearing's own stiffness), which brings it back over tens of
seconds — the rocker stays where the last wire left it, as in Fig. 5.6.

Units: mm, s, °C, N; angles in degrees in the public fields.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from ..errors import CranktrackError
from .heat import CurrentSteps, SMAWire, simulate_wire
from .sma_material import PRESTRAIN_PCT, envelope_stress

#: The thesis's pre-stress steps, mm (§5.3.2).
THESIS_TABLE_MM = (0.0, 2.5, 5.0, 7.5, 10.0, 12.5)


def _thesis_wire() -> SMAWire:
    # §5.3.2: a 230 µm Dynalloy wire; resistance scaled from Table 4.4's 2.3 Ω for
    # 115 mm of 250 µm wire by length and cross-section.
    d, length = 230e-6, 0.20
    return SMAWire(diameter_m=d, length_m=length,
                   R_ohm=2.3 * (length / 0.115) * (250e-6 / d) ** 2)


@dataclass(frozen=True)
class AntagonisticBed:
    """Parameters of the two-wire mechanism (see the module docstring).

    ``current_A``: §5.3.2 drives 0.8 A, which in the heat model of chapter 4
    holds a 230 µm wire at about 56 °C, short of A_f = 70 °C; 1.1 A (about
    86 °C) transforms it fully. Wire ``plus`` is heated from ``on_s[0]`` to
    ``off_s[0]``, then wire ``minus`` from ``on_s[1]`` to ``off_s[1]``.
    """

    arm_mm: float = 8.0
    marker_mm: float = 40.0
    rest_deg: float = 131.0
    slack_mm: float = 0.2
    table_mm: float = 5.0
    current_A: float = 1.1
    on_s: tuple[float, float] = (0.3, 2.4)
    off_s: tuple[float, float] = (1.8, 3.9)
    E_detwinned_MPa_per_pct: float = 280.0  # 28 GPa
    centring_Nm_rad: float = 1e-4
    damping_Nms_rad: float = 3e-3
    wire: SMAWire = field(default_factory=_thesis_wire)

    def __post_init__(self) -> None:
        for name in ("arm_mm", "marker_mm", "current_A", "E_detwinned_MPa_per_pct",
                     "centring_Nm_rad", "damping_Nms_rad"):
            if not getattr(self, name) > 0:
                raise CranktrackError(f"{name} must be positive, not {getattr(self, name)}")
        if self.slack_mm < 0:
            raise CranktrackError(f"slack_mm cannot be negative, not {self.slack_mm}")
        if not 0 < self.rest_deg < 180:
            raise CranktrackError("rest_deg must lie between 0 and 180")
        if not (self.on_s[0] < self.off_s[0] <= self.on_s[1] < self.off_s[1]):
            raise CranktrackError("heat the wires one after the other: on_s[0] < off_s[0] "
                                  "≤ on_s[1] < off_s[1]")

    @property
    def wire_length_mm(self) -> float:
        return self.wire.length_m * 1e3

    @property
    def anchor_mm(self) -> float:
        """Distance from A to the anchors (and to C) along the axis, mm."""
        return self.wire_length_mm - self.slack_mm + self.table_mm

    @property
    def area_mm2(self) -> float:
        return float(np.pi * (self.wire.diameter_m * 1e3) ** 2 / 4.0)

    def currents(self) -> tuple[CurrentSteps, CurrentSteps]:
        """The alternating drive: wire plus, then wire minus."""
        return (CurrentSteps((self.on_s[0], self.off_s[0]), (self.current_A, 0.0)),
                CurrentSteps((self.on_s[1], self.off_s[1]), (self.current_A, 0.0)))

    def strains_pct(self, psi: ArrayLike) -> tuple[NDArray, NDArray]:
        """Strain of wire plus and wire minus at rocker turn ``psi`` (rad), %."""
        p = np.asarray(psi, float)
        a, x = self.arm_mm, self.anchor_mm
        # Pins at (∓a·sin ψ, ±a·cos ψ); anchors at (x, ±a).
        plus = np.hypot(x + a * np.sin(p), a * (1.0 - np.cos(p)))
        minus = np.hypot(x - a * np.sin(p), a * (1.0 - np.cos(p)))
        L = self.wire_length_mm
        return 100.0 * (plus / L - 1.0), 100.0 * (minus / L - 1.0)

    def stress_MPa(self, strain_pct: ArrayLike, xi: ArrayLike) -> NDArray:
        """Wire stress, MPa, from strain (%) and martensite fraction (see the module docstring)."""
        e = np.asarray(strain_pct, float)
        w = self.wire
        hot = envelope_stress(e, w.Af_C)
        cold = np.minimum(envelope_stress(np.minimum(e, PRESTRAIN_PCT), w.Mf_C)
                          + self.E_detwinned_MPa_per_pct * np.maximum(e - PRESTRAIN_PCT, 0.0),
                          hot)
        xi = np.asarray(xi, float)
        return xi * cold + (1.0 - xi) * hot

    def torque_Nm(self, psi: ArrayLike, xi_plus: ArrayLike, xi_minus: ArrayLike) -> NDArray:
        """Net torque on the rocker about A (positive turns ψ up), N·m."""
        p = np.asarray(psi, float)
        a, x = self.arm_mm, self.anchor_mm
        e_plus, e_minus = self.strains_pct(p)
        F_plus = self.stress_MPa(e_plus, xi_plus) * self.area_mm2
        F_minus = self.stress_MPa(e_minus, xi_minus) * self.area_mm2
        # Torque of a pull from pin P towards anchor Q: (P × (Q − P)/|Q − P|)·F.
        torque = np.zeros(np.broadcast(p, np.asarray(xi_plus)).shape)
        for sign, F in ((1.0, F_plus), (-1.0, F_minus)):
            Px, Py = -sign * a * np.sin(p), sign * a * np.cos(p)
            dx, dy = x - Px, sign * a - Py
            torque = torque + F * (Px * dy - Py * dx) / np.hypot(dx, dy)
        return torque * 1e-3 - self.centring_Nm_rad * p


@dataclass(frozen=True)
class AntagonisticMotion:
    """Rocker turn ψ (rad), marker angle θ (rad), wire states over time."""

    t_s: NDArray[np.float64]
    psi: NDArray[np.float64]
    theta: NDArray[np.float64]
    T_plus_C: NDArray[np.float64]
    T_minus_C: NDArray[np.float64]
    xi_plus: NDArray[np.float64]
    xi_minus: NDArray[np.float64]

    @property
    def rocking_deg(self) -> float:
        """Total swing, largest minus smallest θ, deg (what Fig. 5.7 plots)."""
        return float(np.degrees(self.theta.max() - self.theta.min()))


def equilibrium_psi(bed: AntagonisticBed, xi_plus: ArrayLike, xi_minus: ArrayLike,
                    limit_rad: float = 1.2) -> NDArray[np.float64]:
    """ψ where the wires' torques balance, for each pair of martensite fractions, rad.

    The net torque falls monotonically with ψ (each wire pulls harder the more
    it is stretched), so a bisection over [−limit, limit] finds the root; it
    runs on all instants at once.
    """
    xp, xm = np.broadcast_arrays(np.asarray(xi_plus, float), np.asarray(xi_minus, float))
    lo = np.full(xp.shape, -limit_rad)
    hi = np.full(xp.shape, limit_rad)
    if np.any(bed.torque_Nm(lo, xp, xm) < 0) or np.any(bed.torque_Nm(hi, xp, xm) > 0):
        raise CranktrackError("the wires do not balance within ±69° of the symmetric "
                              "position; shorten the arm or lengthen the wires")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        up = bed.torque_Nm(mid, xp, xm) > 0
        lo = np.where(up, mid, lo)
        hi = np.where(up, hi, mid)
    return 0.5 * (lo + hi)


def simulate_antagonistic(bed: AntagonisticBed, t_s: ArrayLike) -> AntagonisticMotion:
    """Heat the two wires in turn (:meth:`AntagonisticBed.currents`) and follow the rocker.

    The wires' temperatures and martensite fractions come from the heat model
    on a 1 ms grid; the rocker's equation (module docstring) is integrated by
    LSODA (stiff: milliseconds when the wires are taut, tens of seconds when
    they are not) from the balanced position at t = 0.
    """
    t = np.asarray(t_s, float)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0) or t[0] < 0:
        raise CranktrackError("times must be increasing, from 0 or later")
    grid = np.arange(0.0, float(t[-1]) + 2e-3, 1e-3)
    cur_plus, cur_minus = bed.currents()
    plus = simulate_wire(bed.wire, cur_plus, grid, fast=True)
    minus = simulate_wire(bed.wire, cur_minus, grid, fast=True)
    psi0 = float(equilibrium_psi(bed, plus.xi[0], minus.xi[0]))

    def rhs(time: float, y: NDArray) -> list[float]:
        xp = np.interp(time, grid, plus.xi)
        xm = np.interp(time, grid, minus.xi)
        return [float(bed.torque_Nm(y[0], xp, xm)) / bed.damping_Nms_rad]

    sol = solve_ivp(rhs, (0.0, float(t[-1])), [psi0], method="LSODA", t_eval=t, rtol=1e-8,
                    atol=1e-10, max_step=0.05)
    if not sol.success:
        raise CranktrackError(f"the rocker's equation did not integrate: {sol.message}")
    psi = sol.y[0]
    T_plus = np.interp(t, grid, plus.T_C)
    T_minus = np.interp(t, grid, minus.T_C)
    return AntagonisticMotion(t, psi, np.radians(bed.rest_deg) + psi, T_plus, T_minus,
                              np.interp(t, grid, plus.xi), np.interp(t, grid, minus.xi))


def rocking_vs_table(bed: AntagonisticBed, tables_mm: ArrayLike = THESIS_TABLE_MM,
                     dt_s: float = 0.01) -> NDArray[np.float64]:
    """Total rocking angle (deg) of one heat-one-then-the-other cycle at each table position."""
    t = np.arange(0.0, bed.off_s[1] + 2.0, dt_s)
    return np.array([simulate_antagonistic(replace(bed, table_mm=float(x)), t).rocking_deg
                     for x in np.asarray(tables_mm, float)])
