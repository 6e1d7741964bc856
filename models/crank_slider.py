"""The analytic crank-slider of the thesis (§2.2, eqs. 2.1–2.5).

Names follow the thesis: ``L1`` is the frame (A–C), ``L2`` the crank (A–B),
``L3`` the slider/wire (B–C) and ``theta`` the internal angle at A between
A→C and A→B. The mechanism plane has A at the origin and C on +x; y is 90°
counter-clockwise from x. The assembly *branch* says on which side of the
frame line B sits: ``+1`` puts B at positive y (the thesis's figures), ``-1``
is the mirror assembly.

All lengths are in mm, angles in radians, time in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import CranktrackError

__all__ = [
    "CrankSlider",
    "CrankState",
    "Incompatibility",
    "KinematicIncompatibilityError",
    "SliderState",
    "crank_state",
    "incompatibility",
    "l3_from_theta",
    "theta_from_l3",
    "vB_via_slider",
]


class Incompatibility(Enum):
    """Why a crank-slider with given link lengths cannot close (thesis Fig. 2.5)."""

    #: L1 + L3 < L2: frame plus actuator shorter than the rocker (bottom-left
    #: boundary of Fig. 2.5).
    FRAME_TOO_SHORT = "frame plus wire is shorter than the crank (L1 + L3 < L2)"
    #: L2 + L3 < L1: rocker plus actuator shorter than the frame (the mirror
    #: incompatibility of Fig. 2.5).
    CRANK_TOO_SHORT = "crank plus wire is shorter than the frame (L2 + L3 < L1)"
    #: L3 > L1 + L2: the wire would have to be longer than the open linkage.
    WIRE_TOO_LONG = "wire is longer than frame plus crank (L3 > L1 + L2)"


class KinematicIncompatibilityError(CranktrackError, ValueError):
    """The mechanism cannot close for some of the requested slider lengths."""

    def __init__(self, kind: Incompatibility, count: int, first_index: int) -> None:
        self.kind = kind
        self.count = count
        self.first_index = first_index
        super().__init__(
            f"the crank-slider cannot close: {kind.value} "
            f"({count} sample(s), first at index {first_index})"
        )


def incompatibility(L1: float, L2: float, L3: ArrayLike) -> NDArray[np.object_]:
    """Classify each L3 as closable (``None``) or an :class:`Incompatibility`.

    Parameters
    ----------
    L1, L2 : float
        Frame and crank lengths, mm.
    L3 : array_like
        Slider (wire) lengths, mm.

    Returns
    -------
    ndarray of object
        Same shape as ``L3``; ``None`` where the loop closes.

    Examples
    --------
    >>> incompatibility(160.8, 72.4, [105.4, 80.0])[1]
    <Incompatibility.CRANK_TOO_SHORT: 'crank plus wire is shorter than the frame (L2 + L3 < L1)'>
    """
    L3 = np.asarray(L3, dtype=float)
    out = np.full(L3.shape, None, dtype=object)
    out[L1 + L3 < L2] = Incompatibility.FRAME_TOO_SHORT
    out[L2 + L3 < L1] = Incompatibility.CRANK_TOO_SHORT
    out[L3 > L1 + L2] = Incompatibility.WIRE_TOO_LONG
    return out


def _raise_if_incompatible(L1: float, L2: float, L3: NDArray[np.float64]) -> None:
    # The same tests as incompatibility(), in booleans first: fits call this
    # hundreds of thousands of times, and the object array is only needed to name a fault.
    if not np.any((L1 + L3 < L2) | (L2 + L3 < L1) | (L3 > L1 + L2)):
        return
    kinds = incompatibility(L1, L2, L3)
    bad = np.flatnonzero(kinds.ravel() != None)  # noqa: E711 - elementwise on objects
    if bad.size:
        first = int(bad[0])
        raise KinematicIncompatibilityError(kinds.ravel()[first], int(bad.size), first)


def l3_from_theta(theta: ArrayLike, L1: float, L2: float) -> NDArray[np.float64]:
    """Slider length from the internal angle by the cosine law.

    ``L3² = L1² + L2² − 2·L1·L2·cos θ``; valid on both assembly branches
    (``θ`` and ``−θ`` give the same length).

    Parameters
    ----------
    theta : array_like
        Internal angle at A, rad.
    L1, L2 : float
        Frame and crank lengths, mm.

    Returns
    -------
    ndarray
        L3 in mm.

    Examples
    --------
    >>> round(float(l3_from_theta(np.pi / 2, 3.0, 4.0)), 12)
    5.0
    """
    theta = np.asarray(theta, dtype=float)
    return np.sqrt(L1**2 + L2**2 - 2.0 * L1 * L2 * np.cos(theta))


def theta_from_l3(L3: ArrayLike, L1: float, L2: float, branch: int = 1) -> NDArray[np.float64]:
    """Internal angle at A from the slider length (inverse cosine law).

    Parameters
    ----------
    L3 : array_like
        Slider (wire) length, mm.
    L1, L2 : float
        Frame and crank lengths, mm.
    branch : {+1, -1}
        Assembly branch: ``+1`` returns θ in [0, π] (B at positive y),
        ``-1`` its mirror in [−π, 0].

    Returns
    -------
    ndarray
        θ in rad.

    Raises
    ------
    KinematicIncompatibilityError
        If any length cannot close the loop; the error names which of the
        incompatibilities of thesis Fig. 2.5 it is.
    """
    if branch not in (1, -1):
        raise ValueError(f"branch must be +1 or -1, not {branch!r}")
    L3 = np.asarray(L3, dtype=float)
    _raise_if_incompatible(L1, L2, L3)
    cos_theta = (L1**2 + L2**2 - L3**2) / (2.0 * L1 * L2)
    # Exactly at a boundary rounding can step just outside [-1, 1].
    return branch * np.arccos(np.clip(cos_theta, -1.0, 1.0))


@dataclass(frozen=True)
class SliderState:
    """Slider length and its first two time derivatives (mm, mm/s, mm/s²)."""

    L3: NDArray[np.float64]
    L3_rate: NDArray[np.float64]
    L3_accel: NDArray[np.float64]


@dataclass(frozen=True)
class CrankSlider:
    """Link lengths of a crank-slider, mm.

    Examples
    --------
    >>> bed = CrankSlider(L1=160.8, L2=72.4)   # thesis Table 2.2
    >>> round(float(np.degrees(bed.theta(105.4))), 2)
    30.85
    """

    L1: float
    L2: float
    branch: int = 1

    def theta(self, L3: ArrayLike) -> NDArray[np.float64]:
        """Internal angle at A (rad) for slider length(s) ``L3`` (mm)."""
        return theta_from_l3(L3, self.L1, self.L2, self.branch)

    def l3(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Slider length (mm) for internal angle(s) ``theta`` (rad)."""
        return l3_from_theta(theta, self.L1, self.L2)

    @property
    def min_l3(self) -> float:
        """Shortest wire that still closes the loop (θ = 0), mm."""
        return abs(self.L1 - self.L2)

    def max_stroke(self, L3_0: float) -> float:
        """Largest contraction from ``L3_0`` before θ reaches 0, mm."""
        return L3_0 - self.min_l3

    def positions(self, theta: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Plane positions of A, B, C (mm) for internal angle(s) ``theta``.

        Returns a dict ``{"A": (..., 2), "B": (..., 2), "C": (..., 2)}``.
        """
        phi = self.branch * np.abs(np.asarray(theta, dtype=float))
        B = self.L2 * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
        A = np.zeros_like(B)
        C = np.zeros_like(B)
        C[..., 0] = self.L1
        return {"A": A, "B": B, "C": C}


@dataclass(frozen=True)
class CrankState:
    """Kinematic state of the crank for a prescribed slider motion.

    Angles in rad, rates in rad/s and rad/s², positions in mm, velocities in
    mm/s, accelerations in mm/s². ``omega`` and ``alpha`` are derivatives of
    the internal angle θ (so a contracting wire gives ``omega < 0``).
    """

    theta: NDArray[np.float64]
    omega: NDArray[np.float64]
    alpha: NDArray[np.float64]
    B: NDArray[np.float64]
    vB: NDArray[np.float64]
    aB: NDArray[np.float64]
    #: Angular velocity of the wire B–C (link 3) in the plane, rad/s (eq. 2.3).
    omega3: NDArray[np.float64]


def crank_state(bed: CrankSlider, slider: SliderState) -> CrankState:
    """θ, ω, α and the velocity/acceleration of B for a prescribed L3(t).

    Differentiating the cosine law gives, with ``s = sin θ``::

        θ' = L3·L3' / (L1·L2·sin θ)
        θ'' = (L3'² + L3·L3'' − L1·L2·cos θ·θ'²) / (L1·L2·sin θ)

    and B follows from eqs. 2.2 and 2.4 as a rotation about A:
    ``v_B = ω × r_B/A`` and ``a_B = α × r_B/A + ω × (ω × r_B/A)``.
    At θ = 0 or π (the wire in line with the crank) ω is unbounded for a
    moving slider; such samples come back as ``inf``/``nan`` only where the
    slider actually moves there, never silently elsewhere.

    Parameters
    ----------
    bed : CrankSlider
        Link lengths and assembly branch.
    slider : SliderState
        L3 (mm), L3' (mm/s), L3'' (mm/s²), arrays of one shape.

    Returns
    -------
    CrankState
    """
    L1, L2, s = bed.L1, bed.L2, bed.branch
    L3, dL3, ddL3 = (np.asarray(a, dtype=float) for a in (slider.L3, slider.L3_rate,
                                                          slider.L3_accel))
    theta_int = theta_from_l3(L3, L1, L2, branch=1)
    sin_t, cos_t = np.sin(theta_int), np.cos(theta_int)
    with np.errstate(divide="ignore", invalid="ignore"):
        omega_int = L3 * dL3 / (L1 * L2 * sin_t)
        alpha_int = (dL3**2 + L3 * ddL3 - L1 * L2 * cos_t * omega_int**2) / (L1 * L2 * sin_t)
    still = (dL3 == 0) & (ddL3 == 0)
    omega_int = np.where(still, 0.0, omega_int)
    alpha_int = np.where(still, 0.0, alpha_int)

    # The signed crank angle phi = s·θ; its rates carry the same sign.
    phi, w, a = s * theta_int, s * omega_int, s * alpha_int
    r = L2 * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    perp = np.stack([-r[..., 1], r[..., 0]], axis=-1)  # ẑ × r
    vB = w[..., None] * perp  # eq. 2.2
    aB = a[..., None] * perp - (w**2)[..., None] * r  # eq. 2.4

    # Link 3: the angle gamma at C from the cosine law L2² = L1² + L3² − 2·L1·L3·cos γ,
    # differentiated without using θ' so eq. 2.3 is an independent route to v_B.
    cos_g = np.clip((L1**2 + L3**2 - L2**2) / (2.0 * L1 * L3), -1.0, 1.0)
    sin_g = np.sqrt(1.0 - cos_g**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        dgamma = (L1 * cos_g - L3) * dL3 / (L1 * L3 * sin_g)
    dgamma = np.where(still, 0.0, dgamma)
    # The direction C→B is at angle π − s·γ, so link 3 turns at −s·γ'.
    omega3 = -s * dgamma
    return CrankState(
        theta=theta_int, omega=omega_int, alpha=alpha_int, B=r, vB=vB, aB=aB, omega3=omega3
    )


def vB_via_slider(bed: CrankSlider, slider: SliderState, omega3: ArrayLike) -> NDArray[np.float64]:
    """Velocity of B by the slider route, thesis eq. 2.3 (mm/s).

    ``V_B = V_C3/C4 + ω3 × r_B/C3``: the wire's own rate along C→B plus the
    rotation of the wire about C. It must agree with eq. 2.2; the tests use
    it as a second method.
    """
    L3 = np.asarray(slider.L3, dtype=float)
    dL3 = np.asarray(slider.L3_rate, dtype=float)
    pos = bed.positions(theta_from_l3(L3, bed.L1, bed.L2))
    r_bc = pos["B"] - pos["C"]
    u = r_bc / L3[..., None]
    perp = np.stack([-r_bc[..., 1], r_bc[..., 0]], axis=-1)
    return dL3[..., None] * u + np.asarray(omega3, dtype=float)[..., None] * perp
