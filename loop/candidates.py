"""The effect library: what each base model can be extended by, as data and prose.

A :class:`Candidate` is one effect a model lacks, with its own physical
parameters (:class:`Parameter`: unit and bounds), its starting values, the value at
which it vanishes, the range a real rig can have and how it shows in θ(t). The
base models' own parameters are here too (``*_BASE``), named as ``--known`` takes
them. The physics of each effect is in :mod:`.simulate` and :mod:`.camera_view`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
    #: Where the fit has a valley per class of motion (dry friction: one per number of
    #: swings before the crank sticks; a ripple: one per number of cycles), the
    #: parameter profiled over before the fit and its range (in its unit); a data guess
    #: of it narrows the range.
    scan: tuple[str, float, float] | None = None


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
              "the crank has inertia: it rings when the drive starts and when it stops, and "
              "lags a little while it runs"),
    Candidate("wire_stretch_mm", "physical",
              (Parameter("wire_stretch_mm", "mm", 0.0, 10.0),), ((0.1,), (0.5,)), 0.0,
              (0.0, 10.0),
              "the crank lags the kinematic model by an angle that grows as the return "
              "spring winds up and the moment arm shrinks: the wire stretches under its pull",
              also_looks_like="a compliant mounting of the spool or the pivot; a stiffer "
              "(steel) wire, or a lighter return spring, shrinks a wire stretch and nothing "
              "else"),
    Candidate("drive_ripple_mm", "physical",
              (Parameter("drive_ripple_mm", "mm", 0.0, 5.0),
               # A turn longer than a few strokes is a bend, not a ripple: it would
               # stand in for slack or growth (it did, at 296 mm, on a slack of 1 mm).
               Parameter("ripple_turn_mm", "mm", 1.0, 50.0),
               Parameter("ripple_phase_deg", "deg", -360.0, 720.0)),
              ((0.05, 10.0, 0.0), (0.05, 10.0, 90.0)), 0.0, (0.0, 5.0),
              "the wire's speed ripples once per spool turn (an off-centre spool or a "
              "wobbling servo horn): ω wobbles while the drive runs, at the turn rate, and "
              "nowhere else",
              also_looks_like="a servo whose speed wavers with its own control loop (a "
              "ripple not at the turn rate); mark the spool's rim and count turns to check "
              "that ripple_turn_mm is one turn's wire (2π × the spool radius)",
              scan=("ripple_turn_mm", 2.0, 50.0)),
    Candidate("play_deg", "physical", (Parameter("play_deg", "deg", 0.0, 30.0),),
              ((0.3,), (1.5,)), 0.0, (0.0, 20.0),
              "play (a dead band) between the wire and the crank: the crank stays at rest "
              "until the wire has turned the play, then trails the play-free linkage by the "
              "whole play and rocks through that much less",
              needs_known=("start_s", "stroke_mm"),
              separated_by="hold the wire and rock the crank by hand: play is the angle it "
              "moves freely; or pre-tension the wire before the start, which takes up slack "
              "and leaves play",
              also_looks_like="slack in the wire (slack_mm): slack is wire lost at the "
              "start, play an angle lost at the crank; they part only as the wire's lever "
              "arm changes over the stroke"),
    Candidate("coulomb_rad_s2", "physical",
              (Parameter("coulomb_rad_s2", "rad/s²", 0.0, 1e3),
               Parameter("return_spring_hz", "Hz", 0.05, 1e3),
               Parameter("return_spring_zeta", "1", 0.001, 0.99)),
              ((0.5, 3.0, 0.1), (2.0, 3.0, 0.1), (0.5, 8.0, 0.1), (2.0, 1.0, 0.1)), 0.0,
              (0.0, 1e3),
              "dry friction at the pivot, acting through the crank's inertia: the crank "
              "breaks away late, stops short of the wire's angle, and its ring at the stop "
              "dies in a few swings, each smaller by the same angle, and freezes off "
              "balance",
              also_looks_like="a crank with inertia and more viscous damping "
              "(return_spring_hz with a larger zeta); dry friction stops the ring dead "
              "after a few swings, viscous damping never quite does: film the stop at a "
              "higher frame rate, or run the drive at two speeds",
              scan=("coulomb_rad_s2", 0.01, 30.0)),
    Candidate("clock_scale", "recording", (Parameter("clock_scale", "1", 0.2, 5.0),),
              ((1.02,), (0.98,)), 1.0, (0.2, 5.0),
              "every rate is off by one factor: the container's frame rate is not the "
              "camera's (true time = clock_scale × video time)",
              needs_known=("speed_mm_s",),
              separated_by="film a clock or a stopwatch, or measure the spool speed on the bench",
              also_looks_like="a spool speed off its nominal value by the same factor; a "
              "stopwatch in the picture separates the two"),
)}


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
              (Parameter("coulomb_rad_s2", "rad/s²", 0.0, 1e3),),
              ((0.1,), (0.3,), (1.0,), (3.0,)), 0.0,
              (0.0, 1e3),
              "the swing shrinks by the same angle every half cycle instead of by the same "
              "fraction, and the crank stops off the springs' equilibrium",
              also_looks_like="stiction in a bearing or a rubbing marker; a swing started "
              "from a larger angle separates it from extra viscous damping (dry friction "
              "costs the same angle per swing whatever the amplitude)",
              scan=("coulomb_rad_s2", 0.01, 30.0)),
    Candidate("play_deg", "physical", (Parameter("play_deg", "deg", 0.0, 30.0),),
              ((0.5,), (2.0,)), 0.0, (0.0, 20.0),
              "play (a dead band) between the wire and the crank: within it the wire is "
              "idle, so the swing slows as it shrinks into the band (the torsion spring "
              "alone is softer) and the crank settles where the torsion spring balances "
              "the wire at the band's edge",
              also_looks_like="a softer wire spring (smaller k_s) or a bias spring whose "
              "rest angle is elsewhere; those keep the period as the swing decays, play "
              "does not: start the swing from two amplitudes and compare the periods",
              separated_by="hold the crank and move the wire's end by hand: play is the "
              "angle the crank turns before the wire tightens"),
)}


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
    Candidate("coulomb_Nm", "physical", (Parameter("coulomb_Nm", "N·m", 0.0, 0.5),),
              ((0.003,), (0.02,)), 0.0, (0.0, 0.5),
              "dry friction at the pivot: the crank trails the balance by friction / "
              "stiffness while it moves, so it stops short of both end angles, and after "
              "each switch of the current it stays put until the wire's pull has changed "
              "by twice the friction",
              also_looks_like="a thermal lag (which delays the turn but does not cut the "
              "angles short) or a smaller recovery strain (which cuts the heated angle "
              "short but not the cooled one); a wire under a larger preload presses the "
              "pin harder and grows dry friction, and nothing else here"),
    Candidate("time_offset_s", "recording", (Parameter("time_offset_s", "s", -5.0, 5.0),),
              ((0.05,), (-0.05,)), 0.0, (-5.0, 5.0),
              "every switch of the current takes effect later (or earlier) on the video's "
              "clock than the logged times",
              separated_by="film the power supply's indicator, or log the "
              "current on the same clock as the camera"),
)}
