"""θ(t) of each base model with whichever candidate effects a set of values switches on.

Three base models (:data:`MODELS`): ``spool`` (the rigid bed of thesis §2.5.2),
``dynamic`` (the free response of eq. 3.28) and ``sma`` (the current-heated bed of
§2.5.3 with the heat model of chapter 4). Each :class:`ModelSpec` says how to
simulate it, where a fit starts from the data (``guesses``) and what must be held
for the rest to be identifiable (``hold``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.optimize import brentq

from ..errors import CranktrackError
from ..models.dynamics import CrankDynamics, free_response
from ..models.heat import CurrentSteps, SMAWire, simulate_wire
from ..models.sma_bed import SMABed, lagged, quasi_static_theta
from ..models.spool import TABLE_2_2, SpoolDrive, spool_motion
from .candidates import (
    CANDIDATES,
    DYNAMIC_BASE,
    DYNAMIC_CANDIDATES,
    SMA_BASE,
    SMA_CANDIDATES,
    SPOOL_BASE,
    Candidate,
    Parameter,
)


def spool_drive(values: dict[str, float]) -> SpoolDrive:
    """The spool drive that the base values name (:data:`.candidates.SPOOL_BASE`)."""
    return SpoolDrive(L1=values["L1_mm"], L2=values["L2_mm"], L3_0=values["L3_0_mm"],
                      speed_mm_s=values["speed_mm_s"], start_s=values["start_s"],
                      stroke_mm=values["stroke_mm"])


def spool_theta(values: dict[str, float], t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """θ (rad) of the spool model with whichever candidate effects ``values`` sets.

    Raises :class:`CranktrackError` when the values give a linkage that cannot close.
    """
    v = values
    start = v["start_s"]
    # A wrong clock stretches time about the known start, then an offset shifts it.
    tt = start + v.get("clock_scale", 1.0) * (t_s - start) - v.get("time_offset_s", 0.0)
    theta = spool_motion(spool_drive(v), tt, slack_mm=v.get("slack_mm", 0.0),
                         growth_per_s=v.get("spool_growth_per_s", 0.0),
                         ring_hz=v.get("return_spring_hz", 0.0),
                         ring_zeta=v.get("return_spring_zeta", 0.1), rates=False,
                         stretch_mm=v.get("wire_stretch_mm", 0.0),
                         ripple_mm=v.get("drive_ripple_mm", 0.0),
                         ripple_turn_mm=v.get("ripple_turn_mm", 10.0),
                         ripple_phase_deg=v.get("ripple_phase_deg", 0.0),
                         coulomb_rad_s2=v.get("coulomb_rad_s2", 0.0))[0]
    play = v.get("play_deg", 0.0)
    if play:
        # The spring holds the crank on its rest side of the play until the wire has
        # turned the whole play; from then on the crank trails by all of it.
        rest = float(spool_drive(v).bed.theta(v["L3_0_mm"]))
        theta = np.minimum(theta + np.radians(play), rest)
    if not np.all(np.isfinite(theta)):
        raise CranktrackError("the linkage does not close for these values")
    return theta


def _spool_guess(t: NDArray, theta: NDArray, measured: pd.DataFrame,
                 known: dict[str, float]) -> dict[str, float]:
    """Base values to start from: measured link lengths, the first frames' wire length,
    the thesis's speed, and the start where θ first clearly leaves its first value."""
    def median(col: str, default: float) -> float:
        if col in measured and np.isfinite(measured[col]).any():
            return float(np.nanmedian(measured[col]))
        return default

    L3 = measured["L3_mm"].to_numpy(float) if "L3_mm" in measured else np.full(t.size, np.nan)
    guess = {"L1_mm": median("L1_mm", TABLE_2_2["L1"]), "L2_mm": median("L2_mm", TABLE_2_2["L2"]),
             "L3_0_mm": float(np.nanmedian(L3[:5])) if np.isfinite(L3[:5]).any()
             else TABLE_2_2["L3_0"], "speed_mm_s": TABLE_2_2["speed_mm_s"]}
    guess.update({k: v for k, v in known.items() if k in guess})
    th0 = np.median(theta[:5])
    moved = np.flatnonzero(np.abs(theta - th0) > np.radians(0.5))
    guess["start_s"] = float(t[moved[0]]) - 0.1 if moved.size else float(t[0])
    stroke = guess["L3_0_mm"] - np.nanmin(L3) if np.isfinite(L3).any() else 10.0
    guess["stroke_mm"] = float(max(stroke, 0.1))
    guess.update(known)
    return guess


def dynamic_theta(values: dict[str, float], t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """θ (rad) of the free response (eq. 3.28, unit inertia, ε = 0.05) from t_s[0], with
    stick–slip dry friction and play between wire and crank when ``values`` sets them
    (compiled RK4, 4 ms steps: :func:`cranktrack.models.dynamics.free_response`, a few
    ms for a minute of swing)."""
    v = values
    dyn = CrankDynamics(I=1.0, k_l=v["k_l"], k_s=v["k_s"], k_d=v["k_d"], L1=v["L1_mm"],
                        L2=v["L2_mm"], theta0=np.radians(v["theta_rest_deg"]),
                        coulomb=v.get("coulomb_rad_s2", 0.0),
                        play=np.radians(v.get("play_deg", 0.0)))
    return free_response(dyn, t_s, np.radians(v["theta_init_deg"]), v["omega_init_rad_s"])[0]


@dataclass(frozen=True)
class ModelSpec:
    """A base model the loop can fit: its parameters, simulation, effect library,
    starting values (``guesses``: data → list of full value sets) and what must be held
    for the rest to be identifiable (``hold``: data, known → extra values, messages)."""

    name: str
    base: dict[str, Parameter]
    simulate: Callable[[dict[str, float], NDArray[np.float64]], NDArray[np.float64]]
    candidates: dict[str, Candidate]
    guesses: Callable[[NDArray, NDArray, pd.DataFrame, dict[str, float]], list[dict]]
    hold: Callable[[pd.DataFrame, dict[str, float]], tuple[dict[str, float], list[str]]]
    #: Relative step of the fit's finite-difference Jacobian: well above the
    #: simulation's own error, or the Jacobian is noise.
    diff_step: float = 1e-7
    #: How many of the data's guesses an effect's fit also starts from, besides where
    #: the base fit ended. One, unless the model is cheap and its guesses differ in
    #: ways an effect needs (the free response's damping: dry friction looks like more).
    effect_guesses: int = 1


def _measured_median(measured: pd.DataFrame, col: str) -> float | None:
    if col in measured and np.isfinite(measured[col]).any():
        return float(np.nanmedian(measured[col]))
    return None


def _spool_hold(measured: pd.DataFrame, known: dict[str, float]
                ) -> tuple[dict[str, float], list[str]]:
    if "speed_mm_s" in known or {"L1_mm", "L2_mm", "L3_0_mm"} & set(known):
        return {}, []
    # θ(t) is unchanged when every length and the speed scale together: one length must
    # be held, and the frame |AC| is measured directly.
    L1 = _measured_median(measured, "L1_mm")
    if L1 is None:
        raise CranktrackError("with the speed unknown, give --known L1_mm (one length fixes "
                              "the scale)")
    return {"L1_mm": L1}, [f"L1_mm held at the measured |AC| = {L1:.3f} mm: with the speed "
                           "unknown, one length must fix the scale"]


def _spool_guesses(t: NDArray, theta: NDArray, measured: pd.DataFrame,
                   held: dict[str, float]) -> list[dict]:
    guess = _spool_guess(t, theta, measured, held)
    if "start_s" in held:
        return [guess]
    span = float(t[-1] - t[0])
    return [guess] + [{**guess, "start_s": guess["start_s"] + sh}
                      for sh in (-0.05 * span, 0.05 * span)]


def _hold_links(measured: pd.DataFrame, known: dict[str, float], why: str = ""
                ) -> tuple[dict[str, float], list[str]]:
    """L1 and L2 held at the measured |AC| and |AB| unless known."""
    out, notes = {}, []
    for col, what in (("L1_mm", "|AC|"), ("L2_mm", "|AB|")):
        if col not in known:
            value = _measured_median(measured, col)
            if value is None:
                raise CranktrackError(f"give --known {col}: the run has no measured {what}")
            out[col] = value
            notes.append(f"{col} held at the measured {what} = {value:.3f} mm{why}")
    return out, notes


def _dynamic_hold(measured: pd.DataFrame, known: dict[str, float]
                  ) -> tuple[dict[str, float], list[str]]:
    return _hold_links(measured, known, " (the wire stiffness absorbs what a free length "
                       "would)")


def _dynamic_guesses(t: NDArray, theta: NDArray, measured: pd.DataFrame,
                     held: dict[str, float]) -> list[dict]:
    """From the swing itself: its first angle and rate, where it settles, its frequency
    (crossings of the settling angle) and its decay.

    A crossing counts only between excursions beyond 5σ of the tracker's noise on
    each side: a crank that has stopped (dry friction) sits on its settling angle
    and the noise alone would cross it every other frame, making the swing look
    fifty times faster than it is."""
    deg = np.degrees(theta)
    rest = float(np.median(deg[-max(3, deg.size // 4):]))
    x = deg - rest
    col = next((c for c in ("theta_deg_sigma_tracker", "theta_deg_sigma") if c in measured),
               None)
    sigma = float(np.nanmedian(measured[col])) if col is not None else 0.0
    big = np.flatnonzero(np.abs(x) > 5.0 * (sigma if np.isfinite(sigma) else 0.0))
    turns = np.flatnonzero(np.sign(x[big][1:]) != np.sign(x[big][:-1]))
    crossings = 0.5 * (t[big][turns] + t[big][turns + 1])
    period = 2.0 * float(np.median(np.diff(crossings))) if crossings.size > 2 \
        else float(t[-1] - t[0])
    wn = 2.0 * np.pi / max(period, 1e-6)
    base = {"theta_init_deg": float(deg[0]),
            "omega_init_rad_s": float((theta[1] - theta[0]) / (t[1] - t[0])),
            "k_l": wn**2, "k_s": 0.0, "theta_rest_deg": rest, **held}
    # The decay seen, as a damping ratio from the mean log decrement per half swing
    # (dry friction shows here too, so it comes first: the effect's fit starts there).
    halves = np.split(np.abs(x), np.searchsorted(t, crossings))
    peaks = np.array([h.max() for h in halves if h.size])
    zetas = [0.05, 0.2]
    if peaks.size >= 3 and peaks[-1] > 0:
        delta = float(np.log(peaks[0] / peaks[-1])) / (peaks.size - 1)
        zetas.insert(0, float(np.clip(delta / np.hypot(np.pi, delta), 0.01, 0.7)))
        # The same decay as dry friction alone, which costs 2μ/ωn² of amplitude every
        # half swing: a start for that effect's fit (its least squares has a valley
        # for each number of swings before the crank sticks).
        loss = float(np.radians(peaks[0] - peaks[-1])) / (peaks.size - 1)
        base["coulomb_rad_s2"] = 0.5 * loss * wn**2
    guesses = [{**base, "k_d": 2.0 * zeta * wn} for zeta in zetas]
    # From k_s = 0 the wire does nothing, and an effect that acts through it (play)
    # cannot be fitted there: also start from the wire carrying most of the stiffness.
    shared = _wire_sharing(guesses[0], wn, 0.75, held)
    if shared:
        guesses.insert(1, shared)
    return guesses


def _wire_sharing(guess: dict[str, float], wn: float, share: float,
                  held: dict[str, float]) -> dict[str, float] | None:
    """``guess`` with the wire giving ``share`` of the stiffness ωn² (1/s²) and the
    torsion spring the rest, its rest angle moved so the crank still settles where the
    swing does; None where no such angle is within 60° of it."""
    rest = np.radians(guess["theta_rest_deg"])
    L1, L2 = held.get("L1_mm", 1.0), held.get("L2_mm", 1.0)
    per_k_s = -float(CrankDynamics(I=1.0, k_l=0.0, k_s=1.0, L1=L1, L2=L2,
                                   theta0=rest).daccel_dtheta(rest))
    if not per_k_s > 0:
        return None
    k_l, k_s = (1.0 - share) * wn**2, share * wn**2 / per_k_s

    def settles_off(theta0: float) -> float:
        return float(CrankDynamics(I=1.0, k_l=k_l, k_s=k_s, L1=L1, L2=L2,
                                   theta0=theta0).accel(rest))

    lo, hi = rest - np.radians(60.0), rest + np.radians(60.0)
    if settles_off(lo) * settles_off(hi) > 0:
        return None
    theta0 = brentq(settles_off, lo, hi, xtol=1e-10)
    return {**guess, "k_l": k_l, "k_s": k_s, "theta_rest_deg": float(np.degrees(theta0))}


def sma_theta(values: dict[str, float], t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """θ (rad) of the SMA bed: the heat model on a 5 ms grid (LSODA, rtol 1e-7), ξ through the
    optional thermal lag, and the crank where the torques balance (relaxing towards
    it through the damper; held by the optional dry friction): within 0.04° of the
    full equation of motion, a hundred times faster."""
    v = values
    dt = v.get("time_offset_s", 0.0)
    if not v["current_off_s"] > v["current_on_s"]:
        raise CranktrackError("current_off_s must come after current_on_s")
    current = CurrentSteps((v["current_on_s"] + dt, v["current_off_s"] + dt),
                           (v["current_A"], 0.0))
    wire = SMAWire(h_W_m2K=v["h_W_m2K"], T_amb_C=v["ambient_C"], As_C=v["As_C"],
                   Af_C=v["Af_C"], Ms_C=v["Ms_C"], Mf_C=v["Mf_C"])
    bed = SMABed(L1=v["L1_mm"], L2=v["L2_mm"], theta0_deg=v["theta0_deg"],
                 recovery_strain=v["recovery_strain"], thermal=wire,
                 thermal_lag_s=v.get("thermal_lag_s", 0.0),
                 damping_Nms_rad=SMABed.damping_Nms_rad + v.get("damping_Nms_rad", 0.0))
    t = np.asarray(t_s, float)
    fine = np.arange(min(0.0, t[0]), t[-1] + 0.01, 0.005)
    heat = simulate_wire(bed.wire, current, fine, rtol=1e-7, fast=True)
    xi = lagged(heat.xi, fine, bed.thermal_lag_s)
    return np.interp(t, fine, quasi_static_theta(bed, xi, fine,
                                                 coulomb_Nm=v.get("coulomb_Nm", 0.0)))


def _sma_hold(measured: pd.DataFrame, known: dict[str, float]
              ) -> tuple[dict[str, float], list[str]]:
    for name in ("current_A", "current_on_s"):
        if name not in known:
            raise CranktrackError(f"the sma model needs --known {name} (what the power supply "
                                  "did is an input, not something to fit)")
    out, notes = {}, []
    if "current_off_s" not in known:
        out["current_off_s"] = float(np.nanmax(measured["t_s"])) + 1.0
        notes.append("current_off_s not given: the current stays on to the end of the clip")
    if "ambient_C" not in known:
        out["ambient_C"] = SMAWire().T_amb_C
        notes.append(f"ambient_C held at {out['ambient_C']:g} °C (thesis Table 4.2)")
    links, link_notes = _hold_links(measured, known)
    return {**out, **links}, notes + link_notes


def _sma_guesses(t: NDArray, theta: NDArray, measured: pd.DataFrame,
                 held: dict[str, float]) -> list[dict]:
    w = SMAWire()
    return [{"theta0_deg": float(np.degrees(np.median(theta[:5]))), "recovery_strain": 0.0325,
             "h_W_m2K": w.h_W_m2K, "As_C": w.As_C, "Af_C": w.Af_C, "Ms_C": w.Ms_C,
             "Mf_C": w.Mf_C, **held}]


MODELS: dict[str, ModelSpec] = {
    "spool": ModelSpec("spool", SPOOL_BASE, spool_theta, CANDIDATES, _spool_guesses,
                       _spool_hold),
    "dynamic": ModelSpec("dynamic", DYNAMIC_BASE, dynamic_theta, DYNAMIC_CANDIDATES,
                         _dynamic_guesses, _dynamic_hold, diff_step=1e-4, effect_guesses=4),
    "sma": ModelSpec("sma", SMA_BASE, sma_theta, SMA_CANDIDATES, _sma_guesses, _sma_hold,
                     diff_step=1e-3),
}

#: What ``--known`` takes: each model's base parameters, and the lens's horizontal
#: field of view, which the tilt candidates need.
KNOWN_NAMES = {name: (*spec.base, "hfov_deg") for name, spec in MODELS.items()}


def known_names(model: str) -> tuple[str, ...]:
    """The parameters ``model`` takes as known (:data:`KNOWN_NAMES`); one sentence if the
    model cannot be fitted."""
    names = KNOWN_NAMES.get(model)
    if names is None:
        raise CranktrackError(f"the {model!r} model cannot be fitted yet; available: "
                              f"{', '.join(KNOWN_NAMES)}")
    return names
