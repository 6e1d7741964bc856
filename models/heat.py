"""Heat transfer in a Joule-heated SMA wire (thesis chapter 4, Table 4.1).

The lumped model of eq. 4.2: a wire of uniform temperature T, heated by
I²R, cooled by natural convection, storing heat as internal energy and as
the latent heat of the martensite ↔ austenite transformation::

    m·c_p·T' + m·Δh·|ξ'(T)|·T' = I²R − h·A_s·(T − T∞)

The martensite fraction ξ follows the cosine kinetics of eqs. 4.3/4.5 with
hysteresis: on heating it falls along the austenite curve between A_s and
A_f, on cooling it rises along the martensite curve between M_s and M_f, and
otherwise it keeps its value. Heating *absorbs* latent heat (it slows the
temperature rise: the wire looks heavier), cooling releases it — the sign
that eq. 4.2's ``− m·Δh·dξ/dt`` on the left gives, since ξ falls on heating.

Units: SI with temperatures in °C (only differences matter), time in s,
energy in J. Defaults are the constants the thesis uses (Tables 4.2 and
4.4, the starred values): d = 250 µm, L = 115 mm, ρ = 6450 kg/m³, c_p =
250 J/(kg·K), h = 625 W/(m²·K), R = 2.3 Ω, Δh = 30 000 J/kg, T∞ = 23 °C,
A_s/A_f = 55/70 °C, M_s/M_f = 50/25 °C.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from ..errors import CranktrackError


@dataclass(frozen=True)
class SMAWire:
    """A Joule-heated SMA wire (defaults: thesis Tables 4.2/4.4)."""

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

    def __post_init__(self) -> None:
        if not (self.Mf_C < self.Ms_C and self.As_C < self.Af_C):
            raise CranktrackError("transformation temperatures must satisfy Mf < Ms and As < Af")
        for name in ("diameter_m", "length_m", "density_kg_m3", "cp_J_kgK", "h_W_m2K",
                     "R_ohm"):
            if not getattr(self, name) > 0:
                raise CranktrackError(f"{name} must be positive, not {getattr(self, name)}")

    @property
    def mass_kg(self) -> float:
        return self.density_kg_m3 * np.pi * self.diameter_m**2 / 4.0 * self.length_m

    @property
    def surface_m2(self) -> float:
        """Convective (lateral) surface A_s, m²."""
        return np.pi * self.diameter_m * self.length_m

    @property
    def hA_W_K(self) -> float:
        return self.h_W_m2K * self.surface_m2

    @property
    def time_constant_s(self) -> float:
        """m·c_p / (h·A_s): the e-folding time away from any transformation, s."""
        return self.mass_kg * self.cp_J_kgK / self.hA_W_K

    def steady_temperature(self, current_A: ArrayLike) -> NDArray[np.float64]:
        """Eq. 4.26: T = T∞ + I²R / (h·A_s), °C."""
        i = np.asarray(current_A, dtype=float)
        return self.T_amb_C + i**2 * self.R_ohm / self.hA_W_K

    def current_for(self, temperature_C: float) -> float:
        """The steady current that holds the wire at ``temperature_C``, A."""
        return float(np.sqrt(max(temperature_C - self.T_amb_C, 0.0) * self.hA_W_K / self.R_ohm))

    def xi_heating(self, T: ArrayLike) -> NDArray[np.float64]:
        """Eq. 4.3: martensite fraction on the heating curve (1 below A_s, 0 above A_f)."""
        x = np.clip((np.asarray(T, float) - self.As_C) / (self.Af_C - self.As_C), 0.0, 1.0)
        return 0.5 * (1.0 + np.cos(np.pi * x))

    def xi_cooling(self, T: ArrayLike) -> NDArray[np.float64]:
        """Eq. 4.5: martensite fraction on the cooling curve (1 below M_f, 0 above M_s)."""
        x = np.clip((np.asarray(T, float) - self.Mf_C) / (self.Ms_C - self.Mf_C), 0.0, 1.0)
        return 0.5 * (1.0 + np.cos(np.pi * x))

    def _slope(self, T: float, lo: float, hi: float) -> float:
        """|dξ/dT| of a cosine branch between ``lo`` and ``hi`` (eqs. 4.4, 4.6), 1/K."""
        if not lo < T < hi:
            return 0.0
        return float(np.pi / (2.0 * (hi - lo)) * np.sin(np.pi * (T - lo) / (hi - lo)))


@dataclass(frozen=True)
class CurrentSteps:
    """A piecewise-constant current: ``amps[k]`` from ``times_s[k]`` until the next time.

    Before the first time the current is 0.
    """

    times_s: tuple[float, ...]
    amps: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.times_s) != len(self.amps) or not self.times_s:
            raise CranktrackError("a current profile needs as many times as currents (≥ 1)")
        if np.any(np.diff(self.times_s) <= 0):
            raise CranktrackError("current step times must increase")

    def __call__(self, t_s: ArrayLike) -> NDArray[np.float64]:
        t = np.asarray(t_s, dtype=float)
        k = np.searchsorted(np.asarray(self.times_s), t, side="right") - 1
        return np.where(k >= 0, np.asarray(self.amps)[np.maximum(k, 0)], 0.0)


@dataclass(frozen=True)
class WireResponse:
    """Temperature, martensite fraction and the energy split over time.

    Energies are cumulative from the start, J: ``generated`` (∫I²R),
    ``convected`` (∫hA(T − T∞), heat lost), ``latent`` (absorbed by the
    transformation; negative when released on cooling) and ``internal``
    (m·c_p·(T − T0)). ``generated = internal + latent + convected``.
    """

    t_s: NDArray[np.float64]
    T_C: NDArray[np.float64]
    xi: NDArray[np.float64]
    current_A: NDArray[np.float64]
    generated_J: NDArray[np.float64]
    convected_J: NDArray[np.float64]
    latent_J: NDArray[np.float64]
    internal_J: NDArray[np.float64]

    def energy_imbalance_J(self) -> NDArray[np.float64]:
        """``generated − internal − latent − convected`` (zero up to the integrator)."""
        return self.generated_J - self.internal_J - self.latent_J - self.convected_J


#: The longest step of ``simulate_wire(fast=True)``, s: a sixtieth of the wire's
#: time constant (0.16 s for Table 4.2's wire); with the limit on T's change below,
#: classical Runge–Kutta keeps ξ within 1e-5 of the adaptive solve (tests/test_heat.py).
FAST_STEP_S = 2.5e-3
#: ... and the most T may change in one step, K: a fiftieth of a transformation
#: window, whose cosine the steps must follow.
FAST_CHANGE_K = 0.3


@njit(cache=True, nogil=True)
def _latent_from(xi_start: float, lo: float, hi: float) -> float:
    """The temperature (°C) where the active cosine branch (eqs. 4.3–4.6, between
    ``lo`` and ``hi``) meets ξ at the piece's start: ξ follows the branch, and takes
    latent heat, above it when heating and below it when cooling (min/max below)."""
    return lo + (hi - lo) * math.acos(min(max(2.0 * xi_start - 1.0, -1.0), 1.0)) / math.pi


@njit(cache=True, nogil=True)
def _heat_rate(T: float, power_W: float, latent: bool, lo: float, hi: float,
               wire: tuple[float, float, float, float, float]) -> tuple[float, float]:
    """(T', K/s; convective loss, W) of eq. 4.2 under a constant heating power.

    ``latent``: whether ξ is on the cosine branch between ``lo`` and ``hi``, where
    it takes latent heat; ``wire`` = (hA W/K, T∞ °C, m kg, c_p J/(kg·K), Δh J/kg).
    """
    hA, T_amb, m, cp, dh = wire
    x = min(max((T - lo) / (hi - lo), 0.0), 1.0)
    slope = math.pi / (2.0 * (hi - lo)) * math.sin(math.pi * x) if latent else 0.0
    loss = hA * (T - T_amb)
    return (power_W - loss) / (m * (cp + dh * slope)), loss


@njit(cache=True, nogil=True)
def _rk4_step(T: float, conv: float, h: float, power_W: float, latent: bool, lo: float,
              hi: float, wire: tuple[float, float, float, float, float]) -> tuple[float, float]:
    k1, l1 = _heat_rate(T, power_W, latent, lo, hi, wire)
    k2, l2 = _heat_rate(T + 0.5 * h * k1, power_W, latent, lo, hi, wire)
    k3, l3 = _heat_rate(T + 0.5 * h * k2, power_W, latent, lo, hi, wire)
    k4, l4 = _heat_rate(T + h * k3, power_W, latent, lo, hi, wire)
    return (T + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4),
            conv + h / 6.0 * (l1 + 2.0 * l2 + 2.0 * l3 + l4))


@njit(cache=True, nogil=True)
def _rk4(T0: float, conv0: float, start: float, times: NDArray, max_step: float,
         max_change: float, power_W: float, xi_start: float, heating: bool, lo: float, hi: float,
         wire: tuple[float, float, float, float, float]) -> tuple[NDArray, NDArray]:
    """T (°C) and the convected energy (J) at ``times`` (s, increasing, after
    ``start``), by classical Runge–Kutta in steps of at most ``max_step`` and short
    enough that T changes by about ``max_change`` (K) at most.

    Where ξ joins its branch the heat capacity jumps (several-fold in the middle of
    a transformation), which would cost a fixed step its order: the step that
    crosses that temperature is cut there, found by bisection.
    """
    T_out, conv_out = np.empty(times.size), np.empty(times.size)
    T_join = _latent_from(xi_start, lo, hi)
    sign = 1.0 if heating else -1.0
    latent = sign * (T0 - T_join) > 0.0
    T, conv, now = T0, conv0, start
    for i in range(times.size):
        rate = abs(_heat_rate(T, power_W, latent, lo, hi, wire)[0])
        span = times[i] - now
        n = max(1, math.ceil(span / max_step - 1e-9), math.ceil(span * rate / max_change))
        h = span / n
        for _ in range(n):
            T_new, conv_new = _rk4_step(T, conv, h, power_W, latent, lo, hi, wire)
            if not latent and sign * (T_new - T_join) > 0.0:
                short, long = 0.0, h
                for _ in range(60):
                    mid = 0.5 * (short + long)
                    if sign * (_rk4_step(T, conv, mid, power_W, False, lo, hi, wire)[0]
                               - T_join) > 0.0:
                        long = mid
                    else:
                        short = mid
                T, conv = _rk4_step(T, conv, long, power_W, False, lo, hi, wire)
                latent = True
                T_new, conv_new = _rk4_step(T, conv, h - long, power_W, True, lo, hi, wire)
            T, conv = T_new, conv_new
        now = times[i]
        T_out[i], conv_out[i] = T, conv
    return T_out, conv_out


def simulate_wire(wire: SMAWire, current: CurrentSteps, t_s: ArrayLike,
                  T0_C: float | None = None, xi0: float = 1.0, rtol: float = 1e-9,
                  fast: bool = False) -> WireResponse:
    """Integrate Table 4.1's equations with Dormand–Prince (RK45, rtol 1e-9).

    Parameters
    ----------
    wire : SMAWire
    current : CurrentSteps
        The current through the wire, A.
    t_s : array_like
        Increasing output times, s; integration starts at ``t_s[0]``.
    T0_C : float, optional
        Initial temperature (default: ambient).
    xi0 : float
        Initial martensite fraction (1: all martensite).
    rtol : float
        Relative tolerance of the integration (a fit may trade accuracy for speed).
    fast : bool
        Classical Runge–Kutta, compiled, in steps of at most ``FAST_STEP_S`` and
        ``FAST_CHANGE_K``, instead of Dormand–Prince (``rtol`` then unused): for fits
        that simulate many times.
    """
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise CranktrackError("output times must be an increasing array of at least 2")
    w = wire
    T0 = w.T_amb_C if T0_C is None else float(T0_C)
    m, hA = w.mass_kg, w.hA_W_K
    tol = {"rtol": rtol, "atol": [rtol, rtol * 1e-3]}

    # Under a constant current T moves monotonically towards its steady value, so
    # within each piece the direction is fixed and ξ is a function of T alone:
    # min(ξ at the piece's start, heating curve) when warming, max(…, cooling
    # curve) when cooling. Integrating T alone avoids the chatter an ODE for ξ
    # with an on/off transformation switch would have.
    constants = (hA, w.T_amb_C, m, w.cp_J_kgK, w.dh_J_kg)

    def rhs(_t: float, y: NDArray, power: float, xi_start: float, heating: bool,
            lo: float, hi: float) -> list[float]:
        T_join = _latent_from(xi_start, lo, hi)
        return list(_heat_rate(y[0], power, y[0] > T_join if heating else y[0] < T_join,
                               lo, hi, constants))

    # Integrate between the current's switching instants, where the right-hand side jumps.
    edges = sorted({t[0], t[-1], *[s for s in current.times_s if t[0] < s < t[-1]]})
    T_now, xi_now, conv_now, gen_now, lat_now = T0, float(xi0), 0.0, 0.0, 0.0
    T_out, xi_out = np.empty(t.size), np.empty(t.size)
    conv_out, gen_out, lat_out = np.empty(t.size), np.empty(t.size), np.empty(t.size)
    T_out[0], xi_out[0], conv_out[0], gen_out[0], lat_out[0] = T0, xi_now, 0.0, 0.0, 0.0
    for a, b in pairwise(edges):
        amps = float(current(a))
        heating = amps**2 * w.R_ohm > hA * (T_now - w.T_amb_C)
        lo, hi = (w.As_C, w.Af_C) if heating else (w.Mf_C, w.Ms_C)
        args = (amps**2 * w.R_ohm, xi_now, heating, lo, hi)
        inside = (t > a) & (t <= b)
        at = t[inside]
        wanted = np.union1d(at, [b])  # b too: the next piece starts from it
        if fast:
            y = np.stack(_rk4(T_now, conv_now, a, wanted, FAST_STEP_S, FAST_CHANGE_K, *args,
                              constants))
        else:
            sol = solve_ivp(rhs, (a, b), [T_now, conv_now], method="RK45", t_eval=wanted,
                            args=args, **tol)
            if not sol.success:
                raise CranktrackError(f"the heat-transfer integration failed: {sol.message}")
            y = sol.y
        xi = (np.minimum(xi_now, w.xi_heating(y[0])) if heating
              else np.maximum(xi_now, w.xi_cooling(y[0])))  # as _heat_rate, vectorised
        pick = np.searchsorted(wanted, at)
        T_out[inside], conv_out[inside] = y[0][pick], y[1][pick]
        xi_out[inside] = xi[pick]
        gen_out[inside] = gen_now + amps**2 * w.R_ohm * (t[inside] - a)
        lat_out[inside] = lat_now + m * w.dh_J_kg * (xi_now - xi[pick])
        T_now, conv_now = float(y[0][-1]), float(y[1][-1])
        gen_now += amps**2 * w.R_ohm * (b - a)
        lat_now += m * w.dh_J_kg * (xi_now - xi[-1])
        xi_now = float(xi[-1])
    return WireResponse(t, T_out, xi_out, current(t), gen_out, conv_out, lat_out,
                        m * w.cp_J_kgK * (T_out - T0))


def energy_split(response: WireResponse, times_s: Sequence[float]) -> list[dict[str, float]]:
    """The cumulative energies (J) at chosen times, as rows for a table (Figs. 4.3–4.7)."""
    rows = []
    for ts in times_s:
        i = int(np.argmin(np.abs(response.t_s - ts)))
        rows.append({"t_s": float(response.t_s[i]), "T_C": float(response.T_C[i]),
                     "xi": float(response.xi[i]), "generated_J": float(response.generated_J[i]),
                     "internal_J": float(response.internal_J[i]),
                     "latent_J": float(response.latent_J[i]),
                     "convected_J": float(response.convected_J[i])})
    return rows
