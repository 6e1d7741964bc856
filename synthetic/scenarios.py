"""Scenarios: the motion a render shows, computed from the models in ``kinematics``.

A scenario maps frame times to a :class:`Motion`: plane positions of the
markers and the exact kinematics columns: the spool bed (Table 2.2), the free
response of chapter 3, the SMA bed (Table 2.3) and the antagonistic pair of
chapter 5.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicHermiteSpline

from ..models.antagonistic import AntagonisticBed, simulate_antagonistic
from ..models.crank_slider import crank_state, l3_from_theta
from ..models.dynamics import CrankDynamics
from ..models.sma_bed import SMABed
from ..models.spool import SpoolDrive
from .free_swing import SwingingCrank
from .sma_rig import SMARig, SMAWireParts, current_step


@dataclass(frozen=True)
class Motion:
    """Exact motion at the frame times.

    ``points_mm`` maps marker name to plane positions (n, 2) in mm; the other
    fields are the kinematics of the crank in SI-with-mm units: θ and its
    rates in rad, rad/s, rad/s²; ``vB_mm_s`` (n, 2); ``L3_mm`` and
    ``L3_rate_mm_s``. ``wires_mm`` and ``bars_mm`` are segments (start, end),
    each (n, 2) mm, that a mechanism other than the crank-slider draws: wires
    in place of the B–C wire, bars in the crank's colour.
    """

    t_s: NDArray[np.float64]
    points_mm: dict[str, NDArray[np.float64]]
    theta: NDArray[np.float64]
    omega: NDArray[np.float64]
    alpha: NDArray[np.float64]
    vB_mm_s: NDArray[np.float64]
    L3_mm: NDArray[np.float64]
    L3_rate_mm_s: NDArray[np.float64]
    wires_mm: tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...] = ()
    bars_mm: tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...] = ()


@dataclass(frozen=True)
class SpoolScenario:
    """The rigid test bed of thesis Table 2.2 driven by the spool at C."""

    drive: SpoolDrive = field(default_factory=SpoolDrive)
    name: str = "spool"

    def motion(self, t_s: ArrayLike) -> Motion:
        """Exact motion at times ``t_s`` (s)."""
        t = np.asarray(t_s, dtype=float)
        slider = self.drive.slider(t)
        state = crank_state(self.drive.bed, slider)
        pos = self.drive.bed.positions(state.theta)
        return Motion(
            t_s=t,
            points_mm={"A": pos["A"], "B": state.B, "C": pos["C"]},
            theta=state.theta,
            omega=state.omega,
            alpha=state.alpha,
            vB_mm_s=state.vB,
            L3_mm=slider.L3,
            L3_rate_mm_s=slider.L3_rate,
        )

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Plane box (lo, hi) that holds the whole motion, mm."""
        d = self.drive
        thetas = d.bed.theta(np.linspace(d.L3_0 - d.stroke_mm, d.L3_0, 64))
        b = d.bed.positions(thetas)["B"]
        pts = np.vstack([b, [[0.0, 0.0], [d.L1, 0.0]]])
        return pts.min(axis=0), pts.max(axis=0)

    def to_dict(self) -> dict:
        """Parameters for ``scene.json``."""
        return {"name": self.name, **asdict(self.drive), "stop_s": self.drive.stop_s,
                "theta0_deg": float(np.degrees(self.drive.bed.theta(self.drive.L3_0)))}


def motion_from_angle(t: NDArray, theta: NDArray, omega: NDArray, alpha: NDArray, L1: float,
                      L2: float) -> Motion:
    """The full :class:`Motion` of a crank-slider (A at 0, C at (L1, 0)) from θ(t) and its
    rates: B on the crank circle, v_B = ω × r_B/A, L3 = |BC| and its rate."""
    B = L2 * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    vB = omega[:, None] * np.stack([-B[:, 1], B[:, 0]], axis=1)
    L3 = l3_from_theta(theta, L1, L2)
    return Motion(t_s=t, points_mm={"A": np.zeros_like(B), "B": B,
                                    "C": np.tile([L1, 0.0], (len(t), 1))},
                  theta=theta, omega=omega, alpha=alpha, vB_mm_s=vB, L3_mm=L3,
                  L3_rate_mm_s=L1 * L2 * np.sin(theta) * omega / L3)


class Scenario(Protocol):
    """What the renderer needs from a scenario."""

    name: str

    def motion(self, t_s: ArrayLike) -> Motion: ...

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...

    def to_dict(self) -> dict: ...


@dataclass(frozen=True)
class FreeScenario:
    """The free response of thesis chapter 3 (eq. 3.28), in the rigid bed's geometry.

    The crank is released at ``theta_init_deg`` with ``omega_init_rad_s`` and
    moves under the bias spring, the stretched wire and damping. Lengths are
    the rigid bed's (mm); the constants are chosen so one oscillation takes
    about two seconds: ``I`` = 0.05, ``k_l`` = 1, ``k_d`` = 0.5 and ``k_s`` for a
    stiffness ratio of 0.5 (a centre at θ0). Any of them can be changed.
    """

    dynamics: CrankDynamics = field(default_factory=lambda: CrankDynamics(
        I=0.05, k_l=1.0, k_s=0.5 / (160.8 * 72.4 * 0.05), k_d=0.5, L1=160.8, L2=72.4,
        theta0=np.radians(90.0)))
    theta_init_deg: float = 70.0
    omega_init_rad_s: float = 0.0
    name: str = "free"

    @property
    def crank(self) -> SwingingCrank:
        """The same bed built from its parts (:mod:`.free_swing`): the render's physics,
        written apart from the fitter's eq. 3.28, with a true stick–slip for dry friction."""
        d = self.dynamics
        return SwingingCrank(d.L1, d.L2, d.I, d.k_l, d.k_s, d.theta0, d.eps, d.k_d, d.coulomb,
                             d.play)

    def motion(self, t_s: ArrayLike) -> Motion:
        """Motion at times ``t_s`` (s, from 0), to the integrator's 1e-11."""
        t = np.asarray(t_s, dtype=float)
        theta, omega, alpha = _free_swing(self.crank, np.radians(self.theta_init_deg),
                                          self.omega_init_rad_s, _horizon(t))(t)
        return motion_from_angle(t, theta, omega, alpha, self.dynamics.L1, self.dynamics.L2)

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The crank's whole circle and the frame: wherever the motion goes."""
        d = self.dynamics
        return np.array([-d.L2, -d.L2]), np.array([d.L1, d.L2])

    def to_dict(self) -> dict:
        return {"name": self.name, **asdict(self.dynamics),
                "L3_0": self.dynamics.L3_0, "stiffness_ratio": self.dynamics.stiffness_ratio,
                "theta_init_deg": self.theta_init_deg, "omega_init_rad_s": self.omega_init_rad_s}


@dataclass(frozen=True)
class SMAScenario:
    """The SMA-actuated bed of thesis §2.5.3 (Table 2.3): a current step heats the
    wire, it contracts and pulls the crank from θ0 = 125° to about 98°, then the
    current stops, the wire cools and the bias spring brings the crank back. The
    parameters are :class:`cranktrack.models.sma_bed.SMABed`'s; the motion is
    rendered from :mod:`.sma_rig`, written apart from that model."""

    bed: SMABed = field(default_factory=SMABed)
    current_A: float = 1.3
    on_s: float = 0.5
    off_s: float = 3.0
    name: str = "sma"
    #: Dry friction at the pivot, N·m: an effect the fitter's lumped model lacks.
    coulomb_Nm: float = 0.0
    #: A dead time between the transformation and the wire's length, s (the other
    #: form of ``bed.thermal_lag_s``'s lag).
    strain_delay_s: float = 0.0

    def motion(self, t_s: ArrayLike) -> Motion:
        """Motion at times ``t_s`` (s, from 0), from one dense solution per clip (the
        renderer asks frame by frame): cubic Hermite in θ with ω as its slope, and in ω
        with α as its slope, on a 1 ms grid."""
        t = np.asarray(t_s, dtype=float)
        theta, omega, alpha = _sma_response(self.rig, (self.current_A, self.on_s, self.off_s),
                                            _horizon(t))(t)
        return motion_from_angle(t, theta, omega, alpha, self.bed.L1, self.bed.L2)

    @property
    def rig(self) -> SMARig:
        """The same bed built from its parts (:mod:`.sma_rig`): the render's physics,
        written apart from the fitter's heat and balance models."""
        b = self.bed
        return SMARig(b.L1, b.L2, np.radians(b.theta0_deg), b.recovery_strain,
                      b.E_austenite_Pa, b.E_martensite_Pa, b.bias_k_Nm_rad, b.preload_N,
                      b.inertia_kg_m2, b.damping_Nms_rad, SMAWireParts(**asdict(b.thermal)),
                      b.thermal_lag_s, self.coulomb_Nm, self.strain_delay_s)

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The crank's whole circle and the frame."""
        b = self.bed
        return np.array([-b.L2, -b.L2]), np.array([b.L1, b.L2])

    def to_dict(self) -> dict:
        b = self.bed
        return {"name": self.name, "current_A": self.current_A, "on_s": self.on_s,
                "off_s": self.off_s, **{k: v for k, v in asdict(b).items() if k != "thermal"},
                "thermal": asdict(b.thermal), "L3_0": b.L3_0,
                "wire_R_ohm": b.wire.R_ohm, "bias_rest_deg": float(np.degrees(b.bias_rest_rad))}


@dataclass(frozen=True)
class AntagonisticScenario:
    """The two-wire mechanism of thesis chapter 5 (:mod:`cranktrack.models.antagonistic`):
    one wire is heated and turns the rocker, then the other turns it back; the slide
    table's position ``bed.table_mm`` sets the pre-stress. The markers are A (pivot),
    B (on the rocker, at ``bed.rest_deg`` from A→C at the symmetric position) and C
    (the slide-table shaft)."""

    bed: AntagonisticBed = field(default_factory=AntagonisticBed)
    name: str = "antagonistic"

    def motion(self, t_s: ArrayLike) -> Motion:
        """Motion at times ``t_s`` (s, from 0), from one dense quasi-static solution per
        clip: θ on a 1 ms grid, ω and α by central differences there, cubic Hermite
        between grid points."""
        t = np.asarray(t_s, dtype=float)
        t_end = 10.0 * np.ceil(max(float(t.max()), 1e-9) / 10.0)
        theta_of, omega_of = _antagonistic_solution(self.bed, t_end)
        theta, omega = theta_of(t), omega_of(t)
        m = motion_from_angle(t, theta, omega, omega_of(t, 1), self.bed.anchor_mm,
                              self.bed.marker_mm)
        b = self.bed
        psi = theta - np.radians(b.rest_deg)
        pins = [b.arm_mm * np.stack([-s * np.sin(psi), s * np.cos(psi)], axis=1)
                for s in (1.0, -1.0)]
        anchors = [np.tile([b.anchor_mm, s * b.arm_mm], (len(t), 1)) for s in (1.0, -1.0)]
        return replace(m, wires_mm=tuple(zip(pins, anchors, strict=True)),
                       bars_mm=((pins[0], pins[1]),
                                (anchors[0], anchors[1])))

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The marker's whole circle and the slide-table shaft."""
        b = self.bed
        return np.array([-b.marker_mm, -b.marker_mm]), np.array([b.anchor_mm, b.marker_mm])

    def to_dict(self) -> dict:
        b = self.bed
        return {"name": self.name, **{k: v for k, v in asdict(b).items() if k != "wire"},
                "wire": asdict(b.wire), "anchor_mm": b.anchor_mm,
                "wire_length_mm": b.wire_length_mm}


@lru_cache(maxsize=8)
def _antagonistic_solution(bed: AntagonisticBed, t_end: float
                           ) -> tuple[CubicHermiteSpline, CubicHermiteSpline]:
    grid = np.arange(0.0, t_end + 1e-3, 1e-3)
    theta = simulate_antagonistic(bed, grid).theta
    omega = np.gradient(theta, grid)
    alpha = np.gradient(omega, grid)
    return CubicHermiteSpline(grid, theta, omega), CubicHermiteSpline(grid, omega, alpha)


def _horizon(t: NDArray) -> float:
    """The next whole 10 s after the last time: one solution covers every frame asked for."""
    return 10.0 * np.ceil(max(float(t.max()), 1e-9) / 10.0)


@lru_cache(maxsize=8)
def _free_swing(crank: SwingingCrank, theta_init: float, omega_init: float, t_end: float
                ) -> Callable[[NDArray], tuple[NDArray, NDArray, NDArray]]:
    """θ, θ', θ'' at any times up to ``t_end``, from one solution on a 1 ms grid
    (the renderer asks frame by frame): cubic Hermite in θ and θ' with their rates
    as slopes, so a stick is kept exactly where it happens to within a millisecond."""
    grid = np.arange(0.0, t_end + 1e-3, 1e-3)
    theta, omega, alpha = crank.swing(grid, theta_init, omega_init)
    th_of, om_of = CubicHermiteSpline(grid, theta, omega), CubicHermiteSpline(grid, omega, alpha)
    return lambda t: (th_of(t), om_of(t), om_of(t, 1))


@lru_cache(maxsize=8)
def _sma_response(rig: SMARig, step: tuple[float, float, float], t_end: float
                  ) -> Callable[[NDArray], tuple[NDArray, NDArray, NDArray]]:
    """θ, θ', θ'' at any times up to ``t_end`` under the current step (A, on s, off s),
    from one integration on a 1 ms grid."""
    grid = np.arange(0.0, t_end + 1e-3, 1e-3)
    theta, omega, alpha = rig.response(grid, current_step(*step))
    th_of, om_of = CubicHermiteSpline(grid, theta, omega), CubicHermiteSpline(grid, omega, alpha)
    return lambda t: (th_of(t), om_of(t), om_of(t, 1))
