"""Effects real rigs have and the analytic models lack, each switchable on a render.

Every effect has a name, one parameter with a unit, and one sentence saying
how it shows in the measured kinematics (:data:`EFFECTS`). All are off by
default. ``scene.json`` lists them only when asked (``--declare-effects``),
so a test can make data whose effect the fitting code is not told about.

Physical effects change the motion (:class:`EffectedSpool`, whose physics is
:mod:`.mechanism`, written apart from the fitter's models); recording
effects change which frames are written and the times the container claims
(:func:`recording_times`); camera effects are the render options of the
same names (lens, tilt, exposure).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import CranktrackError
from .mechanism import SpoolBed
from .scenarios import Motion, Scenario, SpoolScenario, motion_from_angle


@dataclass(frozen=True)
class EffectInfo:
    """An effect's kind, its parameter's unit, and how it shows in the data."""

    kind: str  # "physical", "recording" or "camera"
    unit: str
    shows_as: str


EFFECTS: dict[str, EffectInfo] = {
    "slack_mm": EffectInfo(
        "physical", "mm",
        "the crank starts moving slack/speed later than the drive and rocks through a "
        "smaller angle (the first slack of wire is wound in without pulling)"),
    "spool_growth_per_s": EffectInfo(
        "physical", "1/s",
        "the wire's speed grows by this fraction per second as it layers onto the spool, so ω "
        "rises faster than the constant-speed model and the stroke ends sooner"),
    "return_spring_hz": EffectInfo(
        "physical", "Hz",
        "the crank has inertia against the wire and the torsion spring: it rings at this "
        "frequency when the spool starts and when it stops (thesis Fig. 2.36 shows the "
        "stop) and lags a little while the spool runs"),
    "wire_stretch_mm": EffectInfo(
        "physical", "mm",
        "the wire stretches under the return spring's pull (this much at the start): the "
        "crank lags the kinematic model by an angle that grows as the spring winds up and "
        "the moment arm shrinks"),
    "return_spring_zeta": EffectInfo(
        "physical", "1",
        "damping ratio of that ringing (default 0.1 when return_spring_hz is set)"),
    "drive_delay_s": EffectInfo(
        "physical", "s",
        "every movement of the drive reaches the crank this much later (slack as a pure "
        "delay: a slipping coupling or a servo that answers late)"),
    "spool_eccentricity": EffectInfo(
        "physical", "1",
        "the spool turns off-centre, so the wire's speed ripples by ± this fraction once per "
        "spool turn (the fitter's drive_ripple_mm: offset = this × the spool radius)"),
    "spool_radius_mm": EffectInfo(
        "physical", "mm",
        "the spool's bare radius (3 mm unless given): one turn winds 2π × this much wire, "
        "which sets the period of an eccentric spool's ripple"),
    "dead_band_deg": EffectInfo(
        "physical", "deg",
        "play between the wire and the crank (the fitter's play_deg): on the spool the "
        "wire closes this angle before the crank moves, and the crank then stays that far "
        "behind; in the free scenario the wire idles through it, so the swing slows as it "
        "shrinks into the band"),
    "servo_stall_s": EffectInfo(
        "physical", "s",
        "the servo stops for this long halfway through its stroke, then winds the rest: "
        "the crank follows the model until then and trails it afterwards (not in the "
        "fitter's library)"),
    "dropped_frames": EffectInfo(
        "recording", "fraction",
        "this fraction of frames is missing: gaps in the timestamps, never interpolated"),
    "fps_label": EffectInfo(
        "recording", "fps",
        "the container claims this frame rate while the camera ran at --fps, so every measured "
        "rate is scaled by label/true and every duration by true/label"),
    "k1": EffectInfo("camera", "1", "barrel (k1 < 0) or pincushion lens distortion bends the "
                     "frame link and makes 'rigid' lengths vary across the image"),
    "k2": EffectInfo("camera", "1", "higher-order radial distortion, as k1"),
    "tilt_deg": EffectInfo("camera", "deg", "a camera tilted off the plane normal: a scale "
                           "that varies across the image, so angles from a single scale are "
                           "biased"),
    "exposure_s": EffectInfo("camera", "s", "motion blur: moving markers smear along their "
                             "path over the exposure"),
    "readout_s": EffectInfo("camera", "s", "rolling shutter: rows are read out one after "
                            "another over this time, so a marker lower in the image is caught "
                            "later and θ, built from points caught at different instants, "
                            "errs by ω × the time between their rows"),
    "pivot_amp_mm": EffectInfo("physical", "mm", "the whole frame (pivot A and slider end C) "
                               "shakes across the A–C line with this amplitude: θ and ω are "
                               "untouched (they come from the three points together), but A's "
                               "track moves and v_B carries the frame's own velocity"),
    "pivot_hz": EffectInfo("physical", "Hz", "frequency of that shaking (default 5 Hz when "
                           "pivot_amp_mm is set)"),
    "thermal_lag_s": EffectInfo("physical", "s", "(sma scenario) the wire's strain follows "
                                "its transformation through a first-order lag: the crank "
                                "answers each switch of the current later and more smoothly "
                                "than the lumped heat model says"),
    "damping_Nms_rad": EffectInfo("physical", "N·m·s/rad", "(sma scenario) extra viscous "
                                  "drag at the pivot, on top of the bed's own: the crank "
                                  "follows each heating and cooling later and more smoothly "
                                  "but settles at the same angles"),
    "coulomb_Nm": EffectInfo("physical", "N·m", "(sma scenario) dry friction at the pivot, "
                             "as stick and slip: the crank stays put after each switch of "
                             "the current until the wire's pull has changed by twice the "
                             "friction, then trails its balance and stops short of both end "
                             "angles"),
    "strain_delay_s": EffectInfo("physical", "s", "(sma scenario) a dead time between the "
                                 "wire's transformation and its length: the crank answers "
                                 "each switch of the current this much later (the fitter "
                                 "calls it time_offset_s; thermal_lag_s is the lag's other "
                                 "form)"),
    "coulomb_rad_s2": EffectInfo("physical", "rad/s²", "dry friction at the pivot: in "
                                 "the free scenario the swing shrinks by the same angle every "
                                 "half cycle instead of by the same fraction and the crank "
                                 "comes to rest off the springs' equilibrium, on the spool "
                                 "(with return_spring_hz) the crank sticks until the wire's "
                                 "pull overcomes it and stops short of the kinematic angle"),
}

#: Physical effects of the free-response scenario.
FREE_ONLY = ("coulomb_rad_s2",)
#: Physical effects of the SMA bed.
SMA_ONLY = ("thermal_lag_s", "damping_Nms_rad", "coulomb_Nm", "strain_delay_s")

#: Effects that work on any scenario (the rest of the physical ones are the spool's).
ANY_SCENARIO = ("pivot_amp_mm", "pivot_hz")


def check_effects(out: dict[str, float]) -> dict[str, float]:
    """``out`` (effect name → value), refused with one sentence where the effects cannot go
    together or a value cannot be negative."""
    if "return_spring_zeta" in out and "return_spring_hz" not in out:
        raise CranktrackError("return_spring_zeta needs return_spring_hz")
    if "pivot_hz" in out and "pivot_amp_mm" not in out:
        raise CranktrackError("pivot_hz needs pivot_amp_mm")
    if "spool_radius_mm" in out and not out["spool_radius_mm"] > 0:
        raise CranktrackError("spool_radius_mm must be positive")
    if not 0 <= out.get("spool_eccentricity", 0) < 1:
        raise CranktrackError("spool_eccentricity is a fraction of the radius, from 0 to below 1")
    for name in ("readout_s", "pivot_amp_mm", "pivot_hz", "exposure_s", "drive_delay_s",
                 "dead_band_deg", "coulomb_rad_s2", "servo_stall_s", "coulomb_Nm",
                 "strain_delay_s", "thermal_lag_s", "damping_Nms_rad"):
        if name in out and out[name] < 0:
            raise CranktrackError(f"{name} cannot be negative")
    return out


#: Spool effects → the :class:`.mechanism.SpoolBed` field each sets (growth converts).
_SPOOL_FIELDS = {"slack_mm": "slack_mm", "return_spring_hz": "ring_hz",
                 "return_spring_zeta": "ring_zeta", "wire_stretch_mm": "stretch_mm",
                 "drive_delay_s": "delay_s", "spool_eccentricity": "eccentricity",
                 "spool_radius_mm": "spool_radius_mm",
                 "dead_band_deg": "dead_band_deg", "coulomb_rad_s2": "coulomb_rad_s2"}


@dataclass(frozen=True)
class EffectedSpool:
    """The spool scenario with physical effects switched on.

    The physics is :class:`.mechanism.SpoolBed`, written from the rig's parts and
    sharing no code with the models the fitter simulates; this turns its θ(t)
    into marker positions, with ω and α by central differences (h = 0.1 ms).
    """

    base: SpoolScenario = field(default_factory=SpoolScenario)
    effects: dict[str, float] = field(default_factory=dict)
    name: str = "spool"

    def __post_init__(self) -> None:
        _ = self.bed  # refuses effects that cannot go together before anything is written

    @property
    def bed(self) -> SpoolBed:
        d, e = self.base.drive, self.effects
        bed = SpoolBed(L1_mm=d.L1, L2_mm=d.L2, L3_0_mm=d.L3_0, speed_mm_s=d.speed_mm_s,
                       start_s=d.start_s, stroke_mm=d.stroke_mm)
        values = {_SPOOL_FIELDS[k]: v for k, v in e.items() if k in _SPOOL_FIELDS}
        if "spool_growth_per_s" in e:  # a thicker wire layers faster: diameter = g·r/turns
            values["wire_diameter_mm"] = (e["spool_growth_per_s"] * bed.spool_radius_mm
                                          / bed.turn_hz)
        if "servo_stall_s" in e:  # halfway through the stroke as the servo runs it
            values.update(stall_s=e["servo_stall_s"],
                          stall_at_s=d.start_s + 0.5 * d.stroke_mm / d.speed_mm_s)
        if values.get("coulomb_rad_s2", 0) > 0 and "ring_hz" not in values:
            raise CranktrackError("coulomb_rad_s2 on the spool needs return_spring_hz: dry "
                                  "friction acts through the crank's inertia")
        return replace(bed, **values)

    def motion(self, t_s: ArrayLike) -> Motion:
        t = np.asarray(t_s, dtype=float)
        bed, d, h = self.bed, self.base.drive, 1e-4
        theta = bed.theta(t)
        ahead, behind = bed.theta(t + h), bed.theta(np.maximum(t - h, 0.0))
        step = t + h - np.maximum(t - h, 0.0)
        omega = (ahead - behind) / step
        alpha = (ahead - 2 * theta + behind) / h**2
        return motion_from_angle(t, theta, omega, alpha, d.L1, d.L2)

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        lo, hi = self.base.extent_mm()
        if self.effects.get("return_spring_hz", 0) > 0:  # the ring may overshoot
            lo = np.minimum(lo, [0.0, -0.2 * self.base.drive.L2])
        return lo, hi

    def to_dict(self) -> dict:
        return self.base.to_dict()


def recording_times(n: int, fps: float, effects: dict[str, float], seed: int = 0
                    ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Which frames are written and the time the container gives each (s).

    Returns (indices of the frames kept, their container timestamps).
    """
    keep = np.arange(n)
    drop = effects.get("dropped_frames", 0.0)
    if drop > 0:
        if not 0 < drop < 1:
            raise CranktrackError("dropped_frames is a fraction between 0 and 1")
        rng = np.random.default_rng(seed + 7919)
        lost = rng.random(n) < drop
        lost[0] = False
        keep = keep[~lost]
    label = effects.get("fps_label", fps)
    if not label > 0:
        raise CranktrackError("fps_label must be positive")
    return keep, keep / label


@dataclass(frozen=True)
class ShakenFrame:
    """Any scenario on a frame that shakes across the A–C line (pivot motion):
    every point moves by ``amp_mm·sin(2π·hz·t)`` in y, and so does v_B."""

    base: Scenario
    amp_mm: float
    hz: float = 5.0

    @property
    def name(self) -> str:
        return self.base.name

    def motion(self, t_s: ArrayLike) -> Motion:
        t = np.asarray(t_s, dtype=float)
        m = self.base.motion(t)
        w = 2 * np.pi * self.hz
        shift = np.stack([np.zeros_like(t), self.amp_mm * np.sin(w * t)], axis=1)
        speed = np.stack([np.zeros_like(t), self.amp_mm * w * np.cos(w * t)], axis=1)
        return replace(m, points_mm={k: v + shift for k, v in m.points_mm.items()},
                       vB_mm_s=m.vB_mm_s + speed,
                       wires_mm=tuple((a + shift, b + shift) for a, b in m.wires_mm),
                       bars_mm=tuple((a + shift, b + shift) for a, b in m.bars_mm))

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        lo, hi = self.base.extent_mm()
        pad = np.array([0.0, self.amp_mm])
        return lo - pad, hi + pad

    def to_dict(self) -> dict:
        return self.base.to_dict()
