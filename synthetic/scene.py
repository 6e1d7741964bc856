"""Render a scenario to a folder: ``video.mp4``, ``truth.csv`` and ``scene.json``."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cranktrack.files import ensure_dir, write_csv_atomic, write_json_atomic
from cranktrack.synthetic.camera import Camera
from cranktrack.synthetic.render import Style, render_frame, to_uint8
from cranktrack.synthetic.scenarios import SpoolScenario
from cranktrack.synthetic.truth import truth_table
from cranktrack.synthetic.video import VideoWriter

#: Version of the ``scene.json`` layout.
SCENE_SCHEMA = 1


@dataclass(frozen=True)
class RenderSettings:
    """How to film a scenario.

    ``size`` is (width, height) in px, ``fps`` frames per second, ``seconds``
    the clip length, ``noise_dn`` the sensor noise σ in 8-bit digital
    numbers, ``lossless`` picks bit-exact RGB over ordinary H.264 at ``crf``.
    """

    size: tuple[int, int] = (1280, 720)
    fps: float = 30.0
    seconds: float = 2.5
    noise_dn: float = 0.0
    seed: int = 0
    lossless: bool = False
    crf: int = 20

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


def scenario_camera(scenario: SpoolScenario, size: tuple[int, int]) -> Camera:
    """The default framing: the whole motion (plus a marker's margin) centred."""
    lo, hi = scenario.extent_mm()
    return Camera.framing(size[0], size[1], lo, hi, fill=0.8)


def render_scene(
    scenario: SpoolScenario,
    out_dir: str | os.PathLike,
    settings: RenderSettings = RenderSettings(),
    style: Style | None = None,
    camera: Camera | None = None,
    on_frame: Callable[[int, int], None] | None = None,
    hidden: dict[str, Iterable[int]] | None = None,
) -> SceneFiles:
    """Render ``scenario`` and write the video, its truth and its description.

    ``hidden`` maps a marker name to the frames in which it is not drawn
    (covered, or absent); its truth there keeps the position but has
    ``_ok = False``. ``on_frame(i, n)`` is called after each frame (for a
    progress bar).
    """
    style = style or Style()
    folder = ensure_dir(out_dir)
    camera = camera or scenario_camera(scenario, settings.size)
    n = settings.n_frames
    t = np.arange(n) / settings.fps
    motion = scenario.motion(t)
    truth = truth_table(motion, camera)
    hide = {k: set(v) for k, v in (hidden or {}).items()}
    for name, frames in hide.items():
        truth.loc[truth["frame"].isin(frames), f"{name}_ok"] = False
    rng = np.random.default_rng(settings.seed)
    video = folder / "video.mp4"
    with VideoWriter(video, *settings.size, settings.fps, settings.lossless,
                     settings.crf) as writer:
        for i in range(n):
            pts = {k: camera.project(v[i]) for k, v in motion.points_mm.items()}
            shown = Style(**{**style.__dict__, "markers": {
                k: c for k, c in style.markers.items() if i not in hide.get(k, ())}})
            img = render_frame(pts, settings.size, camera.px_per_mm, shown)
            writer.write(to_uint8(img, settings.noise_dn, rng), float(t[i]))
            if on_frame:
                on_frame(i + 1, n)
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
        },
        "style": {
            "marker_radius_mm": style.marker_radius_mm,
            "marker_radius_px": style.marker_radius_mm * camera.px_per_mm,
            "markers_rgb": style.markers,
            "background_rgb": style.background,
            "illuminant": style.illuminant,
        },
        "hidden": {k: sorted(v) for k, v in hide.items()},
        "effects": [],
    }
    scene_path = write_json_atomic(folder / "scene.json", scene)
    return SceneFiles(folder, video, truth_path, scene_path)
