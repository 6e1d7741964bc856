"""Helpers shared by the benchmarks: renders that are made once and reused, decoding
alone as the measure of speed, and #20's aims as a table."""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import av
import numpy as np

from cranktrack.synthetic.scenarios import SpoolScenario
from cranktrack.synthetic.scene import RenderSettings, SceneFiles, render_scene
from cranktrack.tracker.track import TrackResult

CACHE = Path(__file__).resolve().parent / ".cache"


def decode_only(path: Path, fmt: str | None = "rgb24") -> tuple[int, float]:
    """Decode every frame to arrays and nothing else, as a user's own PyAV loop would
    (FFmpeg's threads, its own colour conversion): RGB (what a pipeline that works on
    RGB needs) or, with ``fmt=None``, the decoder's own YUV planes (the floor: no
    colour conversion at all). Returns the frames and the seconds taken.

    This is the reference for tracking speed: it shares no code with cranktrack's
    reader, whose whole-frame conversion is several times slower than FFmpeg's."""
    t = time.perf_counter()
    n = 0
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        for frame in container.decode(stream):
            frame.to_ndarray(format=fmt) if fmt else frame.to_ndarray()
            n += 1
    return n, time.perf_counter() - t


def scene(name: str, settings: RenderSettings) -> SceneFiles:
    """Render a spool scene into ``bench/.cache/NAME`` unless it is already there."""
    folder = CACHE / name
    files = SceneFiles(folder, folder / "video.mp4", folder / "truth.csv", folder / "scene.json")
    if not files.video.exists():
        t = time.perf_counter()
        render_scene(SpoolScenario(), folder, settings)
        print(f"rendered {name} in {time.perf_counter() - t:.1f} s")
    return files


def clip_1080p(frames: int) -> SceneFiles:
    """The 1920×1080 H.264 spool render that bench/speed.py and bench/memory.py share
    (30 fps, noise 2.5 DN, seed 5), ``frames`` long; one cache folder per length."""
    return scene(f"speed_1080p_{frames}", RenderSettings(
        size=(1920, 1080), fps=30.0, seconds=frames / 30.0, noise_dn=2.5, seed=5))


def track_command(files: SceneFiles, out: Path, video: Path | None = None) -> list[str]:
    """``cranktrack track`` as a user runs it on a render (or on ``video``, a copy of its
    frames): with the render's own A–C length, so kinematics, tables and report are
    all made."""
    length = json.loads(files.scene.read_text())["scenario"]["L1"]
    return [sys.executable, "-m", "cranktrack", "track", str(video or files.video),
            "--out", str(out), "--known-length", f"A-C={length}", "--quiet"]


@dataclass
class Scorecard:
    """#20's "Done when", clip by clip: each figure the bench measured against its aim,
    gathered as the clips run and printed last (:meth:`show`)."""

    rows: list[tuple[str, str, str, str, bool]] = field(default_factory=list)

    def add(self, clip: str, what: str, figure: str, aim: str, met: bool) -> None:
        """One measured figure of ``clip`` and whether it meets ``aim``."""
        self.rows.append((clip, what, figure, aim, bool(met)))

    def show(self) -> None:
        """The table, then how many figures meet their aims."""
        if not self.rows:
            return
        print("\n#20's aims, as measured in this run (the lines above say why each is so):")
        widths = [max(len(r[k]) for r in self.rows) for k in range(4)]
        for clip, what, figure, aim, met in self.rows:
            print(f"  {clip:<{widths[0]}}  {what:<{widths[1]}}  {figure:>{widths[2]}}  "
                  f"aim {aim:<{widths[3]}}  {'met' if met else 'NOT met'}")
        print(f"  {sum(r[4] for r in self.rows)} of {len(self.rows)} met")


def sure_of_nothing(result: TrackResult, name: str) -> int:
    """Rows of marker ``name`` that are ``ok`` with a σ that is not finite or not under
    the radius the run learned for it (#20: there must be none)."""
    tab = result.tracks
    ok = tab[f"{name}_ok"].to_numpy(bool)
    sigma = tab[f"{name}_sigma_px"].to_numpy(float)
    radius = (result.learned.get(name) or {}).get("radius_px")
    bad = ok & ~np.isfinite(sigma)
    if radius is not None:
        bad |= ok & ~(sigma < radius)
    return int(bad.sum())
