"""Helpers shared by the benchmarks: renders that are made once and reused."""

from __future__ import annotations

import time
from pathlib import Path

from cranktrack.synthetic.scenarios import SpoolScenario
from cranktrack.synthetic.scene import RenderSettings, SceneFiles, render_scene

CACHE = Path(__file__).resolve().parent / ".cache"


def scene(name: str, settings: RenderSettings) -> SceneFiles:
    """Render a spool scene into ``bench/.cache/NAME`` unless it is already there."""
    folder = CACHE / name
    files = SceneFiles(folder, folder / "video.mp4", folder / "truth.csv", folder / "scene.json")
    if not files.video.exists():
        t = time.perf_counter()
        render_scene(SpoolScenario(), folder, settings)
        print(f"rendered {name} in {time.perf_counter() - t:.1f} s")
    return files
