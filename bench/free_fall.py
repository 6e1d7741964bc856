"""A steel ball dropped past a tape measure, filmed at 1000 fps: g from a clip the
project did not make, followed by a marker with no colour of its own.

The clip is ``CaidaLibreTrim.mp4`` of SantiagoGiraldoM17/LaboratorioCaidaLibre (a
student's free-fall lab; not committed here): 209 grey frames of 384×800, stored to
play at 30 a second though taken at 1000 (the student's script divides frame numbers
by 1000). The ball is darker than its ground at its rim, a little brighter inside
and bright where it mirrors the lamps; no colour or tone finds it, so it is followed
by its picture (``--marker ball=template@161,53,35``, :mod:`cranktrack.tracker.template`).

Every figure it is checked against is made here, apart from the tracker:

- **the scale**, from the tape's own ticks: the period of its millimetre ticks down
  the column they share (a Fourier transform of that column's brightness), checked
  against the centimetre ticks' period in a column only they reach;
- **g**, from a parabola through the fall, against 9.80 m/s² (#20's aim: within 2 %);
- **the ball's outline**, a circle fitted to where each frame's brightness changes
  most along rays across its rim: a second centre that no highlight moves. Its rays
  are laid about our fix (the rim is sought within 8 px of the radius from it), so
  it shares that starting point with the tracker, not its answer: seeded from its own
  earlier outlines instead, it lost the ball within the fall;
- **the student's own way of tracking it**, OpenCV's MOSSE tracker
  (``bench/mosse_peer.py``, under a Python with opencv-contrib, ``--mosse-python``).

The tape and the ball need not be at one distance from the camera: a ball 2 % further
away than the tape gives a g 2 % low, and nothing in the clip tells the two apart.

    .venv/bin/python bench/real_footage.py --free-fall /path/to/LaboratorioCaidaLibre \
        --mosse-python /path/to/a/venv/with/opencv-contrib/bin/python
"""

from __future__ import annotations

import subprocess
from io import StringIO
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from numpy.typing import NDArray

CLIP = "CaidaLibreTrim.mp4"
#: Frames a second the clip was taken at (its file says 30).
FPS = 1000.0
#: Where the ball is in the first frame and its radius (px), read off the picture.
MARKER = "ball=template@161,53,35"
#: Columns (px) crossed by every millimetre tick of the tape's metric edge, and one
#: reached only by its centimetre ticks (read off the picture).
MM_COLUMNS = (221, 227)
CM_COLUMN = 234
#: The fall is fitted from this frame on: the ball is let go in frames 2-4.
FALLING_FROM = 8
#: m/s², #20's figure for g.
G = 9.80


def grey_frames(video: Path) -> list[NDArray[np.float32]]:
    """Every frame of ``video`` as grey levels (DN)."""
    capture = cv2.VideoCapture(str(video))
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            return frames
        frames.append(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY).astype(np.float32))


def tick_period(column: NDArray, shortest: float, longest: float) -> float:
    """The period (px) of the strongest repeat of ``column``'s brightness between
    ``shortest`` and ``longest`` px: the peak of its Fourier transform, padded 64-fold
    so the peak is read to a small fraction of a bin, after its slow changes (the
    tape's shading) are taken away."""
    column = np.asarray(column, np.float64)
    column = column - cv2.GaussianBlur(column[:, None], (1, 0), 6).ravel()
    n = len(column)
    spectrum = np.abs(np.fft.rfft((column - column.mean()) * np.hanning(n), 64 * n))
    freq = np.fft.rfftfreq(64 * n)
    band = (freq > 1.0 / longest) & (freq < 1.0 / shortest)
    return float(1.0 / freq[np.argmax(np.where(band, spectrum, 0.0))])


def tape_px_per_mm(frame: NDArray) -> tuple[float, float]:
    """The tape's scale (px per mm) from its millimetre ticks, and again from its
    centimetre ticks alone."""
    mm = tick_period(frame[:, MM_COLUMNS[0]:MM_COLUMNS[1]].mean(axis=1), 3.0, 5.0)
    cm = tick_period(frame[:, CM_COLUMN], 30.0, 45.0)
    return mm, cm / 10.0


def rim_circle(frame: NDArray, x: float, y: float, radius: float
               ) -> tuple[float, float, float]:
    """The circle (x, y, radius px) through the ball's outline near (``x``, ``y``): on
    each of 120 rays, where the brightness changes most within 8 px of ``radius``;
    a circle fitted to those points by least squares, points more than 3 robust
    σ off it left out, five times over."""
    smooth = cv2.GaussianBlur(frame, (0, 0), 1.0)
    angles = np.linspace(0.0, 2.0 * np.pi, 120, endpoint=False)
    radii = np.arange(radius - 8.0, radius + 8.01, 0.25)
    xs = (x + np.outer(np.cos(angles), radii)).astype(np.float32)
    ys = (y + np.outer(np.sin(angles), radii)).astype(np.float32)
    rays = cv2.remap(smooth, xs, ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    r = radii[np.argmax(np.abs(np.gradient(rays, axis=1)), axis=1)]
    px, py = x + r * np.cos(angles), y + r * np.sin(angles)
    keep = np.ones(len(angles), bool)
    for _ in range(5):
        a = np.c_[2.0 * px[keep], 2.0 * py[keep], np.ones(keep.sum())]
        (cx, cy, c), *_ = np.linalg.lstsq(a, px[keep]**2 + py[keep]**2, rcond=None)
        fitted = float(np.sqrt(c + cx**2 + cy**2))
        off = np.hypot(px - cx, py - cy) - fitted
        spread = 1.4826 * np.median(np.abs(off[keep]))
        keep = np.abs(off) < max(3.0 * spread, 0.5)
    return float(cx), float(cy), fitted


def mosse_track(video: Path, python: Path, x: float, y: float, radius: float
                ) -> pd.DataFrame | None:
    """The student's MOSSE track (``bench/mosse_peer.py`` under ``python``), or None,
    said, where it could not be made."""
    script = Path(__file__).resolve().parent / "mosse_peer.py"
    try:
        out = subprocess.run([str(python), str(script), str(video), str(x), str(y),
                              str(radius)], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as e:
        print(f"  the MOSSE track could not be made with {python} ({e}); skipped")
        return None
    return pd.read_csv(StringIO(out))


def parabola(t: NDArray, y: NDArray) -> tuple[float, NDArray, np.poly1d]:
    """The acceleration (px/s²) of a parabola through ``y`` (px) at ``t`` (s), what it
    leaves (px), and the parabola itself (px at any t)."""
    curve = np.poly1d(np.polyfit(t, y, 2))
    return 2.0 * float(curve.coeffs[0]), y - curve(t), curve
