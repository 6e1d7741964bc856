"""Close the loop between measured θ(t) and a model: residual, missing effect, before/after.

Three base models (:data:`MODELS`): ``spool`` (the rigid bed of thesis §2.5.2),
``dynamic`` (the free response of eq. 3.28) and ``sma`` (the current-heated bed of
§2.5.3 with the heat model of chapter 4), each with its own effect library.

1. The base model is fitted by simulation (output error): least squares of
   measured minus simulated θ over every parameter the user did not fix
   (``known``), from several starts.
2. Its residual is diagnosed: RMS, largest, fit%, Ljung–Box whiteness, and
   what it correlates with (time, θ, ω, the sign of ω, the drive's phases,
   the marker's place in the image).
3. Every candidate effect of the model (e.g. :data:`CANDIDATES` for the
   spool, each a model extension with its own physical parameters) is fitted
   on top of the current model.
4. A candidate passes only if ΔBIC > 20 (:data:`BIC_THRESHOLD`), its
   parameter's 95 % interval excludes "no effect", the value is physically
   plausible and its imprint on θ rises above the noise; the passing one
   with the largest ΔBIC is accepted (any that fit as well or better but
   fail are named beside it), then the rest are tried again on top of it,
   until nothing more is accepted or the residual is white.

Tracker errors on compressed video are mostly a slowly varying bias (the
same marker at the same place gives the same error), so the residual of a
right model is not white. Counting every frame as independent evidence
would then accept effects that merely bend around that bias. The BIC and the
parameter intervals therefore count independent evidence
(:func:`independent_frames`): each stretch where the mechanism stands still
once, moving frames as ``n·(1 − ρ)/(1 + ρ)`` from the lag-1 autocorrelation
ρ (the AR(1) variance inflation) of the best candidate model's residual (the
candidates that could pass, fitted together and alone) or of the rigid |AB|
link, whichever is more correlated. That keeps null data from "discovering"
effects while an effect that is really there still wins by a wide margin.

Candidates a model cannot tell apart are handled openly: an effect that
needs a known value to be separable (a dead time is a later start unless the
start time is known) is not fitted without it and the report says which
value would separate it; candidates that fit equally well are reported as a
group with the experiment that would tell them apart.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.integrate import odeint
from scipy.optimize import least_squares
from statsmodels.stats.diagnostic import acorr_ljungbox

from cranktrack.errors import CranktrackError
from cranktrack.kinematics.compare import fit_percent
from cranktrack.kinematics.dynamics import COULOMB_SMOOTHING, CrankDynamics
from cranktrack.kinematics.heat import CurrentSteps, SMAWire, simulate_wire
from cranktrack.kinematics.sma_bed import SMABed, lagged, quasi_static_theta
from cranktrack.kinematics.spool import TABLE_2_2, SpoolDrive, spool_motion
from cranktrack.options import parse_numbers

#: ΔBIC an effect must win by. 10 is "very strong" on the Kass–Raftery scale, but
#: tracked renders without any effect reached 15.3 (tracker bias that differs between
#: the two rest positions looks like a little slack; bench/discrepancy.py, 20 null
#: renders), while the weakest real effect detected scored 26: hence 20.
BIC_THRESHOLD = 20.0
#: An accepted effect must change θ by more than this many σ of the noise somewhere.
#: 3σ let a 0.02 mm wire stretch through on one of 40 tracked null renders (imprint
#: 3.7σ, ΔBIC 20.6); the weakest real effect on the benchmark's ladders left 6.9σ.
IMPRINT_SIGMAS = 5.0
#: Two candidates whose ΔBIC differ by less than this explain the residual equally well.
LOOK_ALIKE_BIC = 2.0
#: Model evaluations per least-squares start: kinked models (a drive that starts and
#: stops) can crawl along a valley for thousands of steps without gaining anything.
MAX_EVALUATIONS = 200
#: Ljung–Box p-value below which a residual is called structured.
WHITE_P = 0.01


@dataclass(frozen=True)
class Parameter:
    """A model parameter: its unit and the bounds a fit keeps it in."""

    name: str
    unit: str
    lower: float
    upper: float


@dataclass(frozen=True)
class Candidate:
    """An effect the base model lacks, as an extension with its own parameters.

    ``off`` is the value of the first parameter at which the effect vanishes
    (``inf`` for a ring frequency: an infinitely stiff spring stops dead);
    ``plausible`` the range a real rig can have; ``needs_known`` known values
    of which at least one is needed to tell the effect from the base model's
    own parameters; ``separated_by`` says what experiment tells this one from
    the candidates that fit as well.
    """

    name: str
    kind: str
    parameters: tuple[Parameter, ...]
    starts: tuple[tuple[float, ...], ...]
    off: float
    plausible: tuple[float, float]
    shows_as: str
    needs_known: tuple[str, ...] = ()
    separated_by: str = ""
    also_looks_like: str = ""


#: Base parameters of the spool model, named as ``--known`` takes them.
SPOOL_BASE = {
    "start_s": Parameter("start_s", "s", -np.inf, np.inf),
    "stroke_mm": Parameter("stroke_mm", "mm", 0.01, 1e4),
    "L1_mm": Parameter("L1_mm", "mm", 1.0, 1e5),
    "L2_mm": Parameter("L2_mm", "mm", 1.0, 1e5),
    "L3_0_mm": Parameter("L3_0_mm", "mm", 1.0, 1e5),
    "speed_mm_s": Parameter("speed_mm_s", "mm/s", 1e-3, 1e4),
}

_DELAY = ("know the stroke (slack shrinks the rocking angle, a clock offset does not) "
          "or film the drive's start signal (an LED lit with the servo)")

#: The effects the spool model can be extended by.
CANDIDATES: dict[str, Candidate] = {c.name: c for c in (
    Candidate("slack_mm", "physical", (Parameter("slack_mm", "mm", 0.0, 50.0),),
              ((0.5,), (2.0,)), 0.0, (0.0, 50.0),
              "the crank starts slack/speed after the drive and rocks through a smaller angle",
              needs_known=("start_s", "stroke_mm"), separated_by=_DELAY),
    Candidate("time_offset_s", "recording", (Parameter("time_offset_s", "s", -5.0, 5.0),),
              ((0.05,), (-0.05,)), 0.0, (-5.0, 5.0),
              "every event happens later (or earlier) on the video's clock than the known start",
              needs_known=("start_s",), separated_by=_DELAY,
              also_looks_like="a rolling shutter (B caught readout × row/height after the frame "
              "time), a lagging servo, or motion blur from an exposure that is not centred on "
              "the timestamp; to tell them apart, film an LED lit with the drive in several "
              "image rows, or turn the camera by 90°: a rolling shutter's delay follows the "
              "image row, a clock offset does not"),
    Candidate("spool_growth_per_s", "physical",
              (Parameter("spool_growth_per_s", "1/s", -0.9, 10.0),),
              ((0.1,), (0.5,)), 0.0, (0.0, 5.0),
              "ω grows during the stroke beyond the constant-speed model's and the stroke "
              "ends sooner"),
    Candidate("return_spring_hz", "physical",
              (Parameter("return_spring_hz", "Hz", 0.05, 1e3),
               Parameter("return_spring_zeta", "1", 0.001, 0.99)),
              ((0.5, 0.1), (1.0, 0.1), (2.0, 0.1), (4.0, 0.1), (8.0, 0.1)), np.inf,
              (0.05, np.inf),
              "after the drive stops the crank overshoots and rings about its final angle"),
    Candidate("wire_stretch_mm", "physical",
              (Parameter("wire_stretch_mm", "mm", 0.0, 10.0),), ((0.1,), (0.5,)), 0.0,
              (0.0, 10.0),
              "the crank lags the kinematic model by an angle that grows as the return "
              "spring winds up and the moment arm shrinks: the wire stretches under its pull",
              also_looks_like="a compliant mounting of the spool or the pivot; a stiffer "
              "(steel) wire, or a lighter return spring, shrinks a wire stretch and nothing "
              "else"),
    Candidate("clock_scale", "recording", (Parameter("clock_scale", "1", 0.2, 5.0),),
              ((1.02,), (0.98,)), 1.0, (0.2, 5.0),
              "every rate is off by one factor: the container's frame rate is not the "
              "camera's (true time = clock_scale × video time)",
              needs_known=("speed_mm_s",),
              separated_by="film a clock or a stopwatch, or measure the spool speed on the bench",
              also_looks_like="a spool speed off its nominal value by the same factor; a "
              "stopwatch in the picture separates the two"),
)}



@dataclass(frozen=True)
class CameraView:
    """Where the mechanism sits in the image and how the run maps pixels to the plane.

    What a camera candidate needs to say how it would bend the measured angle:
    ``to_plane`` and ``to_image`` map (n, 2) px ↔ mm as the run's calibration does;
    ``size`` is the image (width, height), px; ``A_px`` and ``C_px`` the
    measured pivot and slider end (medians), px; ``side`` +1 or −1, the side of
    A→C the crank tip is on in the plane.
    """

    to_plane: Callable[[NDArray], NDArray]
    to_image: Callable[[NDArray], NDArray]
    size: tuple[int, int]
    A_px: NDArray[np.float64]
    C_px: NDArray[np.float64]
    side: float


#: The camera candidates' effect parameters that bend the image, all "no effect" at 0.
CAMERA_PARAMETERS = ("lens_edge_pct", "tilt_vertical_deg", "tilt_horizontal_deg")
#: The rolling shutter's readout time (s): it bends time, not the image.
READOUT = "readout_s"

_CAMERA_SEPARATION = ("calibrate the camera with a chessboard (`cranktrack calibrate camera`, "
                      "then `calibrate plane` with it): that measures the lens and the plane's "
                      "tilt directly, and tracked again with it a camera effect goes while a "
                      "mechanism effect stays")


#: Field of view assumed for a tilt unless ``--known hfov_deg=…`` says otherwise, deg.
#: Over one clip a tilt's keystone fixes only tan(tilt)·tan(fov/2) (the squeeze
#: across the tilt axis is second order), so the two cannot be fitted together.
DEFAULT_HFOV_DEG = 60.0


def _tilt(axis: str) -> Candidate:
    name = f"tilt_{axis}_deg"
    about = "horizontal" if axis == "vertical" else "vertical"
    follows = "row" if axis == "vertical" else "column"
    return Candidate(
        name, "camera", (Parameter(name, "deg", -60.0, 60.0),), ((3.0,), (-3.0,)), 0.0,
        (-45.0, 45.0),
        f"a camera tilted about the image's {about} axis: the plane's scale changes along "
        f"the image's {follows}s and is squeezed across them, so the angle and the rigid "
        f"|AB| follow B's image {follows} (the tilt is for a lens of {DEFAULT_HFOV_DEG:g}° "
        "horizontal field of view unless `--known hfov_deg=…` gives yours; it scales "
        "about as 1/tan(fov/2))",
        separated_by=_CAMERA_SEPARATION,
        also_looks_like="lens distortion does" + (
            ", or a rolling shutter (which also follows the row, but only while the crank "
            "moves)" if axis == "vertical" else ""))


#: Camera effects: they bend where the tracker sees B, so they change the measured
#: angle by an amount that depends on where B is in the image.
CAMERA_CANDIDATES: dict[str, Candidate] = {c.name: c for c in (
    Candidate("lens_edge_pct", "camera", (Parameter("lens_edge_pct", "%", -40.0, 40.0),),
              ((-2.0,), (2.0,)), 0.0, (-30.0, 30.0),
              "radial lens distortion: the angle is off by an amount that grows with B's "
              "distance from the image centre, and the rigid crank |AB| seems to change "
              "length as it turns (the parameter is the radial displacement at the image's "
              "half-width, in % of that radius; negative is barrel; OpenCV's k1 = this / 100 "
              "× (2f/width)², k1 = 3 × this / 100 for a 60° lens)",
              separated_by=_CAMERA_SEPARATION,
              also_looks_like="a camera tilt does when B stays on one side of the image"),
    _tilt("vertical"),
    _tilt("horizontal"),
    Candidate(READOUT, "camera", (Parameter(READOUT, "s", -0.2, 0.2),), ((0.02,), (-0.02,)),
              0.0, (-0.1, 0.1),
              "a rolling shutter: the sensor reads its rows one after another over this "
              "time, so B is caught readout × (its image row / the image height) after the "
              "frame's timestamp; a delay that follows B's row (negative: rows read bottom "
              "to top). The frame's timestamp is taken as the first row's",
              needs_known=("start_s", "current_on_s"),
              separated_by="film an LED lit with the drive in several image rows, or turn the "
              "camera by 90°: a rolling shutter's delay follows the image row, a clock offset "
              "does not",
              also_looks_like="a clock offset (time_offset_s), when B's row changes little "
              "over the stroke, or a camera whose timestamp is not the first row's"),
)}


def _tilted(q: NDArray, tau: float, forward: bool) -> NDArray:
    """A pinhole's tilt by ``tau`` (rad) about its x axis, in coordinates over the focal
    length, re-aimed so the image centre stays on the centre: forward from the image an
    untilted camera would take, or back."""
    c, s = np.cos(tau), np.sin(tau)
    x, y = q[:, 0], q[:, 1]
    if forward:
        y = y - np.tan(tau)
        d = c - y * s
        return np.stack([x / d, (y * c + s) / d], axis=1)
    qy = (y * c - s) / (c + y * s)
    return np.stack([x * (c - qy * s), qy + np.tan(tau)], axis=1)


def _camera_maps(values: dict[str, float], size: tuple[int, int]
                 ) -> tuple[Callable[[NDArray], NDArray], Callable[[NDArray], NDArray]]:
    """(seen, ideal): where the camera effects put an ideal image point, and back, px.

    Tilts are exact pinhole tilts (:func:`_tilted`, about the image's horizontal
    axis for ``tilt_vertical_deg``, its vertical axis for ``tilt_horizontal_deg``)
    for a lens of ``hfov_deg`` (:data:`DEFAULT_HFOV_DEG` unless known); the lens
    then scales coordinates centred on the image and over its half-width by
    ``1 + k·|u|²``, k = ``lens_edge_pct``/100.
    """
    c = (np.asarray(size, float) - 1.0) / 2.0
    half = size[0] / 2.0
    k = values.get("lens_edge_pct", 0.0) / 100.0
    tilts = []
    for axis, swap in (("vertical", False), ("horizontal", True)):
        # Signed as ``cranktrack synth --effect tilt_deg`` turns its camera.
        tau = -np.radians(values.get(f"tilt_{axis}_deg", 0.0))
        if tau:
            fov = np.radians(values.get("hfov_deg", DEFAULT_HFOV_DEG))
            tilts.append((tau, half / np.tan(fov / 2.0), swap))

    def tilt(px: NDArray, forward: bool) -> NDArray:
        for tau, f, swap in tilts if forward else tilts[::-1]:
            q = (px - c) / f
            q = _tilted(q[:, ::-1], tau, forward)[:, ::-1] if swap else _tilted(q, tau, forward)
            px = c + f * q
        return px

    def seen(px: NDArray) -> NDArray:
        u = (tilt(px, True) - c) / half
        return c + half * u * (1.0 + k * np.sum(u**2, axis=1, keepdims=True))

    def ideal(px: NDArray) -> NDArray:
        w = (px - c) / half
        u = w.copy()
        if k:
            for _ in range(30):  # k·|u|² ≪ 1: a contraction that settles in a few steps
                step = w / (1.0 + k * np.sum(u**2, axis=1, keepdims=True))
                done = np.max(np.abs(step - u)) < 1e-13
                u = step
                if done:
                    break
        return tilt(c + half * u, False)

    return seen, ideal


def _crank_tip(theta: NDArray, values: dict[str, float], view: CameraView
               ) -> tuple[NDArray, NDArray]:
    """B in the plane at true angles ``theta`` (rad), A and C where the measured ones
    would be without the camera effects in ``values``, |AB|/|AC| = L2/L1; and B's
    image point through those effects, px."""
    seen, ideal = _camera_maps(values, view.size)
    A, C = view.to_plane(ideal(np.vstack([view.A_px, view.C_px])))
    span = C - A
    e = span / np.hypot(*span)
    n = view.side * np.array([-e[1], e[0]])
    crank = values["L2_mm"] / values["L1_mm"] * np.hypot(*span)
    B = A + crank * (np.cos(theta)[:, None] * e + np.sin(theta)[:, None] * n)
    return B, seen(view.to_image(B))


def camera_theta(theta: NDArray, values: dict[str, float], view: CameraView) -> NDArray:
    """The angle the run would measure for true angles ``theta`` (rad) through the
    camera effects in ``values`` (:data:`CAMERA_CANDIDATES`).

    B is placed by :func:`_crank_tip`, imaged through the effects and mapped
    back to the plane by the run's own calibration, as are the measured A and C.
    """
    Bm = view.to_plane(_crank_tip(theta, values, view)[1])
    Am, Cm = view.to_plane(np.vstack([view.A_px, view.C_px]))
    u, v = Cm - Am, Bm - Am
    return np.arctan2(np.abs(u[0] * v[:, 1] - u[1] * v[:, 0]), v @ u)


def _with_camera(simulate: Callable, view: CameraView | None) -> Callable:
    """``simulate`` followed by the camera effects, when there are any.

    A rolling shutter simulates again at the times B is caught (A and C stand
    still on these beds, so B's time is θ's): B's row moves by far less than
    the image between that time and the frame's, so one correction is enough.
    """
    if view is None:
        return simulate

    def run(values: dict[str, float], t_s: NDArray) -> NDArray:
        theta = simulate(values, t_s)
        readout = values.get(READOUT, 0.0)
        if readout:
            row = np.clip(_crank_tip(theta, values, view)[1][:, 1], 0.0, view.size[1])
            late = t_s + readout * row / view.size[1]
            # A negative readout can put the first frame before the first time asked for;
            # the models take times in order, which a readout shorter than a frame keeps.
            theta = simulate(values, late)
        if not any(values.get(k, 0.0) for k in CAMERA_PARAMETERS):
            return theta
        return camera_theta(theta, values, view)

    return run


def parse_known(items: list[str] | None, model: str = "spool") -> dict[str, float]:
    """``["L1_mm=160.8", "start_s=0.5"]`` → a dict, checked against the model's names."""
    names = KNOWN_NAMES.get(model)
    if names is None:
        raise CranktrackError(f"the {model!r} model cannot be fitted yet; available: "
                              f"{', '.join(KNOWN_NAMES)}")
    return parse_numbers(items, names, "--known", f"a {model} parameter", finite=True)


def spool_theta(values: dict[str, float], t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """θ (rad) of the spool model with whichever candidate effects ``values`` sets.

    Raises :class:`CranktrackError` when the values give a linkage that cannot close.
    """
    v = values
    start = v["start_s"]
    # A wrong clock stretches time about the known start, then an offset shifts it.
    tt = start + v.get("clock_scale", 1.0) * (t_s - start) - v.get("time_offset_s", 0.0)
    drive = SpoolDrive(L1=v["L1_mm"], L2=v["L2_mm"], L3_0=v["L3_0_mm"],
                       speed_mm_s=v["speed_mm_s"], start_s=start, stroke_mm=v["stroke_mm"])
    theta = spool_motion(drive, tt, slack_mm=v.get("slack_mm", 0.0),
                         growth_per_s=v.get("spool_growth_per_s", 0.0),
                         ring_hz=v.get("return_spring_hz", 0.0),
                         ring_zeta=v.get("return_spring_zeta", 0.1), rates=False,
                         stretch_mm=v.get("wire_stretch_mm", 0.0))[0]
    if not np.all(np.isfinite(theta)):
        raise CranktrackError("the linkage does not close for these values")
    return theta


#: Base parameters of the free-response model (thesis eq. 3.28 per unit inertia).
DYNAMIC_BASE = {
    "theta_init_deg": Parameter("theta_init_deg", "deg", -360.0, 360.0),
    "omega_init_rad_s": Parameter("omega_init_rad_s", "rad/s", -100.0, 100.0),
    "k_l": Parameter("k_l", "1/s²", 1e-6, 1e5),
    "k_s": Parameter("k_s", "1/(mm·s)²·mm", 0.0, 1e3),
    "k_d": Parameter("k_d", "1/s", 0.0, 1e3),
    "theta_rest_deg": Parameter("theta_rest_deg", "deg", 0.0, 360.0),
    "L1_mm": Parameter("L1_mm", "mm", 1.0, 1e5),
    "L2_mm": Parameter("L2_mm", "mm", 1.0, 1e5),
}

#: The effects the free-response model can be extended by.
DYNAMIC_CANDIDATES: dict[str, Candidate] = {c.name: c for c in (
    Candidate("coulomb_rad_s2", "physical",
              (Parameter("coulomb_rad_s2", "rad/s²", 0.0, 1e3),), ((0.2,), (1.0,)), 0.0,
              (0.0, 1e3),
              "the swing shrinks by the same angle every half cycle instead of by the same "
              "fraction, and the crank stops off the springs' equilibrium",
              also_looks_like="stiction in a bearing or a rubbing marker; a swing started "
              "from a larger angle separates it from extra viscous damping (dry friction "
              "costs the same angle per swing whatever the amplitude)"),
)}


def dynamic_theta(values: dict[str, float], t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """θ (rad) of the free response (eq. 3.28, unit inertia, ε = 0.05) from t_s[0], with
    Coulomb friction when ``values`` sets it (LSODA, rtol 1e-9)."""
    v = values
    L1, L2 = v["L1_mm"], v["L2_mm"]
    dyn = CrankDynamics(I=1.0, k_l=v["k_l"], k_s=v["k_s"], k_d=v["k_d"], L1=L1, L2=L2,
                        theta0=np.radians(v["theta_rest_deg"]),
                        coulomb=v.get("coulomb_rad_s2", 0.0))
    k_l, k_s, k_d, th0, L3_0, fc = (dyn.k_l, dyn.k_s, dyn.k_d, dyn.theta0, dyn.L3_0,
                                    dyn.coulomb)
    a, b = L1 * L1 + L2 * L2, 2.0 * L1 * L2

    # Plain floats: the integrator calls this thousands of times per fit.
    def rhs(y: NDArray, _t: float) -> list[float]:
        th, om = float(y[0]), float(y[1])
        L3 = math.sqrt(a - b * math.cos(th))
        wire = k_s * L1 * L2 * math.sin(th) * (1.0 - L3_0 / L3)
        friction = fc * math.tanh(om / COULOMB_SMOOTHING) if fc else 0.0
        return [om, k_l * (th0 - th) - k_d * om - wire - friction]

    t = np.asarray(t_s, float)
    # LSODA (odeint) rather than RK45 here: the same answer, several times faster with a
    # Python right-hand side, and a fit simulates a thousand times.
    y, info = odeint(rhs, [np.radians(v["theta_init_deg"]), v["omega_init_rad_s"]], t,
                     rtol=1e-9, atol=1e-11, full_output=True)
    if info["message"] != "Integration successful.":
        raise CranktrackError("the free response could not be integrated for these values")
    return y[:, 0]


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
    (zero crossings about the settling angle) and its decay."""
    deg = np.degrees(theta)
    rest = float(np.median(deg[-max(3, deg.size // 4):]))
    x = deg - rest
    crossings = np.flatnonzero(np.sign(x[1:]) != np.sign(x[:-1]))
    period = 2.0 * float(np.median(np.diff(t[crossings]))) if crossings.size > 2 \
        else float(t[-1] - t[0])
    wn = 2.0 * np.pi / max(period, 1e-6)
    base = {"theta_init_deg": float(deg[0]),
            "omega_init_rad_s": float((theta[1] - theta[0]) / (t[1] - t[0])),
            "k_l": wn**2, "k_s": 0.0, "theta_rest_deg": rest, **held}
    return [{**base, "k_d": 2.0 * zeta * wn} for zeta in (0.05, 0.2)]


#: Base parameters of the SMA-actuated bed (thesis §2.5.3 with the heat model of ch. 4).
SMA_BASE = {
    "current_A": Parameter("current_A", "A", 0.0, 20.0),
    "current_on_s": Parameter("current_on_s", "s", -1e4, 1e4),
    "current_off_s": Parameter("current_off_s", "s", -1e4, 1e4),
    "ambient_C": Parameter("ambient_C", "°C", -50.0, 100.0),
    "L1_mm": Parameter("L1_mm", "mm", 1.0, 1e5),
    "L2_mm": Parameter("L2_mm", "mm", 1.0, 1e5),
    "theta0_deg": Parameter("theta0_deg", "deg", 1.0, 179.0),
    "recovery_strain": Parameter("recovery_strain", "1", 1e-4, 0.1),
    "h_W_m2K": Parameter("h_W_m2K", "W/(m²·K)", 5.0, 1e4),
    "As_C": Parameter("As_C", "°C", -50.0, 200.0),
    "Af_C": Parameter("Af_C", "°C", -50.0, 200.0),
    "Ms_C": Parameter("Ms_C", "°C", -50.0, 200.0),
    "Mf_C": Parameter("Mf_C", "°C", -50.0, 200.0),
}

#: The effects the SMA bed's model can be extended by.
SMA_CANDIDATES: dict[str, Candidate] = {c.name: c for c in (
    Candidate("thermal_lag_s", "physical", (Parameter("thermal_lag_s", "s", 0.0, 10.0),),
              ((0.05,), (0.3,)), 0.0, (0.0, 10.0),
              "the crank follows each switch of the current later and more smoothly than the "
              "lumped wire model: its strain lags the transformation",
              also_looks_like="a slow thermocouple-free wire with non-uniform temperature, "
              "heat lost at the clamps, or a damped, heavy crank; a thinner or longer wire "
              "changes a thermal lag, a lighter crank a mechanical one"),
    Candidate("damping_Nms_rad", "physical",
              (Parameter("damping_Nms_rad", "N·m·s/rad", 0.0, 1.0),), ((0.01,), (0.05,)), 0.0,
              (0.0, 1.0),
              "extra viscous drag at the pivot (on top of the bed's own): the crank trails "
              "its balance by an angle that grows with its speed, most where it moves fastest, "
              "and settles at the same angles",
              also_looks_like="a thermal lag does; a damper's lag is an angle in proportion "
              "to the crank's speed, a thermal lag's a time: heat at two currents and compare"),
    Candidate("time_offset_s", "recording", (Parameter("time_offset_s", "s", -5.0, 5.0),),
              ((0.05,), (-0.05,)), 0.0, (-5.0, 5.0),
              "every switch of the current takes effect later (or earlier) on the video's "
              "clock than the logged times",
              separated_by="film the power supply's indicator, or log the "
              "current on the same clock as the camera"),
)}


def sma_theta(values: dict[str, float], t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """θ (rad) of the SMA bed: the heat model on a 5 ms grid (LSODA, rtol 1e-7), ξ through the
    optional thermal lag, and the crank where the torques balance (damper to first
    order): within 0.04° of the full equation of motion, a hundred times faster."""
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
    return np.interp(t, fine, quasi_static_theta(bed, xi, fine))


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
                         _dynamic_guesses, _dynamic_hold, diff_step=1e-4),
    "sma": ModelSpec("sma", SMA_BASE, sma_theta, SMA_CANDIDATES, _sma_guesses, _sma_hold,
                     diff_step=1e-3),
}

#: What ``--known`` takes: each model's base parameters, and the lens's horizontal
#: field of view, which the tilt candidates need.
KNOWN_NAMES = {name: (*spec.base, "hfov_deg") for name, spec in MODELS.items()}


def effective_samples(residual: NDArray[np.float64]) -> float:
    """``n·(1 − ρ)/(1 + ρ)`` with ρ the lag-1 autocorrelation (≥ 0), at least 3."""
    r = residual - residual.mean()
    n = r.size
    denom = float(r @ r)
    rho = float(r[1:] @ r[:-1]) / denom if denom > 0 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    return max(n * (1.0 - rho) / (1.0 + rho), 3.0)


def still_segments(model: NDArray[np.float64], tol: float = 1e-9) -> tuple[NDArray, int]:
    """Frames where the modelled mechanism stands still, and how many still stretches.

    Returns (mask of still frames, number of runs of ≥ 2 consecutive still frames).
    """
    flat = np.abs(np.diff(model)) <= tol
    still = np.zeros(model.size, bool)
    still[:-1] |= flat
    still[1:] |= flat
    edges = np.diff(np.concatenate([[0], still.astype(int), [0]]))
    return still, int(np.sum(edges == 1))


def independent_frames(series: list[NDArray[np.float64]], still: NDArray,
                       segments: int) -> float:
    """Independent pieces of evidence among the frames.

    A still mechanism films the same image again and again: the tracker's
    error there is one draw per still stretch, not one per frame. Moving
    frames count ``n·(1 − ρ)/(1 + ρ)``, with the largest ρ any of ``series``
    (residuals, a rigid link's length) shows over the moving frames.
    """
    moving = [np.asarray(x, float)[~still] for x in series]
    moving = [x[np.isfinite(x)] for x in moving]
    counts = [effective_samples(x) for x in moving if x.size >= 12]
    n_moving = min(counts) if counts else float(np.sum(~still))
    return max(n_moving + segments, 3.0)


@dataclass(frozen=True)
class NoiseModel:
    """The measurement error fits are judged against: a per-frame 1-σ of θ and
    the effective number of independent frames among ``n``."""

    sigma_deg: float
    n: int
    n_eff: float
    source: str

    @property
    def inflation(self) -> float:
        """Variance inflation of a mean over the frames, ``n / n_eff``."""
        return self.n / self.n_eff

    @property
    def variance(self) -> float:
        """σ² in rad²."""
        return float(np.radians(self.sigma_deg) ** 2)

    @classmethod
    def from_residual(cls, residual: NDArray[np.float64], k: int, floor_rad: float,
                      source: str) -> NoiseModel:
        """From a fit's residual (rad) with ``k`` free parameters: its RMS, but never
        below the tracker's own σ (``floor_rad``), and its lag-1 correlation."""
        n = residual.size
        s2 = max(float(residual @ residual) / max(n - k, 1), floor_rad**2)
        return cls(float(np.degrees(np.sqrt(s2))), n, effective_samples(residual), source)

    def to_dict(self) -> dict:
        return {"sigma_deg": self.sigma_deg, "frames": self.n,
                "effective_frames": self.n_eff, "source": self.source}


@dataclass(frozen=True)
class ModelFit:
    """One fitted model: its effects, all values, the free ones' unit covariance
    ``(JᵀJ)⁻¹`` (times the error variance it is the covariance), θ model and
    residual (rad)."""

    effects: tuple[str, ...]
    values: dict[str, float]
    free: tuple[str, ...]
    unit_cov: NDArray[np.float64]
    model: NDArray[np.float64]
    residual: NDArray[np.float64]

    @property
    def rss(self) -> float:
        return float(self.residual @ self.residual)

    @property
    def rmse_deg(self) -> float:
        return float(np.degrees(np.sqrt(np.mean(self.residual**2))))

    def sigmas(self, noise: NoiseModel) -> dict[str, float]:
        """1-σ of the free parameters under ``noise`` (correlated frames counted once)."""
        var = np.clip(np.diag(self.unit_cov), 0.0, None) * noise.variance * noise.inflation
        return {k: float(v) for k, v in zip(self.free, np.sqrt(var), strict=True)}


def delta_bic(simpler: ModelFit, richer: ModelFit, noise: NoiseModel) -> float:
    """BIC(simpler) − BIC(richer) for Gaussian errors of the noise model's variance,
    with ``n_eff`` independent frames (so ``ΔRSS`` counts ``n_eff / n`` of itself)."""
    dk = len(richer.free) - len(simpler.free)
    return float((simpler.rss - richer.rss) / (noise.variance * noise.inflation)
                 - dk * np.log(noise.n_eff))


def _fit(t: NDArray, theta: NDArray, simulate: Callable, fixed: dict[str, float],
         free: list[Parameter], starts: list[list[float]], effects: tuple[str, ...],
         diff_step: float = 1e-7) -> ModelFit | None:
    """Least squares of ``theta − simulate(values, t)`` from each start; the best, or None."""
    def values_of(x: NDArray) -> dict[str, float]:
        return {**fixed, **{p.name: float(v) for p, v in zip(free, x, strict=True)}}

    def residual(x: NDArray) -> NDArray:
        try:
            return theta - simulate(values_of(x), t)
        except (CranktrackError, ValueError, FloatingPointError):
            return np.full(t.size, 10.0)  # a linkage that cannot close: far from any fit

    lo = np.array([p.lower for p in free])
    hi = np.array([p.upper for p in free])
    width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    best = None
    for x0 in starts:
        x0 = np.clip(np.asarray(x0, float), lo + 1e-9 * width, hi - 1e-9 * width)
        if np.all(residual(x0) == 10.0):
            continue
        with np.errstate(all="ignore"):
            sol = least_squares(residual, x0, bounds=(lo, hi), x_scale="jac", method="trf",
                                diff_step=diff_step, max_nfev=MAX_EVALUATIONS)
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None or np.all(best.fun == 10.0):
        return None
    unit_cov = np.linalg.pinv(best.jac.T @ best.jac)
    return ModelFit(effects, values_of(best.x), tuple(p.name for p in free), unit_cov,
                    theta - best.fun, best.fun)


def ljung_box_p(residual: NDArray[np.float64], lags: int | None = None) -> float:
    """Ljung–Box p-value of a residual (small: structured, not white)."""
    n = residual.size
    if n < 12:
        return float("nan")
    lags = lags or int(min(10, n // 5))
    return float(acorr_ljungbox(residual - residual.mean(), lags=[lags])["lb_pvalue"].iloc[0])


def diagnose(fit: ModelFit, measured_deg: NDArray[np.float64], t: NDArray[np.float64],
             context: dict[str, NDArray[np.float64]] | None = None) -> dict:
    """Figures and correlations of a fit's residual.

    ``context`` adds series (same length) to correlate with, e.g. a marker's
    image row. Returns ``rmse_deg``, ``max_deg``, ``fit_percent``,
    ``ljung_box_p``, ``lag1_autocorrelation``, ``correlations`` (Pearson r,
    largest first) and ``phases`` (RMS before the drive, moving, after it).
    """
    r = np.degrees(fit.residual)
    model_deg = np.degrees(fit.model)
    omega = np.gradient(fit.model, t)
    moving = np.abs(omega) > 1e-6 * max(float(np.max(np.abs(omega))), 1e-12)
    series = {"time": t, "theta": model_deg, "omega": omega, "sign(omega)": np.sign(omega),
              **(context or {})}
    corr = {}
    for name, x in series.items():
        ok = np.isfinite(x)
        if ok.sum() > 3 and np.std(x[ok]) > 0 and np.std(r[ok]) > 0:
            corr[name] = float(np.corrcoef(x[ok], r[ok])[0, 1])
    moved = np.flatnonzero(moving)
    phases = {}
    if moved.size:
        parts = {"before": slice(0, moved[0]), "moving": slice(moved[0], moved[-1] + 1),
                 "after": slice(moved[-1] + 1, r.size)}
        for name, s in parts.items():
            if r[s].size:
                phases[name] = {"rmse_deg": float(np.sqrt(np.mean(r[s] ** 2))),
                                "frames": int(r[s].size)}
    rc = r - r.mean()
    lag1 = float(rc[1:] @ rc[:-1] / (rc @ rc)) if rc @ rc > 0 else 0.0
    return {
        "rmse_deg": float(np.sqrt(np.mean(r**2))),
        "max_deg": float(np.max(np.abs(r))),
        "fit_percent": fit_percent(measured_deg, model_deg),
        "ljung_box_p": ljung_box_p(r),
        "lag1_autocorrelation": lag1,
        "correlations": dict(sorted(corr.items(), key=lambda kv: -abs(kv[1]))),
        "phases": phases,
    }


@dataclass(frozen=True)
class CandidateScore:
    """One candidate tried on top of the current model in one round.

    ``imprint_deg`` is the largest change the effect makes to θ at its
    fitted value; ``resolvable`` says whether that rises above the noise
    (:data:`IMPRINT_SIGMAS`) anywhere — an effect smaller than the tracker's own error cannot
    be told from it, however well it happens to bend around that error.
    """

    name: str
    round: int
    delta_bic: float
    rmse_deg: float
    values: dict[str, float]
    sigmas: dict[str, float]
    imprint_deg: float
    ci_excludes_off: bool
    plausible: bool
    resolvable: bool
    accepted: bool = False
    note: str = ""

    @property
    def passes(self) -> bool:
        return (self.delta_bic > BIC_THRESHOLD and self.ci_excludes_off and self.plausible
                and self.resolvable)

    def why_not(self) -> str:
        why = []
        if self.delta_bic <= BIC_THRESHOLD:
            why.append(f"ΔBIC {self.delta_bic:.1f} ≤ {BIC_THRESHOLD:g}")
        if not self.ci_excludes_off:
            why.append("its 95 % interval includes no effect")
        if not self.plausible:
            why.append("value not physically plausible or stuck on a bound")
        if not self.resolvable:
            why.append(f"its imprint ({self.imprint_deg:.3g}°) is below {IMPRINT_SIGMAS:g}σ "
                       "of the noise")
        return "; ".join(why) or "a better candidate was accepted"

    def to_dict(self) -> dict:
        return {"name": self.name, "round": self.round, "delta_bic": self.delta_bic,
                "rmse_deg": self.rmse_deg, "imprint_deg": self.imprint_deg,
                "parameters": {k: {"value": v, "sigma": self.sigmas.get(k)}
                               for k, v in self.values.items()},
                "ci_excludes_off": self.ci_excludes_off, "plausible": self.plausible,
                "resolvable": self.resolvable, "accepted": self.accepted, "note": self.note}


def _switched_off(c: Candidate) -> dict[str, float]:
    """Values that make the simulation leave the effect out (a ring of 0 Hz is none)."""
    return {c.parameters[0].name: 0.0 if np.isinf(c.off) else c.off}


def _score(c: Candidate, rnd: int, current: ModelFit, alt: ModelFit, noise: NoiseModel,
           t: NDArray, simulate: Callable, nyquist_hz: float) -> CandidateScore:
    """ΔBIC, interval, plausibility and imprint of ``alt`` = ``current`` + ``c``."""
    sig = alt.sigmas(noise)
    p = c.parameters[0].name
    v, s = alt.values[p], sig[p]
    if not (np.isfinite(s) and s > 0):
        excludes = False
    elif np.isinf(c.off):  # a ring: resolved only if its whole interval is below Nyquist
        excludes = v + 1.96 * s < nyquist_hz
    else:
        excludes = abs(v - c.off) > 1.96 * s

    def free_of_bounds(q: Parameter) -> bool:
        x, tol = alt.values[q.name], 1e-6 * max(1.0, abs(q.lower), abs(q.upper))
        return q.lower + tol < x < q.upper - tol

    lo, hi = c.plausible
    plausible = lo <= v <= hi and all(free_of_bounds(q) for q in c.parameters)
    try:
        without = simulate({**alt.values, **_switched_off(c)}, t)
        imprint = float(np.degrees(np.max(np.abs(alt.model - without))))
    except CranktrackError:
        imprint = float("nan")
    return CandidateScore(c.name, rnd, delta_bic(current, alt, noise), alt.rmse_deg,
                          {q.name: alt.values[q.name] for q in c.parameters},
                          {q.name: sig[q.name] for q in c.parameters}, imprint,
                          bool(excludes), bool(plausible),
                          bool(imprint > IMPRINT_SIGMAS * noise.sigma_deg))


@dataclass(frozen=True)
class LoopResult:
    """What the loop found: the base fit, each accepted step, every candidate's score."""

    model: str
    known: dict[str, float]
    base: ModelFit
    final: ModelFit
    steps: list[ModelFit]
    scores: list[CandidateScore]
    not_separable: list[dict]
    groups: list[dict]
    diagnosis_before: dict
    diagnosis_after: dict
    noise: NoiseModel
    tracker_sigma_deg: float
    links: dict = field(default_factory=dict)
    messages: list[str] = field(default_factory=list)
    #: The frame-motion check (:func:`.frame_motion.frame_shake`), when the run has
    #: plane tracks of A and C: a shake θ cannot show.
    frame_motion: dict | None = None

    @property
    def shake_accepted(self) -> bool:
        return bool(self.frame_motion and self.frame_motion["accepted"])

    @property
    def effects(self) -> list[str]:
        """Accepted effects in order: θ's, then a shaking frame if found."""
        return list(self.final.effects) + (["pivot_amp_mm"] if self.shake_accepted else [])

    def to_dict(self) -> dict:
        spec = MODELS[self.model]
        units = {**{k: p.unit for k, p in spec.base.items()},
                 **{p.name: p.unit for c in (*spec.candidates.values(),
                                             *CAMERA_CANDIDATES.values()) for p in c.parameters}}
        sig = self.final.sigmas(self.noise)
        params = {}
        for k, v in self.final.values.items():
            entry = {"value": v, "unit": units.get(k, ""), "fixed": k not in sig}
            if k in sig:
                entry.update(sigma=sig[k], ci95=[v - 1.96 * sig[k], v + 1.96 * sig[k]])
            params[k] = entry
        if self.shake_accepted:
            fm = self.frame_motion
            for k, unit, v, sd in (("pivot_amp_mm", "mm", fm["amp_mm"], fm["amp_sigma_mm"]),
                                   ("pivot_hz", "Hz", fm["hz"], fm["hz_sigma"])):
                params[k] = {"value": v, "unit": unit, "fixed": False, "sigma": sd,
                             "ci95": [v - 1.96 * sd, v + 1.96 * sd]}
        before, after = self.diagnosis_before, self.diagnosis_after
        unexplained = None
        # Against the tracker's own σ: the noise model's σ grows with whatever
        # structure no candidate could fit, and would hide exactly this.
        level = self.tracker_sigma_deg or self.noise.sigma_deg
        if after["rmse_deg"] > 1.5 * level and after["ljung_box_p"] < WHITE_P:
            top = next(iter(after["correlations"].items()), None)
            unexplained = ("the residual stays structured and matches no candidate"
                           + (f"; it correlates most with {top[0]} (r = {top[1]:.2f})"
                              if top else ""))
            if self.links.get("camera_effect_suspected"):
                unexplained += "; " + self.links["reading"]
            if self.effects:
                unexplained += ("; the accepted effects improve the fit but do not account for "
                                "it, so they may stand in for something not in the library")
        return {
            "model": self.model,
            "known": self.known,
            "effects": self.effects,
            "rmse_before_deg": before["rmse_deg"],
            "rmse_after_deg": after["rmse_deg"],
            "max_before_deg": before["max_deg"],
            "max_after_deg": after["max_deg"],
            "fit_percent_before": before["fit_percent"],
            "fit_percent_after": after["fit_percent"],
            "noise": self.noise.to_dict(),
            "tracker_sigma_deg": self.tracker_sigma_deg,
            "residual_white_before": bool(before["ljung_box_p"] >= WHITE_P),
            "residual_white_after": bool(after["ljung_box_p"] >= WHITE_P),
            "residual_at_noise_level_after": bool(after["rmse_deg"] <= 1.5 * level),
            "parameters": params,
            "steps": [{"effect": s.effects[-1], "rmse_deg": s.rmse_deg} for s in self.steps],
            "candidates": [s.to_dict() for s in self.scores],
            "not_separable": self.not_separable,
            "look_alike_groups": self.groups,
            "links": self.links,
            "camera_effect_suspected": bool(self.links.get("camera_effect_suspected", False)),
            "unexplained": unexplained,
            "diagnosis_before": before,
            "diagnosis_after": after,
            "messages": self.messages,
            "frame_motion": self.frame_motion,
        }


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


def link_evidence(measured: pd.DataFrame, tracker_sigma_deg: float) -> dict:
    """What the rigid links say: a camera effect (lens distortion, tilt, a wrong
    calibration) bends rigid lengths as the mechanism moves across the image; a
    mechanism effect does not. The crank |AB| is suspect when it varies by more than
    twice what the tracker's σ allows and follows θ (|r| > 0.7)."""
    if "L2_mm" not in measured or "theta_deg" not in measured:
        return {}
    out: dict = {}
    theta = measured["theta_deg"].to_numpy(float)
    for name in ("L1_mm", "L2_mm"):
        if name not in measured:
            continue
        x = measured[name].to_numpy(float)
        ok = np.isfinite(x) & np.isfinite(theta)
        if ok.sum() < 12:
            continue
        r = (float(np.corrcoef(x[ok], theta[ok])[0, 1])
             if np.std(x[ok]) > 0 and np.std(theta[ok]) > 0 else 0.0)
        out[name] = {"median_mm": float(np.median(x[ok])), "std_mm": float(np.std(x[ok])),
                     "r_with_theta": r}
    crank = out.get("L2_mm")
    if crank:
        expected = crank["median_mm"] * np.radians(tracker_sigma_deg)
        suspect = crank["std_mm"] > 2.0 * expected and abs(crank["r_with_theta"]) > 0.7
        out["crank_std_expected_mm"] = float(expected)
        out["camera_effect_suspected"] = bool(suspect)
        if suspect:
            out["reading"] = (f"the rigid crank |AB| varies by {crank['std_mm']:.3f} mm (σ; the "
                              f"tracker allows {expected:.3f}) and follows θ (r = "
                              f"{crank['r_with_theta']:.2f}): a camera effect such as lens "
                              "distortion or tilt, not the mechanism — calibrate the camera "
                              "(`cranktrack calibrate camera`, then `calibrate plane`)")
    return out


def close_loop(measured: pd.DataFrame, known: dict[str, float] | None = None,
               model: str = "spool", context: dict[str, NDArray] | None = None,
               candidates: dict[str, Candidate] | None = None,
               view: CameraView | None = None) -> LoopResult:
    """Fit the base model to measured θ(t), then add effects while the evidence says so.

    Parameters
    ----------
    measured : DataFrame
        A kinematics table: ``t_s``, ``theta_deg`` (per frame, not smoothed),
        ``theta_deg_sigma`` (or ``theta_deg_sigma_tracker``, preferred: the
        noise level without the rigid links' widening), ``L3_mm``;
        ``L1_mm``/``L2_mm`` seed the lengths.
    known : dict
        Values the user knows from the rig, held fixed (the model's base names:
        :data:`SPOOL_BASE`, :data:`DYNAMIC_BASE`).
    model : str
        The base model, a key of :data:`MODELS` (``"spool"``, ``"dynamic"``).
    context : dict, optional
        Extra series, one value per row of ``measured``, to correlate the
        residual with (e.g. ``"B image row"``).
    candidates : dict, optional
        The effect library (default: the model's own, plus the camera effects
        :data:`CAMERA_CANDIDATES` when ``view`` is given).
    view : CameraView, optional
        The run's image geometry, which the camera candidates need.

    Raises
    ------
    CranktrackError
        Another model, too few frames, or known values no model can meet.
    """
    spec = MODELS.get(model)
    if spec is None:
        raise CranktrackError(f"the {model!r} model cannot be fitted yet; available: "
                              f"{', '.join(MODELS)}")
    known = dict(known or {})
    if candidates is None:
        candidates = {**spec.candidates, **(CAMERA_CANDIDATES if view is not None else {})}
    simulate = _with_camera(spec.simulate, view)
    for col in ("t_s", "theta_deg"):
        if col not in measured:
            raise CranktrackError(f"the kinematics table has no {col} column")
    t_all = measured["t_s"].to_numpy(float)
    deg_all = measured["theta_deg"].to_numpy(float)
    ok = np.isfinite(t_all) & np.isfinite(deg_all)
    if ok.sum() < 12:
        raise CranktrackError("fewer than 12 frames have a measured crank angle; too few to fit "
                              "a model and judge its residual")
    t, deg = t_all[ok], deg_all[ok]
    theta = np.radians(deg)
    ctx = {k: np.asarray(v, float)[ok] for k, v in (context or {}).items()}
    extra, messages = spec.hold(measured, known)
    held = {**known, **extra}
    guesses = spec.guesses(t, theta, measured, held)
    guess = guesses[0]
    span = float(t[-1] - t[0])
    base_free = [replace(p, lower=t[0] - span, upper=t[-1]) if k == "start_s" else p
                 for k, p in spec.base.items() if k not in held]
    # The tracker's own σ, without the rigid links' widening where the table has it:
    # a camera effect bends the links, and the loop must not count it as noise.
    noise_col = next((c for c in ("theta_deg_sigma_tracker", "theta_deg_sigma")
                      if c in measured), None)
    sig = measured[noise_col].to_numpy(float)[ok] if noise_col else np.full(t.size, np.nan)
    tracker_deg = float(np.nanmedian(sig)) if np.isfinite(sig).any() else 0.0
    nyquist = 0.5 / float(np.median(np.diff(t)))

    cache: dict[tuple, ModelFit | None] = {}

    def fit_with(effects: tuple[str, ...], start_from: dict[str, float]) -> ModelFit | None:
        """The model with ``effects`` fitted from ``start_from`` (and the data's guesses);
        the same request twice (the reference fit is round 1's when there is one
        candidate) is fitted once."""
        key = (tuple(sorted(effects)), tuple(sorted(start_from.items())))
        if key not in cache:
            cache[key] = _fit_with(effects, start_from)
        fit = cache[key]
        return None if fit is None else replace(fit, effects=effects)

    def _fit_with(effects: tuple[str, ...], start_from: dict[str, float]) -> ModelFit | None:
        free = list(base_free)
        lists = []
        for name in effects:
            ps = [replace(p, upper=min(p.upper, 0.9 * nyquist)) if p.unit == "Hz" else p
                  for p in candidates[name].parameters]
            free += ps
            have = [start_from.get(p.name) for p in ps]
            lists.append([tuple(have)] if all(h is not None for h in have)
                         else list(candidates[name].starts))
        # Each effect's starting values in turn (the longest list sets how many).
        width = max((len(x) for x in lists), default=1)
        effect_starts = [sum((x[i % len(x)] for x in lists), ()) for i in range(width)]
        # The base fit tries every guess; an effect's fit starts where the base ended
        # and from the data's own first guess (a base fit that bent its lengths to
        # mimic an effect can sit in a valley the effect cannot leave).
        origins = (guesses if start_from is guess and not effects
                   else [start_from] if start_from is guess else [start_from, guess])
        starts = [[o[p.name] for p in base_free] + list(es)
                  for es in effect_starts for o in origins]
        return _fit(t, theta, simulate, held, free, starts, effects, spec.diff_step)

    base = fit_with((), guess)
    if base is None:
        raise CranktrackError(f"no {model} model with these known values reproduces the "
                              "measured angles; check the --known values")
    def separable(c: Candidate) -> bool:
        return not c.needs_known or any(k in known for k in c.needs_known)

    not_separable = [{"name": c.name, "needs": list(c.needs_known), "shows_as": c.shows_as,
                      "why": f"without {' or '.join(c.needs_known)} known, {c.name} is the same "
                             "as a change in the base model's own parameters"}
                     for c in candidates.values() if not separable(c)]
    tryable = [c for c in candidates.values() if separable(c)]
    # The noise is judged on the richest model (the candidates together): its
    # residual is as close to the measurement error as the library can get, so a
    # second effect still in the data does not pass for noise while the first is tried.
    # Only effects that could pass join it: a fit whose drop in RSS is under
    # BIC_THRESHOLD tracker variances cannot (the noise is never below the tracker's σ,
    # nor the evidence more than the frames). It starts where each of them alone ended
    # (round 1 fits them anyway, and the cache keeps them) and from each one's first
    # start; the lowest residual of all these fits is the one judged.
    floor2 = np.radians(tracker_deg) ** 2
    alone, first, fits, joining = {}, {}, [], []
    for c in tryable:
        single = fit_with((c.name,), base.values)
        if single is None:
            continue
        fits.append(single)
        if floor2 == 0 or (base.rss - single.rss) / floor2 > BIC_THRESHOLD:
            joining.append(c.name)
            first.update(zip((p.name for p in c.parameters), c.starts[0], strict=True))
            alone.update({p.name: single.values[p.name] for p in c.parameters})
    if len(joining) > 1:
        fits += [f for f in (fit_with(tuple(joining), {**base.values, **alone}),
                             fit_with(tuple(joining), {**base.values, **first}))
                 if f is not None]
    ref = min(fits, key=lambda f: f.rss, default=base)
    ref = ref if ref.rss < base.rss else base
    noise = NoiseModel.from_residual(ref.residual, len(ref.free), np.radians(tracker_deg),
                                     "the base model" if ref is base
                                     else "the best-fitting candidate model")
    # How many independent pieces of evidence the frames hold. The crank |AB| is
    # rigid, so its measured length is the tracker's error seen directly, free of any
    # model; a rich reference model whitens its residual by absorbing some of that
    # error, so the more correlated of the two is the honest count.
    evidence = [ref.residual]
    if "L2_mm" in measured:
        evidence.append(measured["L2_mm"].to_numpy(float)[ok])
    still, segments = still_segments(base.model)
    noise = replace(noise, n_eff=independent_frames(evidence, still, segments),
                    source=noise.source + "; moving frames counted by the lag-1 correlation of "
                    "that residual and of the |AB| link, each still stretch once")
    current, steps, scores, groups = base, [], [], []
    for rnd in range(1, len(tryable) + 1):
        if ljung_box_p(current.residual) >= WHITE_P:
            break  # nothing structured left to explain
        tried = []
        for c in tryable:
            if c.name in current.effects:
                continue
            alt = fit_with((*current.effects, c.name), current.values)
            if alt is not None:
                tried.append((_score(c, rnd, current, alt, noise, t, simulate, nyquist),
                              alt))
        if not tried:
            break
        tried.sort(key=lambda sa: -sa[0].delta_bic)
        # The best candidate that passes every test; one that fits a little better but
        # fails one (an imprint under 5σ, a value on a bound) does not block it — it is
        # named beside it, as is any that fits as well.
        at = next((i for i, (sc, _) in enumerate(tried) if sc.passes), None)
        if at is not None:
            best, alt = tried[at]
            like = [sc.name for i, (sc, _) in enumerate(tried) if i != at and sc.delta_bic > 0
                    and (i < at or best.delta_bic - sc.delta_bic < LOOK_ALIKE_BIC)]
            note = ""
            if like:
                note = f"fits as well as {', '.join(like)}"
                ways = dict.fromkeys(candidates[n].separated_by for n in (best.name, *like))
                groups.append({"effects": [best.name, *like], "round": rnd,
                               "separated_by": "; or ".join(w for w in ways if w)
                               or "a known value or a measurement only one of them changes"})
            tried[at] = (replace(best, accepted=True, note=note), alt)
        scores += [sc if sc.accepted or sc.note else replace(sc, note=sc.why_not())
                   for sc, _ in tried]
        if at is None:
            break
        current = alt
        steps.append(alt)
    before = diagnose(base, deg, t, ctx)
    after = diagnose(current, deg, t, ctx)
    return LoopResult(model, known, base, current, steps, scores, not_separable, groups,
                      before, after, noise, tracker_deg, link_evidence(measured, tracker_deg),
                      messages)
