"""Thermal system identification of an SMA wire from a test-bed log (thesis §4.4).

The log is a CSV table with one row per sample and these columns:

=================  ====  ==========================================================
``t_s``            s     time
``voltage_V``      V     voltage across the wire
``current_A``      A     current through it
``temperature_C``  °C    wire temperature from the thermocouple
``displacement_mm`` mm   wire contraction (0 = martensite length, grows on heating)
=================  ====  ==========================================================

The current is piecewise constant: a stepped V–I sweep and step tests.
What is identified, each with a 1-σ:

- **R** — slope of V against I over the steady states (eqs. 4.7/4.8);
- **h** — from the steady temperatures, T − T∞ = I²R/(h·A_s) (eqs. 4.10/4.26),
  a least-squares slope against I²;
- **c_p** — from each step that starts below A_s: the time from the step to
  the start of contraction (the wire reaching A_s), by the integral method
  (eq. 4.19) and the derivative method (eq. 4.20);
- **Δh** — from a step that completes the contraction: the time from its
  start to its end (A_s → A_f), eq. 4.25.

Contraction start and end are read off the displacement the way the thesis
does (Fig. 4.13): a line through the rise is intersected with the levels
before and after it. The same times read off the thermocouple instead
(when it crosses A_s and A_f) are reported beside them: a thermocouple
heavier than the wire lags, and the bias it gives c_p and Δh is what the
thesis's Table 4.3 saw.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from itertools import pairwise

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import CranktrackError
from .heat import SMAWire

LOG_COLUMNS = ("t_s", "voltage_V", "current_A", "temperature_C", "displacement_mm")
#: The exponential shape eq. 4.15 assumes: the response reaches T_f at 2.2 time constants.
_E = 2.2


@dataclass(frozen=True)
class Piece:
    """A stretch of constant current: its rows and steady (last quarter) averages."""

    start: int
    stop: int
    t0_s: float
    t1_s: float
    current_A: float
    voltage_V: float
    temperature_C: float
    displacement_mm: float


def pieces(log: pd.DataFrame, step_A: float | None = None) -> list[Piece]:
    """Split the log where the current steps by more than ``step_A``
    (default 2 % of the largest current, at least 5 mA)."""
    i = log["current_A"].to_numpy(float)
    step = step_A if step_A is not None else max(0.02 * float(np.nanmax(np.abs(i))), 0.005)
    cuts = np.flatnonzero(np.abs(np.diff(i)) > step) + 1
    bounds = [0, *cuts.tolist(), len(i)]
    out = []
    t = log["t_s"].to_numpy(float)
    for a, b in pairwise(bounds):
        if b - a < 8:
            continue
        tail = slice(a + 3 * (b - a) // 4, b)
        out.append(Piece(a, b, float(t[a]), float(t[b - 1]),
                         float(np.mean(i[tail])),
                         float(np.mean(log["voltage_V"].to_numpy(float)[tail])),
                         float(np.mean(log["temperature_C"].to_numpy(float)[tail])),
                         float(np.mean(log["displacement_mm"].to_numpy(float)[tail]))))
    return out


def _line_fit(x: NDArray, y: NDArray, origin: bool = False) -> tuple[float, float, float]:
    """Least-squares slope (and intercept) with the slope's standard error."""
    if origin:
        slope = float(x @ y / (x @ x))
        r = y - slope * x
        dof = max(x.size - 1, 1)
        return slope, 0.0, float(np.sqrt(r @ r / dof / (x @ x)))
    A = np.stack([x, np.ones_like(x)], axis=1)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ coef
    dof = max(x.size - 2, 1)
    cov = np.linalg.pinv(A.T @ A) * (r @ r) / dof
    return float(coef[0]), float(coef[1]), float(np.sqrt(cov[0, 0]))


def contraction_times(t: NDArray, d: NDArray, before: float, after: float
                      ) -> tuple[float, float]:
    """Start and end of a contraction (thesis Fig. 4.13): a line through the early
    rise (5–30 % of it) meets the level before it, one through the late rise
    (70–95 %) the level after it. NaN where a part of the rise has < 2 samples."""
    frac = (d - before) / (after - before)

    def meet(lo: float, hi: float, level: float) -> float:
        first = int(np.argmax(frac > lo)) if np.any(frac > lo) else t.size
        last = int(np.argmax(frac >= hi)) if np.any(frac >= hi) else t.size
        if last - first < 2:
            return float("nan")
        slope, icpt, _ = _line_fit(t[first:last], d[first:last])
        return float((level - icpt) / slope) if slope > 0 else float("nan")

    return meet(0.05, 0.3, before), meet(0.7, 0.95, after)


def _crossing(t: NDArray, y: NDArray, level: float) -> float:
    """First time ``y`` reaches ``level`` (linear between samples); NaN if never."""
    above = np.flatnonzero(y >= level)
    if not above.size:
        return float("nan")
    k = above[0]
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (level - y[k - 1]) * (t[k] - t[k - 1]) / (y[k] - y[k - 1]))


def cp_integral(wire: SMAWire, current_A: float, T0: float, Tf: float, dt: float) -> float:
    """Eq. 4.19 (J/(kg·K)): heating from T0 to Tf in ``dt`` seconds at ``current_A``."""
    m, hA, Tinf = wire.mass_kg, wire.hA_W_K, wire.T_amb_C
    dT = Tf - T0
    conv = (Tinf - Tf) - (T0 - Tf) * (1.0 - np.exp(-_E)) / _E
    return float(hA / (m * dT) * conv * dt + current_A**2 * wire.R_ohm * dt / (m * dT))


def cp_derivative(wire: SMAWire, current_A: float, T0: float, Tf: float, dt: float) -> float:
    """Eq. 4.20 (J/(kg·K)): the initial heating rate times Δt over ΔT."""
    q = wire.hA_W_K * (wire.T_amb_C - T0) + current_A**2 * wire.R_ohm
    return float(q / wire.mass_kg * dt / (Tf - T0))


def latent_heat(wire: SMAWire, current_A: float, dt: float) -> float:
    """Eq. 4.25 (J/kg): the transformation from A_s to A_f took ``dt`` seconds."""
    m, hA, Tinf = wire.mass_kg, wire.hA_W_K, wire.T_amb_C
    T0, Tf = wire.As_C, wire.Af_C
    conv = (Tinf - Tf) - (T0 - Tf) * (1.0 - np.exp(-_E)) / _E
    return float(hA / m * conv * dt + current_A**2 * wire.R_ohm * dt / m
                 - wire.cp_J_kgK * (Tf - T0))


@dataclass(frozen=True)
class Estimate:
    """A value with its 1-σ (NaN when there is a single test) and how many tests."""

    value: float
    sigma: float
    n: int
    unit: str

    @classmethod
    def of(cls, values: list[float], unit: str) -> Estimate:
        v = np.asarray([x for x in values if np.isfinite(x)], float)
        if not v.size:
            return cls(float("nan"), float("nan"), 0, unit)
        sd = float(np.std(v, ddof=1) / np.sqrt(v.size)) if v.size > 1 else float("nan")
        return cls(float(v.mean()), sd, int(v.size), unit)


@dataclass(frozen=True)
class ThermalID:
    """Identified parameters, and the per-test numbers behind c_p and Δh."""

    R_ohm: Estimate
    h_W_m2K: Estimate
    T_amb_C: float
    cp_integral: Estimate
    cp_derivative: Estimate
    dh: Estimate
    cp_integral_thermocouple: Estimate
    dh_thermocouple: Estimate
    tests: list[dict] = field(default_factory=list)

    def caveats(self) -> list[str]:
        """Sentences that say why a number in the table is off, where one is."""
        out = []
        cp, cp_d = self.cp_integral.value, self.cp_derivative.value
        if np.isfinite(cp) and np.isfinite(cp_d) and cp_d > 1.15 * cp:
            out.append(
                f"c_p by the derivative method is {100 * (cp_d / cp - 1):+.0f} % against the "
                "integral method: eq. 4.20 keeps the heating rate of the step's first "
                "instant for the whole step, while convection takes more of the power as "
                "the wire warms. The bias is −ln(1 − x)/x − 1, x being the share of the "
                "power convection takes at A_s: large for steps that start far below A_s "
                "or with a small current. Prefer the integral method.")
        for key, timing in (("dh", "the contraction"), ("dh_thermocouple", "the thermocouple")):
            e = getattr(self, key)
            if e.n and e.value < 0:
                out.append(
                    f"Δh timed by {timing} is negative, which no wire does: eq. 4.25 "
                    "subtracts c_p·(A_f − A_s) with that timing's own c_p, and this c_p is "
                    "so large that it takes more than all the energy put in. Read it as "
                    "'this timing cannot give Δh'.")
        tc = self.cp_integral_thermocouple.value
        if np.isfinite(cp) and np.isfinite(tc) and tc > 2 * cp:
            out.append(
                f"c_p timed by the thermocouple is {tc / cp:.1f}× the value timed by the "
                "contraction: a thermocouple heavier than the wire lags it, so it crosses "
                "A_s late and the step looks longer. Trust the contraction's timing "
                "(thesis Fig. 4.13).")
        return out

    def to_dict(self) -> dict:
        out = {"T_amb_C": self.T_amb_C, "tests": self.tests}
        for k in ("R_ohm", "h_W_m2K", "cp_integral", "cp_derivative", "dh",
                  "cp_integral_thermocouple", "dh_thermocouple"):
            e = getattr(self, k)
            out[k] = {"value": e.value, "sigma": e.sigma, "n": e.n, "unit": e.unit}
        return out


def read_log(path) -> pd.DataFrame:
    """A thermal log, checked for the columns of :data:`LOG_COLUMNS`."""
    try:
        log = pd.read_csv(path)
    except FileNotFoundError:
        raise CranktrackError(f"{path} does not exist") from None
    except (pd.errors.ParserError, UnicodeDecodeError, pd.errors.EmptyDataError) as e:
        raise CranktrackError(f"{path} is not a readable CSV table ({e})") from None
    missing = [c for c in LOG_COLUMNS if c not in log.columns]
    if missing:
        raise CranktrackError(f"{path} lacks the column(s) {missing}; a thermal log has "
                              f"{', '.join(LOG_COLUMNS)}")
    if len(log) < 20 or not np.all(np.diff(log["t_s"].to_numpy(float)) > 0):
        raise CranktrackError(f"{path}: need at least 20 rows with increasing t_s")
    return log


def identify(log: pd.DataFrame, wire: SMAWire | None = None, T_amb_C: float | None = None
             ) -> ThermalID:
    """Identify R, h, c_p and Δh from a log (see the module's docstring).

    ``wire`` gives the geometry, density and the transformation temperatures
    A_s and A_f (found beforehand from a displacement–temperature sweep,
    thesis §4.6.2); its R, h, c_p and Δh are the unknowns and are ignored.
    ``T_amb_C``: the ambient temperature (default: the steady temperature at
    zero current).
    """
    wire = wire or SMAWire()
    ps = pieces(log)
    if len(ps) < 3:
        raise CranktrackError("the log has fewer than 3 stretches of constant current; "
                              "a V–I sweep needs several steady steps")
    t = log["t_s"].to_numpy(float)
    T = log["temperature_C"].to_numpy(float)
    d = log["displacement_mm"].to_numpy(float)
    imax = max(abs(p.current_A) for p in ps)
    on = [p for p in ps if abs(p.current_A) > 0.05 * imax]
    R, _, R_sd = _line_fit(np.array([p.current_A for p in on]),
                           np.array([p.voltage_V for p in on]))
    if T_amb_C is None:
        off = [p.temperature_C for p in ps if abs(p.current_A) <= 0.05 * imax]
        if not off:
            raise CranktrackError("no stretch at zero current to read the ambient from; "
                                  "give the ambient temperature")
        T_amb_C = float(np.median(off))
    # Steady states only where the stretch lasts long enough to settle (its last
    # quarter is averaged): over a second, several of the wire's time constants.
    # Eq. 4.26 holds at steady state whatever the phase, so no stretch is left out
    # for having transformed.
    steady = [p for p in on if p.t1_s - p.t0_s > 1.0]
    k, _, k_sd = _line_fit(np.array([p.current_A**2 for p in steady]),
                           np.array([p.temperature_C - T_amb_C for p in steady]), origin=True)
    hA = R / k
    h = hA / wire.surface_m2
    h_sd = h * np.hypot(R_sd / R, k_sd / k)
    w = replace(wire, h_W_m2K=h, R_ohm=R, T_amb_C=T_amb_C)
    tests = []
    # Sample-to-sample noise of the displacement, robust to the steps in it.
    noise = 1.4826 * float(np.median(np.abs(np.diff(d)))) / np.sqrt(2) + 1e-12
    for before, after in pairwise(ps):
        if after.current_A <= before.current_A:
            continue
        seg = slice(after.start, after.stop)
        rise = after.displacement_mm - before.displacement_mm
        if rise <= 10 * noise or before.temperature_C >= wire.As_C:
            continue  # no contraction, or the wire was already transforming
        t_on, t_end = contraction_times(t[seg], d[seg], before.displacement_mm,
                                        after.displacement_mm)
        full = after.temperature_C > wire.Af_C
        tc_on = _crossing(t[seg], T[seg], wire.As_C)
        tc_end = _crossing(t[seg], T[seg], wire.Af_C) if full else float("nan")
        I1, Ti = after.current_A, before.temperature_C
        test = {"t_step_s": after.t0_s, "I_before_A": before.current_A, "I_after_A": I1,
                "T_before_C": Ti, "dt_to_As_s": t_on - after.t0_s,
                "dt_to_As_thermocouple_s": tc_on - after.t0_s, "complete": bool(full),
                "cp_integral": cp_integral(w, I1, Ti, wire.As_C, t_on - after.t0_s),
                "cp_derivative": cp_derivative(w, I1, Ti, wire.As_C, t_on - after.t0_s),
                "cp_integral_thermocouple": cp_integral(w, I1, Ti, wire.As_C,
                                                        tc_on - after.t0_s)}
        if full:
            test["dt_As_to_Af_s"] = t_end - t_on
            test["dt_As_to_Af_thermocouple_s"] = tc_end - tc_on
        tests.append(test)
    cp_int = Estimate.of([x["cp_integral"] for x in tests], "J/(kg·K)")
    cp_tc = Estimate.of([x["cp_integral_thermocouple"] for x in tests], "J/(kg·K)")
    complete = [x for x in tests if x["complete"]]
    dh, dh_tc = [], []
    for x in complete:
        # Eq. 4.25 needs c_p: each timing uses the c_p its own timing gave.
        for key, cp, dt in (("dh", cp_int.value, x["dt_As_to_Af_s"]),
                            ("dh_thermocouple", cp_tc.value, x["dt_As_to_Af_thermocouple_s"])):
            x[key] = (latent_heat(replace(w, cp_J_kgK=cp), x["I_after_A"], dt)
                      if cp > 0 and np.isfinite(dt) else float("nan"))
        dh.append(x["dh"])
        dh_tc.append(x["dh_thermocouple"])
    return ThermalID(Estimate(R, R_sd, len(on), "Ω"), Estimate(h, h_sd, len(steady), "W/(m²·K)"),
                     T_amb_C, cp_int, Estimate.of([x["cp_derivative"] for x in tests],
                                                  "J/(kg·K)"),
                     Estimate.of(dh, "J/kg"), cp_tc, Estimate.of(dh_tc, "J/kg"), tests)
