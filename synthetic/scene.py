"""Render a scenario to a folder: ``video.mp4``, ``truth.csv`` and ``scene.json``."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import CranktrackError
from ..files import ensure_dir, write_csv_atomic, write_json_atomic
from .camera import Camera, PinholeCamera
from .effects import (
    ANY_SCENARIO,
    EFFECTS,
    FREE_ONLY,
    SMA_ONLY,
    EffectedSpool,
    ShakenFrame,
    recording_times,
)
from .render import Style, draw_capsule, render_frame, to_uint8
from .scenarios import (
    FreeScenario,
    Motion,
    Scenario,
    SMAScenario,
    SpoolScenario,
)
from .truth import truth_table
from .video import VideoWriter

#: Version of the ``scene.json`` layout.
SCENE_SCHEMA = 1


@dataclass(frozen=True)
class RenderSettings:
    """How to film a scenario.

    ``size`` is (width, height) in px, ``fps`` frames per second, ``seconds``
    the clip length, ``noise_dn`` the sensor noise σ in 8-bit digital
    numbers, ``lossless`` picks bit-exact RGB over ordinary H.264 at ``crf``.

    Real-camera conditions: ``exposure_s`` > 0 blurs motion by averaging
    ``blur_samples`` renders across the exposure (centred on the frame time,
    which is the time in ``truth.csv``); ``light_gradient`` is a left-to-right
    change of illumination (fraction of the mean, e.g. 0.3) whose strength
    sweeps over the clip as ``sin(π·t/seconds)``; ``readout_s`` > 0 is a
    rolling shutter: the row at height y is caught ``readout_s·y/height``
    after the frame time (the first row is caught at the frame time).
    """

    size: tuple[int, int] = (1280, 720)
    fps: float = 30.0
    seconds: float = 2.5
    noise_dn: float = 0.0
    seed: int = 0
    lossless: bool = False
    crf: int = 20
    exposure_s: float = 0.0
    blur_samples: int = 7
    light_gradient: float = 0.0
    readout_s: float = 0.0

    @property
    def n_frames(self) -> int:
        """Frames in the clip (at least one)."""
        return max(1, round(self.seconds * self.fps))


@dataclass(frozen=True)
class SceneFiles:
    """Paths of a rendered scene."""

    folder: Path
    video: Path
    truth: Path
    scene: Path


def scenario_camera(scenario: Scenario, size: tuple[int, int], tilt_deg: float = 0.0,
                    k1: float = 0.0, k2: float = 0.0, pinhole: bool = False
                    ) -> Camera | PinholeCamera:
    """The default framing: the whole motion centred, filling 80 % of the image.

    Straight overhead without distortion: the exact similarity camera; with a
    tilt or distortion (or ``pinhole=True``): a 60° pinhole at the distance
    that frames the same.
    """
    lo, hi = scenario.extent_mm()
    if tilt_deg == 0 and k1 == 0 and k2 == 0 and not pinhole:
        return Camera.framing(size[0], size[1], lo, hi, fill=0.8)
    return PinholeCamera.framing(size[0], size[1], lo, hi, fill=0.8, tilt_deg=tilt_deg,
                                 k1=k1, k2=k2)


def _expose(scenario: Scenario, camera: Camera | PinholeCamera, settings: RenderSettings,
            style: Style, t: float, cover: tuple[str, ...] = ()) -> np.ndarray:
    """One frame: drawn in the ideal image (the mean of renders across the
    exposure, for motion blur), covers added, then bent through the lens."""
    if settings.exposure_s > 0:
        times = t + settings.exposure_s * (np.linspace(0, 1, settings.blur_samples) - 0.5)
    else:
        times = np.array([t])
    motion = scenario.motion(times)
    if settings.readout_s > 0:
        motion = _rolling(scenario, camera, settings, times, motion)
    canvas, offset = camera.ideal_canvas()
    to_plane = camera.canvas_to_plane(offset)
    img = None
    for j in range(len(times)):
        if to_plane is not None:  # drawn on the plane: discs seen as the camera sees them
            frame = render_frame(
                {k: v[j] for k, v in motion.points_mm.items()}, canvas, 1.0, style,
                wires=[(a[j], b[j]) for a, b in motion.wires_mm] if motion.wires_mm else None,
                bars=[(a[j], b[j]) for a, b in motion.bars_mm], to_plane=to_plane)
        else:
            pts = {k: camera.ideal_project(v[j]) + np.asarray(offset)
                   for k, v in motion.points_mm.items()}
            scales = {k: float(camera.local_scale(v[j])) for k, v in motion.points_mm.items()}

            def project(segments, j=j):
                return [(camera.ideal_project(a[j]) + np.asarray(offset),
                         camera.ideal_project(b[j]) + np.asarray(offset)) for a, b in segments]

            frame = render_frame(pts, canvas, scales, style,
                                 wires=project(motion.wires_mm) if motion.wires_mm else None,
                                 bars=project(motion.bars_mm))
        img = frame if img is None else img + frame
    img /= np.float32(len(times))
    mid = scenario.motion(np.array([t]))
    for name in cover:
        xy = mid.points_mm[name][0]
        _draw_cover(img, camera.ideal_project(xy) + np.asarray(offset),
                    style.marker_radius_mm * float(camera.local_scale(xy)))
    return camera.warp(img, offset)


def _rolling(scenario: Scenario, camera: Camera | PinholeCamera, settings: RenderSettings,
             times: np.ndarray, motion: Motion) -> Motion:
    """Each marker where it is when the shutter reaches its row (one fixed-point step:
    a marker moves far less than a row in the readout time)."""
    points = {}
    for name, xy in motion.points_mm.items():
        rows = np.asarray(camera.project(xy))[:, 1]
        late = times + settings.readout_s * np.clip(rows, 0, settings.size[1]) / settings.size[1]
        points[name] = scenario.motion(late).points_mm[name]
    return replace(motion, points_mm=points)


def _draw_cover(img: np.ndarray, centre_px: np.ndarray, radius_px: float) -> None:
    """A grey strip over the right third of a marker (a finger, a cable)."""
    x = centre_px[0] + 0.75 * radius_px
    p0 = np.array([x, centre_px[1] - 2.5 * radius_px])
    p1 = np.array([x, centre_px[1] + 2.5 * radius_px])
    draw_capsule(img, p0, p1, 0.5 * radius_px, (95.0, 92.0, 90.0), 4)


def _light(settings: RenderSettings, t: float) -> np.ndarray:
    """Multiplicative illumination: a horizontal ramp whose strength sweeps in time."""
    w = settings.size[0]
    g = settings.light_gradient * np.sin(np.pi * t / max(settings.seconds, 1e-9))
    ramp = 1.0 + g * (np.arange(w, dtype=np.float32) / max(w - 1, 1) - 0.5)
    return ramp[None, :, None].astype(np.float32)


def render_scene(
    scenario: Scenario,
    out_dir: str | os.PathLike,
    settings: RenderSettings = RenderSettings(),
    style: Style | None = None,
    camera: Camera | PinholeCamera | None = None,
    on_frame: Callable[[int, int], None] | None = None,
    hidden: dict[str, Iterable[int]] | None = None,
    covered: dict[str, Iterable[int]] | None = None,
    effects: dict[str, float] | None = None,
    declare_effects: bool = False,
) -> SceneFiles:
    """Render ``scenario`` and write the video, its truth and its description.

    ``hidden`` maps a marker name to the frames in which it is not drawn
    (covered, or absent); its truth there keeps the position but has
    ``_ok = False``. ``covered`` maps a marker name to frames in which a grey
    strip hides about a third of it (the truth stays ``_ok``).
    ``effects`` switches on physical and recording effects of
    :mod:`.effects` (camera effects are the ``camera`` and ``settings``
    themselves); ``scene.json`` lists them only with ``declare_effects``.
    ``on_frame(i, n)`` is called after each frame (for a progress bar).
    """
    style = style or Style()
    effects = dict(effects or {})
    physical = {k: v for k, v in effects.items()
                if EFFECTS[k].kind == "physical" and k not in ANY_SCENARIO + FREE_ONLY + SMA_ONLY}
    for name in SMA_ONLY:
        if name in effects and not isinstance(scenario, SMAScenario):
            raise CranktrackError(f"{name} applies to the sma scenario")
    if "thermal_lag_s" in effects:
        scenario = replace(scenario, bed=replace(scenario.bed,
                                                 thermal_lag_s=effects["thermal_lag_s"]))
    if "damping_Nms_rad" in effects:
        bed = scenario.bed
        scenario = replace(scenario, bed=replace(
            bed, damping_Nms_rad=bed.damping_Nms_rad + effects["damping_Nms_rad"]))
    for name in ("coulomb_Nm", "strain_delay_s"):
        if name in effects:
            scenario = replace(scenario, **{name: effects[name]})
    if "dead_band_deg" in effects and isinstance(scenario, FreeScenario):
        physical.pop("dead_band_deg")
        scenario = replace(scenario, dynamics=replace(
            scenario.dynamics, play=float(np.radians(effects["dead_band_deg"]))))
    if "coulomb_rad_s2" in effects and isinstance(scenario, SpoolScenario):
        physical["coulomb_rad_s2"] = effects["coulomb_rad_s2"]
    elif "coulomb_rad_s2" in effects:
        if not isinstance(scenario, FreeScenario):
            raise CranktrackError("coulomb_rad_s2 applies to the free and spool scenarios")
        scenario = replace(scenario, dynamics=replace(scenario.dynamics,
                                                      coulomb=effects["coulomb_rad_s2"]))
    if physical:
        if not isinstance(scenario, SpoolScenario):
            if "dead_band_deg" in physical:
                raise CranktrackError("dead_band_deg applies to the spool and free scenarios")
            raise CranktrackError(f"the effects {sorted(physical)} apply to the spool scenario")
        scenario = EffectedSpool(scenario, physical)
    if effects.get("pivot_amp_mm", 0) > 0:
        scenario = ShakenFrame(scenario, effects["pivot_amp_mm"], effects.get("pivot_hz", 5.0))
    camera = camera or scenario_camera(scenario, settings.size)
    created = not Path(out_dir).exists()
    folder = ensure_dir(out_dir)  # only once the request is known to be good
    keep, stamps = recording_times(settings.n_frames, settings.fps, effects, settings.seed)
    n = len(keep)
    t = keep / settings.fps  # when each written frame was really taken
    motion = scenario.motion(t)
    truth = truth_table(motion, camera)
    hide = {k: set(v) for k, v in (hidden or {}).items()}
    cover = {k: set(v) for k, v in (covered or {}).items()}
    for name, frames in hide.items():
        truth.loc[truth["frame"].isin(frames), f"{name}_ok"] = False
    video = folder / "video.mp4"
    try:
        _write_frames(video, scenario, camera, settings, style, (t, stamps), hide, cover,
                      on_frame)
    except KeyboardInterrupt:
        video.unlink(missing_ok=True)  # half a video is not a render
        if created and not any(folder.iterdir()):
            folder.rmdir()  # Ctrl-C leaves no empty folder behind
        raise
    truth_path = write_csv_atomic(folder / "truth.csv", truth)
    scene = {
        "schema": SCENE_SCHEMA,
        "scenario": scenario.to_dict(),
        "camera": camera.to_dict(),
        "render": {
            "width": settings.size[0], "height": settings.size[1], "fps": settings.fps,
            "frames": n, "noise_dn": settings.noise_dn, "seed": settings.seed,
            "codec": "libx264rgb qp0 (lossless)" if settings.lossless
            else f"libx264 yuv420p crf {settings.crf}",
            "supersample": style.supersample,
            "exposure_s": settings.exposure_s,
            "light_gradient": settings.light_gradient,
            "readout_s": settings.readout_s,
        },
        "style": {
            "marker_radius_mm": style.marker_radius_mm,
            "marker_radius_px": float(style.marker_radius_mm
                                      * np.median(camera.local_scale(motion.points_mm["B"]))),
            "markers_rgb": style.markers,
            "background_rgb": style.background,
            "illuminant": style.illuminant,
        },
        "hidden": {k: sorted(v) for k, v in hide.items()},
        "covered": {k: sorted(v) for k, v in cover.items()},
        "effects": effects if declare_effects else ("not declared" if effects else {}),
    }
    scene_path = write_json_atomic(folder / "scene.json", scene)
    return SceneFiles(folder, video, truth_path, scene_path)


def _write_frames(video: Path, scenario: Scenario, camera: Camera | PinholeCamera,
                  settings: RenderSettings, style: Style,
                  times: tuple[NDArray[np.float64], NDArray[np.float64]],
                  hide: dict[str, set[int]], cover: dict[str, set[int]],
                  on_frame: Callable[[int, int], None] | None) -> None:
    """Draw and encode every frame: taken at ``times[0]`` (s), stamped ``times[1]``."""
    t, stamps = times
    n = len(t)
    rng = np.random.default_rng(settings.seed)
    with VideoWriter(video, *settings.size, settings.fps, settings.lossless,
                     settings.crf) as writer:
        for i in range(n):
            shown = Style(**{**style.__dict__, "markers": {
                k: c for k, c in style.markers.items() if i not in hide.get(k, ())}})
            covering = tuple(k for k, frames in cover.items() if i in frames)
            img = _expose(scenario, camera, settings, shown, float(t[i]), covering)
            if settings.light_gradient:
                img *= _light(settings, float(t[i]))
            writer.write(to_uint8(img, settings.noise_dn, rng), float(stamps[i]))
            if on_frame:
                on_frame(i + 1, n)


#: Effects that are the camera itself (its tilt, deg, and lens k1, k2) or the render's
#: settings (exposure and rolling-shutter readout, s), not the scene.
CAMERA_EFFECTS = ("k1", "k2", "tilt_deg")
SETTING_EFFECTS = ("exposure_s", "readout_s")


def render_effects(
    scenario: Scenario,
    out_dir: str | os.PathLike,
    settings: RenderSettings,
    effects: dict[str, float],
    tilt_deg: float = 0.0,
    k1: float = 0.0,
    k2: float = 0.0,
    on_frame: Callable[[int, int], None] | None = None,
    declare_effects: bool = False,
) -> SceneFiles:
    """:func:`render_scene` with ``effects`` of every kind, as ``cranktrack synth`` takes them.

    Camera effects (:data:`CAMERA_EFFECTS`) replace ``tilt_deg`` (deg), ``k1`` and ``k2``
    of the default framing (:func:`scenario_camera`); exposure and readout (s) replace the
    ``settings``' own; the rest go to the scene.
    """
    camera = {"tilt_deg": tilt_deg, "k1": k1, "k2": k2}
    camera.update({k: v for k, v in effects.items() if k in CAMERA_EFFECTS})
    settings = replace(settings, **{k: v for k, v in effects.items() if k in SETTING_EFFECTS})
    return render_scene(scenario, out_dir, settings,
                        camera=scenario_camera(scenario, settings.size, **camera),
                        on_frame=on_frame, effects=effects, declare_effects=declare_effects)
