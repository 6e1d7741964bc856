"""Synthetic thermal test-bed logs with known parameters (for ``thermal-id``).

Each experiment starts from a wire at ambient in full martensite, as the
thesis prepares every test (§4.6.4: re-heated, cooled and re-stretched), and
the experiments are concatenated in time. The thermocouple is a first-order
lag of the wire's temperature (its mass is much larger than the wire's,
thesis §4.6.4), read at its own rate and held between readings, plus noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..models.heat import CurrentSteps, SMAWire, simulate_wire


@dataclass(frozen=True)
class Instruments:
    """How the log is recorded: rates (Hz), the thermocouple's lag (s), noise (1σ)."""

    rate_hz: float = 200.0
    thermocouple_hz: float = 200.0
    thermocouple_tau_s: float = 0.0
    noise_C: float = 0.0
    noise_V: float = 0.0
    noise_A: float = 0.0
    noise_mm: float = 0.0
    recovery_strain: float = 0.0325  # thesis §2.3.3: full recovery of 3.25 % strain


def standard_experiments() -> list[tuple[CurrentSteps, float]]:
    """A V–I sweep (0 → 1.2 A in 0.1 A steps of 15 s), c_p steps from 0, 0.2, 0.4 and
    0.6 A to 1.0 A, and a Δh step from 0 to 1.3 A (full transformation, Fig. 4.5)."""
    sweep = np.round(np.arange(0.0, 1.21, 0.1), 3)
    out = [(CurrentSteps(tuple(15.0 * np.arange(sweep.size)), tuple(sweep)),
            15.0 * sweep.size)]
    for i0 in (0.0, 0.2, 0.4, 0.6):
        out.append((CurrentSteps((0.0, 15.0), (i0, 1.0)), 25.0))
    out.append((CurrentSteps((0.0, 15.0), (0.0, 1.3)), 30.0))
    return out


def thermal_log(wire: SMAWire, experiments: list[tuple[CurrentSteps, float]],
                instruments: Instruments = Instruments(), seed: int = 0) -> pd.DataFrame:
    """The log a test bed would record (columns of :data:`kinematics.thermal_id.LOG_COLUMNS`).

    ``experiments``: (current profile, duration in s) each, run one after another.
    """
    rng = np.random.default_rng(seed)
    ins = instruments
    parts, offset = [], 0.0
    for profile, duration in experiments:
        t = np.arange(0.0, duration, 1.0 / ins.rate_hz)
        r = simulate_wire(wire, profile, t)
        T_tc = r.T_C.copy()
        if ins.thermocouple_tau_s > 0:
            # Exact response of a first-order lag to a temperature linear between samples.
            a = np.exp(-np.diff(t) / ins.thermocouple_tau_s)
            for k in range(1, t.size):
                T_tc[k] = a[k - 1] * T_tc[k - 1] + (1 - a[k - 1]) * r.T_C[k]
        if ins.thermocouple_hz < ins.rate_hz:  # read at its own rate, held in between
            held = np.floor(t * ins.thermocouple_hz) / ins.thermocouple_hz
            T_tc = np.interp(held, t, T_tc)
        parts.append(pd.DataFrame({
            "t_s": offset + t,
            "voltage_V": r.current_A * wire.R_ohm,
            "current_A": r.current_A,
            "temperature_C": T_tc,
            "displacement_mm": ins.recovery_strain * wire.length_m * 1e3 * (1.0 - r.xi)}))
        offset += duration
    log = pd.concat(parts, ignore_index=True)
    n = len(log)
    for col, s in (("voltage_V", ins.noise_V), ("current_A", ins.noise_A),
                   ("temperature_C", ins.noise_C), ("displacement_mm", ins.noise_mm)):
        if s > 0:
            log[col] = log[col] + rng.normal(0.0, s, n)
    return log
