"""Markers filmed close: discs of radius 15, 30 and 60 px in 1080p, how well and how fast.

A phone a hand's width from the crank-slider gives markers 50–150 px across. This bench
draws the three discs (green A, red B, blue C) on a 1920×1080 scene with uneven light
and 2 DN of noise, at radius 15, 30 and 60 px: A slides (4 px a frame along x, 1.3
along y), B goes round a 250 px circle once in 3 s (26 px a frame), C stands still.
Each disc is its exact coverage, drawn by OpenCV 8× over and averaged down
(``cv2.INTER_AREA``); the scene is coded by PyAV as H.264 4:2:0 (crf 18, as a phone
stores it) and as lossless RGB (x264's RGB mode; a third as many frames, as it decodes
slowly). The truth is where the discs were drawn; it
shares no code with cranktrack.

Per clip and marker it prints the frames found, the mean offset (x, y) and RMS distance
from the drawn centre (px), the fraction of frames whose error lies within ±1σ along
x and along y (each axis counted), and the median σ; then tracking time against PyAV
decoding the same file to RGB (the fastest of ``--rounds`` runs of each, back to back).
The truth is taken at each frame's number, not at the time the file stores.

With ``--wire`` a dark wire runs from B's centre to C's, in front of them, as the
crank-slider's SMA wire runs: an eighth of the discs' radius wide, as the thesis's
0.5 mm wire is on its 8 mm discs (a rig filmed closer shows a wider wire). With
``--white`` the discs are white, and tracked as white markers named A, B and C. With
``--nearer F`` the discs grow steadily from the radius given to F times it over the
clip, as a rig does that comes nearer the camera (or a hand-held phone moved in).

    .venv/bin/python bench/large_markers.py [--frames 90] [--rounds 3] [--radii 15 30 60]
        [--wire] [--white] [--nearer 1.45]

The clips are made once into ``bench/.cache/large_markers``.
"""

from __future__ import annotations

import argparse
import fractions
import math
import os
import sys
import time
from pathlib import Path

import av
import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import CACHE, decode_only

from cranktrack.environment import versions_line
from cranktrack.tracker.markers import DEFAULT_MARKERS, parse_markers
from cranktrack.tracker.track import track
from cranktrack.tracker.video import open_frames
from cranktrack.warmup import compile_kernels

W, H, FPS = 1920, 1080, 30
UP = 8  # each disc's coverage is drawn this many times larger, then averaged down
WIRE_UP = 4  # ...and the wire's
RADII = (15, 30, 60)
COLOURS = {"A": (40, 190, 70), "B": (200, 40, 40), "C": (40, 70, 200)}
WHITE = (235, 235, 235)
#: name, encoder, pixel format, options, container.
CODINGS = [("H.264 4:2:0 crf 18", "libx264", "yuv420p", {"crf": "18", "preset": "fast"}, "mp4"),
           ("H.264 RGB (lossless)", "libx264rgb", "bgr24", {"crf": "0", "preset": "fast"},
            "mkv")]


def drawn(t: float) -> dict[str, tuple[float, float]]:
    """Where each disc's centre is at time ``t`` (s), in px (pixel centres at integers)."""
    k = t * FPS
    turn = 2 * math.pi * t / 3.0
    return {"A": (300.0 + 4.0 * k, 400.0 + 1.3 * k),
            "B": (1100.0 + 250.0 * math.cos(turn), 540.0 + 250.0 * math.sin(turn)),
            "C": (1650.0, 250.0)}


def coverage(x: float, y: float, radius: float) -> tuple[np.ndarray, int, int]:
    """The fraction of each pixel a disc of ``radius`` px at (x, y) covers, over the
    patch it lies in, and the patch's top-left pixel."""
    half = math.ceil(radius) + 4
    x0, y0 = math.floor(x) - half, math.floor(y) - half
    size = 2 * half + 2
    big = np.zeros((size * UP, size * UP), np.uint8)
    # Pixel (i, j) spans [j − ½, j + ½]: at UP× its centre is at (j + ½)·UP − ½.
    centre = [round((((v - o) + 0.5) * UP - 0.5) * 64) for v, o in ((x, x0), (y, y0))]
    cv2.circle(big, tuple(centre), round(radius * UP * 64), 255, -1, cv2.LINE_AA, 6)
    small = cv2.resize(big.astype(np.float32) / 255.0, (size, size),
                       interpolation=cv2.INTER_AREA)
    return small, x0, y0


def picture(t: float, radius: float, background: np.ndarray, rng: np.random.Generator,
            wire: bool = False, colours: dict | None = None) -> np.ndarray:
    """The scene at time ``t`` (s): the discs of ``radius`` px over ``background`` (float
    RGB), with 2 DN of noise, as 8-bit RGB; with ``wire``, a dark wire an eighth of their
    radius wide in front of them from B's centre to C's, as the crank-slider's runs.
    ``colours``: each disc's RGB (:data:`COLOURS` by default)."""
    colours = colours or COLOURS
    img = background.copy()
    at = drawn(t)
    for name, (x, y) in at.items():
        m, x0, y0 = coverage(x, y, radius)
        h, w = m.shape
        under = img[y0:y0 + h, x0:x0 + w]
        under[:] = under * (1 - m[..., None]) + np.array(colours[name], float) * m[..., None]
    if wire:
        # Drawn WIRE_UP× over and averaged down, as wide as the thesis's 0.5 mm wire on
        # its 8 mm discs: an eighth of their radius.
        line = np.zeros((H * WIRE_UP, W * WIRE_UP), np.uint8)
        ends = [tuple(round(((v + 0.5) * WIRE_UP - 0.5) * 16) for v in at[m]) for m in "BC"]
        cv2.line(line, ends[0], ends[1], 255, max(1, round(radius / 8 * WIRE_UP)),
                 cv2.LINE_AA, 4)
        m = cv2.resize(line.astype(np.float32) / 255.0, (W, H),
                       interpolation=cv2.INTER_AREA)[..., None]
        img = img * (1 - m) + np.array([70.0, 70.0, 75.0]) * m
    img += rng.normal(0.0, 2.0, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def radius_at(k: int, radius: int, frames: int, nearer: float) -> float:
    """The discs' radius in frame ``k`` (px): ``radius`` growing steadily to ``nearer``
    times it in the last of ``frames``."""
    return radius * (1.0 + (nearer - 1.0) * k / max(frames - 1, 1))


def write(path: Path, radius: int, encoder: str, layout: str, options: dict,
          frames: int, wire: bool, colours: dict, nearer: float = 1.0) -> None:
    """One clip: ``frames`` frames at 30 fps of discs of ``radius`` px in ``colours`` (and
    the wire), growing to ``nearer`` times that radius."""
    yy, xx = np.mgrid[0:H, 0:W]
    # Uneven light: brighter to the left and top, as a lamp beside the rig.
    light = 0.85 + 0.3 * (1 - xx / W) * (1 - 0.5 * yy / H)
    background = (np.array([105.0, 110.0, 100.0]) * light[..., None])
    rng = np.random.default_rng(radius)
    # One part file a process: two runs making the same clip at once each finish their
    # own (a shared one was renamed away under the second, which then stopped).
    tmp = path.with_suffix(f".part{os.getpid()}" + path.suffix)
    with av.open(str(tmp), "w") as out:
        s = out.add_stream(encoder, rate=FPS, options=options)
        s.width, s.height, s.pix_fmt = W, H, layout
        for k in range(frames):
            rgb = picture(k / FPS, radius_at(k, radius, frames, nearer), background, rng,
                          wire, colours)
            frame = av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(format=layout)
            frame.pts, frame.time_base = k, fractions.Fraction(1, FPS)
            out.mux(s.encode(frame))
        out.mux(s.encode())
    tmp.rename(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=90)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--radii", type=int, nargs="+", default=list(RADII),
                    help="disc radii, px (15 30 60)")
    ap.add_argument("--wire", action="store_true",
                    help="draw a dark wire from B to C, in front of them")
    ap.add_argument("--white", action="store_true",
                    help="white discs, tracked as A=white@…, B=white@…, C=white@…")
    ap.add_argument("--nearer", type=float, default=1.0,
                    help="the discs grow to this many times their radius over the clip")
    args = ap.parse_args()
    colours = {m: WHITE for m in COLOURS} if args.white else COLOURS
    at = drawn(0.0)
    specs = (parse_markers([f"{m}=white@{at[m][0]:.0f},{at[m][1]:.0f}" for m in COLOURS])
             if args.white else DEFAULT_MARKERS)
    print(f"libraries: {versions_line()}")
    compile_kernels()
    folder = CACHE / "large_markers"
    folder.mkdir(parents=True, exist_ok=True)
    for name, encoder, layout, options, container in CODINGS:
        # Lossless RGB of a noisy scene decodes at a tenth of H.264's speed: a third as long.
        frames = args.frames if layout == "yuv420p" else max(10, args.frames // 3)
        for radius in args.radii:
            wired = ("_wire" if args.wire else "") + ("_white" if args.white else "") \
                + (f"_nearer{args.nearer:g}" if args.nearer != 1.0 else "")
            path = folder / f"r{radius}_{encoder}_{frames}{wired}.{container}"
            if not path.exists():
                write(path, radius, encoder, layout, options, frames, args.wire, colours,
                      args.nearer)
            track(open_frames(path), specs)  # first run: files and caches warm
            track_s, decode_s = [], []
            for _ in range(args.rounds):
                t0 = time.perf_counter()
                tab = track(open_frames(path), specs).tracks
                track_s.append(time.perf_counter() - t0)
                decode_s.append(decode_only(path)[1])
            grows = (f" → {radius_at(frames - 1, radius, frames, args.nearer):.1f} px"
                     if args.nearer != 1.0 else "")
            print(f"\n{name}, radius {radius} px{grows}: tracking {min(track_s):.2f} s, decoding "
                  f"{min(decode_s):.2f} s, ratio decode/track {min(decode_s) / min(track_s):.2f}")
            for m in COLOURS:
                ok = tab[f"{m}_ok"].to_numpy(bool)
                # By frame number: a Matroska file stores its times to the millisecond,
                # 0.26 px of B's path at 26 px a frame.
                truth = np.array([drawn(k / FPS)[m] for k in tab["frame"]])
                dx = tab[f"{m}_x_px"].to_numpy() - truth[:, 0]
                dy = tab[f"{m}_y_px"].to_numpy() - truth[:, 1]
                sigma = tab[f"{m}_sigma_px"].to_numpy()
                dx, dy, sigma = dx[ok], dy[ok], sigma[ok]
                if not ok.any():
                    print(f"  {m}: found in no frame")
                    continue
                within = 0.5 * (np.mean(np.abs(dx) <= sigma) + np.mean(np.abs(dy) <= sigma))
                print(f"  {m}: found {100 * ok.mean():3.0f} %, offset {dx.mean():+.3f} "
                      f"{dy.mean():+.3f}, RMS {math.sqrt(np.mean(dx**2 + dy**2)):.3f} px, "
                      f"±1σ holds {100 * within:3.0f} %, σ median {np.median(sigma):.3f} px")


if __name__ == "__main__":
    main()
