"""The SMA wire as a material and as an actuator (thesis §2.3).

Three pieces, each read from the thesis as literally as the text allows:

**The stress–strain–temperature envelope** (eqs. 2.6, 2.7, Fig. 2.12).
Strain ε in %, stress σ in MPa, temperature T in °C. Each isotherm is the
fitted cubic of eq. 2.6 with the strain offset of eq. 2.7 as printed
(ε shifted by −0.03·(100 − T)), so a cooler isotherm rises earlier and tops
out lower::

    σ_T(ε) = −15.4·x³ + 480·x + 21 − 12.5·(100 − T),   x = ε + 0.03·(100 − T)

The cubic peaks at x = √(480/46.2) ≈ 3.22 %; past its peak the isotherm
continues with the linear slope of 0.1 (MPa per %) "to complete strains up
to 3.25 %". Stress is floored at zero (a wire carries no compression).
Below about 1.2 % strain a hotter isotherm sits slightly lower (at most
1.9 MPa per °C); that is the fit's doing, and it does not touch the blocked
force. With this reading the 25 °C isotherm plateaus at 115 MPa from 0.97 % strain
on — the thesis's "3.25 % at the stress level of 100 MPa" detwinning — and
the 100 °C isotherm is eq. 2.6 itself (48 GPa, 1052 MPa at its peak, the
austenite "yield at 1100 MPa" of Fig. 2.10).

**The actuator characteristic curve** (eqs. 2.8, 2.9, Fig. 2.14). A wire
pre-strained to ε_L = 3.25 % in martensite is heated to the hot isotherm in
series with a linear spring between two rigid bodies; the spring stretches
by what the wire shortens (constant length, 2.9) and carries the wire's
stress (force balance, 2.8). Sweeping the spring from 0 (free stroke) to ∞
(blocked force) traces the curve. Its linearisation is the straight line
through the same blocked force and free stroke (§2.3.4).

**Maximum work over start and final temperature** (eqs. 2.10–2.12, Figs.
2.17–2.21). The wire starts unloaded on the re-heating line, ε₀(T) falling
linearly from 3.2 % at M_f to 0 at A_f, and is heated to T_f; the work is
the area under the actuation curve at T_f between the free strain ε₀(T_f)
and the start strain ε₀(T_i). For the linear envelope of eq. 2.10 the
isotherm's strain is counted from its own unloaded point, so the actuation
curve is a straight line and eq. 2.11 (½·σ·Δε) and the trapezoid rule of
eq. 2.12 must agree to rounding.

Work densities are in MJ/m³ (MPa × strain fraction); forces in N for the
250 µm wire of §2.3.2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq

from ..errors import CranktrackError
from .grid import grid_max

#: Recoverable (pre-)strain of the idealised wire, % (§2.3.3).
PRESTRAIN_PCT = 3.25
#: Where the cubic of eq. 2.6 peaks, %: dσ/dx = 480 − 46.2·x² = 0.
CUBIC_PEAK_PCT = float(np.sqrt(480.0 / 46.2))
#: Slope of the isotherms past the cubic's peak, MPa per % (§2.3.3, "a linear slope of 0.1").
PLATEAU_SLOPE = 0.1
#: Diameter of the characterised Dynalloy wire, m (§2.3.2).
WIRE_DIAMETER_M = 250e-6
#: Eq. 2.10: thermal stress scalar α (1/°C) and strain stress scalar S (% per MPa).
ALPHA_PER_C = 0.135
S_PCT_PER_MPA = 0.035
#: The re-heating line of §2.3.6 starts at this strain at M_f, %.
REHEAT_STRAIN_PCT = 3.2


def _cubic(x: NDArray) -> NDArray:
    return -15.4 * x**3 + 480.0 * x + 21.0


def envelope_stress(strain_pct: ArrayLike, T_C: ArrayLike) -> NDArray[np.float64]:
    """Stress on the isotherm at ``T_C`` (°C) at ``strain_pct`` (%), MPa (eqs. 2.6–2.7).

    Broadcasts over both arguments.

    Examples
    --------
    >>> round(float(envelope_stress(1.0, 100.0)), 1)  # eq. 2.6 itself at 100 °C
    485.6
    """
    eps = np.asarray(strain_pct, float)
    dT = 100.0 - np.asarray(T_C, float)
    x = eps + 0.03 * dT
    top = _cubic(np.asarray(CUBIC_PEAK_PCT)) - 12.5 * dT
    sigma = np.where(x <= CUBIC_PEAK_PCT, _cubic(x) - 12.5 * dT,
                     top + PLATEAU_SLOPE * (x - CUBIC_PEAK_PCT))
    # Below the cubic's rising branch (x < −3.22 %) the wire is slack, not pulling again.
    sigma = np.where(x < -CUBIC_PEAK_PCT, 0.0, sigma)
    return np.maximum(sigma, 0.0)


def unloaded_strain(T_C: float) -> float:
    """Strain where the isotherm at ``T_C`` reaches zero stress, % (may be negative).

    Negative on hot isotherms: eq. 2.6 still pulls 21 MPa at zero strain, so
    the unloaded wire is slightly shorter than the strain origin.
    """
    dT = 100.0 - T_C
    if _cubic(CUBIC_PEAK_PCT) <= 12.5 * dT:
        raise CranktrackError(f"the envelope carries no stress below the cubic's peak at "
                              f"{T_C} °C: it is defined above about 16 °C")
    # On the cubic's rising branch the stress is monotone in x; find its zero.
    x0 = brentq(lambda x: _cubic(x) - 12.5 * dT, -CUBIC_PEAK_PCT, CUBIC_PEAK_PCT)
    return float(x0 - 0.03 * dT)


@dataclass(frozen=True)
class ActuatorCurve:
    """Force against stroke for a wire actuator, from blocked (stroke 0) to free.

    ``stroke_pct`` is the wire's contraction in % of its length (ascending from
    0); ``force_N`` the force it pulls with there (descending to 0).
    """

    stroke_pct: NDArray[np.float64]
    force_N: NDArray[np.float64]
    spring: NDArray[np.float64]  # series spring stiffness per unit wire, MPa per %; inf = blocked

    @property
    def blocked_N(self) -> float:
        return float(self.force_N[0])

    @property
    def free_pct(self) -> float:
        return float(self.stroke_pct[-1])

    def force_at(self, fraction: ArrayLike) -> NDArray[np.float64]:
        """Force at ``fraction`` of the free stroke (0 = blocked, 1 = free), N."""
        return np.interp(np.asarray(fraction, float) * self.free_pct, self.stroke_pct,
                         self.force_N)

    def linearised(self) -> ActuatorCurve:
        """The straight line through the same blocked force and free stroke (§2.3.4)."""
        u = self.stroke_pct
        return ActuatorCurve(u, self.blocked_N * (1.0 - u / self.free_pct), self.spring)

    def work_J_per_m(self) -> float:
        """Area under the curve per metre of wire, J/m (trapezoid, eq. 2.12)."""
        return float(np.trapezoid(self.force_N, self.stroke_pct / 100.0))


#: The hot state of the characterisation tests: "above the austenite final temperature to 65 °C".
T_HOT_C = 65.0


def actuator_curve(T_hot_C: float = T_HOT_C, prestrain_pct: float = PRESTRAIN_PCT,
                   diameter_m: float = WIRE_DIAMETER_M, n: int = 201) -> ActuatorCurve:
    """The actuator characteristic curve by the series-spring force balance (eqs. 2.8–2.9).

    The wire, pre-strained to ``prestrain_pct`` cold, is heated to ``T_hot_C``
    in series with a spring of stiffness K (stress per % of wire strain). At
    equilibrium σ_T(ε) = K·(ε_L − ε): the spring takes up what the wire gives.
    K runs from 0 (free stroke) to ∞ (blocked) over ``n`` values spaced so the
    points spread evenly along the curve.
    """
    if not 0.0 < prestrain_pct <= 10.0:
        raise CranktrackError(f"pre-strain must be in (0, 10] %, not {prestrain_pct}")
    eps_free = unloaded_strain(T_hot_C)
    if eps_free >= prestrain_pct:
        raise CranktrackError(f"at {T_hot_C} °C the wire is unloaded at {eps_free:.2f} % "
                              f"strain, beyond the {prestrain_pct} % pre-strain: it does not "
                              "contract")
    area_mm2 = np.pi * (diameter_m * 1e3) ** 2 / 4.0
    blocked = float(envelope_stress(prestrain_pct, T_hot_C))
    # Springs chosen by the strain they would leave: K = σ(ε)/(ε_L − ε) over ε in (free, L).
    target = np.linspace(eps_free, prestrain_pct, n)[1:-1]
    K = np.concatenate([[0.0], envelope_stress(target, T_hot_C) / (prestrain_pct - target),
                        [np.inf]])
    eps = np.empty_like(K)
    for i, k in enumerate(K):
        if k == 0.0:
            eps[i] = eps_free
        elif np.isinf(k):
            eps[i] = prestrain_pct
        else:
            eps[i] = brentq(lambda e, k=k: float(envelope_stress(e, T_hot_C))
                            - k * (prestrain_pct - e), eps_free, prestrain_pct, xtol=1e-13)
    sigma = envelope_stress(eps, T_hot_C)
    sigma[-1] = blocked
    order = np.argsort(prestrain_pct - eps)
    return ActuatorCurve((prestrain_pct - eps)[order], (sigma * area_mm2)[order], K[order])


def reheat_strain(T_C: ArrayLike, Mf_C: float = 25.0, Af_C: float = 70.0) -> NDArray:
    """The unloaded re-heating line of §2.3.6: 3.2 % at M_f falling to 0 at A_f, %."""
    T = np.clip(np.asarray(T_C, float), Mf_C, Af_C)
    return REHEAT_STRAIN_PCT * (Af_C - T) / (Af_C - Mf_C)


def linear_modulus(T_C: ArrayLike, Mf_C: float = 25.0) -> NDArray:
    """Slope of the linear isotherm of eq. 2.10, MPa per %: (1/S)·(α·(T − M_f) + 1)."""
    return (ALPHA_PER_C * (np.asarray(T_C, float) - Mf_C) + 1.0) / S_PCT_PER_MPA


@dataclass(frozen=True)
class WorkMap:
    """Work density (MJ/m³) over start (rows) and final (columns) temperature, °C."""

    Ti_C: NDArray[np.float64]
    Tf_C: NDArray[np.float64]
    work_MJ_m3: NDArray[np.float64]  # NaN where T_f ≤ T_i

    @property
    def per_kelvin(self) -> NDArray[np.float64]:
        """Work per degree of heating, MJ/(m³·K) (Figs. 2.19, 2.21)."""
        dT = self.Tf_C[None, :] - self.Ti_C[:, None]
        return self.work_MJ_m3 / np.where(dT > 0, dT, np.nan)

    def optimum(self) -> tuple[float, float, float]:
        """(largest work MJ/m³, its T_i, its T_f)."""
        w, tf, ti = grid_max(self.work_MJ_m3, self.Tf_C, self.Ti_C)
        return w, ti, tf

    def optimum_per_kelvin(self) -> tuple[float, float, float]:
        """(largest work per degree MJ/(m³·K), its T_i, its T_f)."""
        w, tf, ti = grid_max(self.per_kelvin, self.Tf_C, self.Ti_C)
        return w, ti, tf


def max_work_map(Ti_C: ArrayLike, Tf_C: ArrayLike, envelope: str = "linear",
                 method: str = "analytic", n_panels: int = 50, Mf_C: float = 25.0,
                 Af_C: float = 70.0) -> WorkMap:
    """Work of a full actuation from T_i to T_f (eqs. 2.10–2.12), MJ/m³.

    ``envelope`` "linear" uses eq. 2.10's isotherms; "nonlinear" the envelope of
    eqs. 2.6–2.7 (:func:`envelope_stress`), each counted from its own unloaded
    strain. ``method`` "analytic" is eq. 2.11 (linear only), "trapezoid" eq. 2.12
    with ``n_panels`` panels.
    """
    Ti = np.asarray(Ti_C, float)
    Tf = np.asarray(Tf_C, float)
    if envelope not in ("linear", "nonlinear") or method not in ("analytic", "trapezoid"):
        raise CranktrackError("envelope is linear or nonlinear; method analytic or trapezoid")
    if envelope == "nonlinear" and method == "analytic":
        raise CranktrackError("eq. 2.11 holds for the linear envelope only; use trapezoid")
    stroke = reheat_strain(Ti, Mf_C, Af_C)[:, None] - reheat_strain(Tf, Mf_C, Af_C)[None, :]
    valid = Tf[None, :] > Ti[:, None]
    stroke = np.where(valid, stroke, 0.0)
    if method == "analytic":
        sigma = linear_modulus(Tf, Mf_C)[None, :] * stroke
        work = 0.5 * sigma * stroke / 100.0
    else:
        s = np.linspace(0.0, 1.0, n_panels + 1)
        de = stroke[..., None] * s  # strain above the isotherm's unloaded point, %
        if envelope == "linear":
            f = linear_modulus(Tf, Mf_C)[None, :, None] * de
        else:
            zero = np.array([unloaded_strain(t) for t in Tf])
            f = envelope_stress(zero[None, :, None] + de, Tf[None, :, None])
        work = np.trapezoid(f, de, axis=-1) / 100.0
    return WorkMap(Ti, Tf, np.where(valid, work, np.nan))
