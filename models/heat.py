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
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise
from types import SimpleNamespace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import ODEintWarning, odeint, solve_ivp

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
        LSODA (odeint) instead of Dormand–Prince: for fits that simulate many times.
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
    def branch(T: float, xi_start: float, heating: bool) -> tuple[float, float]:
        """(ξ, |dξ/dT|) on the active branch: eqs. 4.3–4.6 in scalar arithmetic (the
        integrator calls this millions of times in a fit, where numpy's per-call cost
        on one number was most of the time)."""
        lo, hi = (w.As_C, w.Af_C) if heating else (w.Mf_C, w.Ms_C)
        x = min(max((T - lo) / (hi - lo), 0.0), 1.0)
        curve = 0.5 * (1.0 + math.cos(math.pi * x))
        if (curve < xi_start) if heating else (curve > xi_start):
            slope = math.pi / (2.0 * (hi - lo)) * math.sin(math.pi * x) if 0 < x < 1 else 0.0
            return curve, slope
        return xi_start, 0.0

    def rhs(_t: float, y: NDArray, amps: float, xi_start: float, heating: bool) -> list[float]:
        T = y[0]
        loss = hA * (T - w.T_amb_C)
        slope = branch(T, xi_start, heating)[1]
        return [(amps**2 * w.R_ohm - loss) / (m * (w.cp_J_kgK + w.dh_J_kg * slope)), loss]

    # Integrate between the current's switching instants, where the right-hand side jumps.
    edges = sorted({t[0], t[-1], *[s for s in current.times_s if t[0] < s < t[-1]]})
    T_now, xi_now, conv_now, gen_now, lat_now = T0, float(xi0), 0.0, 0.0, 0.0
    T_out, xi_out = np.empty(t.size), np.empty(t.size)
    conv_out, gen_out, lat_out = np.empty(t.size), np.empty(t.size), np.empty(t.size)
    T_out[0], xi_out[0], conv_out[0], gen_out[0], lat_out[0] = T0, xi_now, 0.0, 0.0, 0.0
    for a, b in pairwise(edges):
        amps = float(current(a))
        heating = amps**2 * w.R_ohm > hA * (T_now - w.T_amb_C)
        inside = (t > a) & (t <= b)
        # LSODA rejects an output time a rounding error after the start (a grid's
        # 1.4000000000000001 after a switch at 1.4): read such frames a hair later.
        at = np.maximum(t[inside], a + 1e-9 * max(1.0, abs(a)))
        wanted = np.union1d(at, [b])  # b too: the next piece starts from it
        if fast:
            # LSODA in Fortran: several times faster than RK45 with a Python right-hand side.
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ODEintWarning)  # reported below instead
                ys, info = odeint(rhs, [T_now, conv_now], np.concatenate([[a], wanted]),
                                  args=(amps, xi_now, heating), tfirst=True, rtol=rtol,
                                  atol=tol["atol"], full_output=True)
            if info["message"] != "Integration successful.":
                raise CranktrackError(f"the heat-transfer integration failed: {info['message']}")
            sol = SimpleNamespace(y=ys[1:].T)
        else:
            sol = solve_ivp(rhs, (a, b), [T_now, conv_now], method="RK45", t_eval=wanted,
                            args=(amps, xi_now, heating), **tol)
            if not sol.success:
                raise CranktrackError(f"the heat-transfer integration failed: {sol.message}")
        xi = (np.minimum(xi_now, w.xi_heating(sol.y[0])) if heating
              else np.maximum(xi_now, w.xi_cooling(sol.y[0])))  # as branch(), vectorised
        pick = np.searchsorted(wanted, at)
        T_out[inside], conv_out[inside] = sol.y[0][pick], sol.y[1][pick]
        xi_out[inside] = xi[pick]
        gen_out[inside] = gen_now + amps**2 * w.R_ohm * (t[inside] - a)
        lat_out[inside] = lat_now + m * w.dh_J_kg * (xi_now - xi[pick])
        T_now, conv_now = float(sol.y[0][-1]), float(sol.y[1][-1])
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
