"""The SMA bed drawn by a second renderer, written apart from ``synthetic/``, tracked.

Why: every render the tracker had been measured on came from ``synthetic/``, whose
scenes were written by the same project as the tracker (links narrower than the
discs, the wire drawn under them). Issue #20 reported that on an independently
made render of the SMA bed (short crank, wire crossing near the pivot) the pivot
was off by 0.068 px RMS, against 0.026–0.034 on the project's own, and θ's ±1σ band
held the true angle in 36 % of frames (21 % with a 1/60 s exposure). This script is
such a renderer. Nothing in it comes from ``cranktrack``; only the tracking at the
end does.

How it draws (none of it shared with ``synthetic/render.py``):

- each picture is drawn with OpenCV's polygons and circles on a grid
  :data:`SUPERSAMPLE` times finer than the frame, then averaged down by area
  (``cv2.INTER_AREA``); edges are as sharp as the finer grid, and the lens blur is
  a Gaussian of :data:`LENS_BLUR_PX` applied on it;
- a bench board with a fixed, smooth light pattern and wood-like streaks, an
  aluminium crank bar (A to B, 10 mm wide with rounded ends), marker discs A
  (green), B (red), C (blue) printed 8 mm across, and the SMA wire (0.5 mm, dark
  grey) from B's middle to C's, drawn over them (so *in front of* marker A where it
  crosses it);
- the exposure averages :data:`EXPOSURE_SAMPLES` pictures over its open time,
  centred on the frame's time; sensor noise is Gaussian, 2.5 DN;
- H.264 4:2:0 at crf 20 through PyAV, as a phone or webcam writes.

The motion (truth): the crank angle θ (at A, between A→C and A→B) goes from θ0
toward θ1 while the wire is heated and back as it cools, a critically damped
response to the current's pulse (:class:`Heating`), with Table 2.3's frame
L1 = 305 mm and crank L2 = 24.1 mm. The cases (:data:`CASES`, ``--case N``): Table
2.3's 125 → 98°, which keeps the wire about 19 mm from A, and 176 → 160°, which
brings it across marker A for much of the run; each with and without a 1/60 s
exposure.

It prints, per case and seed, each marker's error against where it was drawn (RMS
px per axis, the largest, its σ and the fraction within ±1σ), and θ's and ω's RMS
error and ±1σ coverage against the truth, over the frames where they were measured.

``--no-wire`` draws the same bed without the wire, to tell its share of the error from
the bar's and the codec's. ``--scale K`` films it K times closer (:func:`film_closer`).
``--flicker F`` lights the bed by a lamp on the mains whose light swings by F either
way at 100 Hz. ``--nearer F`` brings the bed nearer the camera over the clip: it grows
about A to F times its size by the last frame (px/mm, markers, bar and wire), in a
frame F times larger; θ, an angle, is the same.

    .venv/bin/python bench/sma_bed_apart.py [--seeds 3] [--case N] [--keep DIR] [--no-wire]
        [--lens-blur PX] [--noise DN] [--crf N] [--flicker F] [--scale K] [--nearer F]
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
from numpy.typing import NDArray

# Only the tracking and its error type: the picture and the truth are drawn here.
from cranktrack.environment import versions_line
from cranktrack.errors import CranktrackError
from cranktrack.pipeline import track_run

#: Finer grid the picture is drawn on, per frame pixel.
SUPERSAMPLE = 4
#: The lens's blur, frame px (σ of a Gaussian).
LENS_BLUR_PX = 0.6
EXPOSURE_SAMPLES = 9
NOISE_DN = 2.5

L1_MM, L2_MM = 305.0, 24.1
MARKER_MM = 8.0
WIRE_MM = 0.5
CRANK_BAR_MM = 10.0
SIZE = (960, 540)
PX_PER_MM = BED_PX_PER_MM = 2.6
A_PX = (100.0, 300.0)

#: Printed marker colours (RGB), as an inkjet gives them: not pure primaries.
GREEN = (40, 165, 75)
RED = (205, 45, 45)
BLUE = (35, 80, 200)
WIRE = (70, 70, 75)
ALUMINIUM = (175, 178, 182)


@dataclass(frozen=True)
class Heating:
    """θ(t), deg: θ0, pulled toward θ1 while the current is on (``on_s`` to ``off_s``)
    and back after, as a critically damped second-order response with time constant
    ``tau_s`` (the wire's heating lag and the crank's own), so that ω is continuous
    and α finite: the pulse is the difference of two step responses
    S(s) = 1 − (1 + s/τ)·e^(−s/τ)."""

    theta0_deg: float = 125.0
    theta1_deg: float = 98.0
    on_s: float = 0.3
    off_s: float = 1.6
    tau_s: float = 0.3

    def theta(self, t: NDArray) -> tuple[NDArray, NDArray]:
        """θ (deg) and ω (rad/s) at times ``t`` (s)."""
        t = np.asarray(t, float)

        def step(s: NDArray) -> tuple[NDArray, NDArray]:
            u = np.clip(s, 0.0, None) / self.tau_s
            return 1.0 - (1.0 + u) * np.exp(-u), u * np.exp(-u) / self.tau_s

        (up, up_rate), (down, down_rate) = step(t - self.on_s), step(t - self.off_s)
        d = self.theta1_deg - self.theta0_deg
        return self.theta0_deg + d * (up - down), np.radians(d * (up_rate - down_rate))


def film_closer(k: float) -> None:
    """Film the bed ``k`` times closer: the frame, its px/mm and the pivot's place ``k``
    times larger (markers of 8 mm then ``k``·10.4 px in radius: 3.2 gives 33 px, as a
    phone close to the rig or a 4K camera does). Drawn on a 2× grid from ``k`` = 2, for
    memory. The drawing reads these as the script's constants, so they are set again
    here, once, before anything is drawn."""
    global SIZE, PX_PER_MM, A_PX, SUPERSAMPLE
    SIZE = (2 * round(SIZE[0] * k / 2), 2 * round(SIZE[1] * k / 2))
    PX_PER_MM, A_PX = PX_PER_MM * k, (A_PX[0] * k, A_PX[1] * k)
    if k >= 2:
        SUPERSAMPLE = 2


#: The bed grows to this many times its size over the clip (``--nearer``).
NEARER = 1.0


def px_per_mm_at(t: float, last_t: float) -> float:
    """The bed's px/mm at time ``t`` (s) of a clip whose last frame is at ``last_t``:
    :data:`PX_PER_MM` growing steadily to :data:`NEARER` times it."""
    return PX_PER_MM * (1.0 + (NEARER - 1.0) * t / max(last_t, 1e-9))


def come_nearer(f: float) -> None:
    """Bring the bed nearer over the clip, to ``f`` times its size by the last frame
    (:func:`px_per_mm_at`), in a frame ``f`` times larger to hold it. Set once, before
    anything is drawn, as :func:`film_closer` does."""
    global SIZE, NEARER
    SIZE = (2 * round(SIZE[0] * f / 2), 2 * round(SIZE[1] * f / 2))
    NEARER = f


def points_px(theta_deg: float, px_per_mm: float | None = None) -> dict[str, NDArray]:
    """A, B, C in frame px: C on +x of A, B above the line A–C (image y down), at
    ``px_per_mm`` (:data:`PX_PER_MM` by default)."""
    k = PX_PER_MM if px_per_mm is None else px_per_mm
    a = np.array(A_PX)
    th = math.radians(theta_deg)
    b = a + k * L2_MM * np.array([math.cos(th), -math.sin(th)])
    c = a + np.array([k * L1_MM, 0.0])
    return {"A": a, "B": b, "C": c}


def board(rng: np.random.Generator) -> NDArray[np.float32]:
    """The bench board on the fine grid, RGB float: a smooth light fall-off and faint
    streaks along x (wood), fixed for the clip."""
    w, h = SIZE[0] * SUPERSAMPLE, SIZE[1] * SUPERSAMPLE
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    light = 1.0 - 0.18 * ((xx / w - 0.45) ** 2 + (yy / h - 0.4) ** 2)
    streak = cv2.resize(rng.normal(0, 1, (h // 32, 8)).astype(np.float32), (w, h),
                        interpolation=cv2.INTER_CUBIC)
    base = np.array([196, 178, 150], np.float32)
    return (base[None, None, :] * (light + 0.02 * streak)[..., None]).astype(np.float32)


def _fine(p: NDArray) -> tuple[int, int]:
    # OpenCV's drawing takes integer points with a shift; on the fine grid the centre of
    # frame pixel (0, 0) is at (S−1)/2.
    s = SUPERSAMPLE
    return (round((p[0] * s + (s - 1) / 2) * 16), round((p[1] * s + (s - 1) / 2) * 16))


def draw(background: NDArray[np.float32], theta_deg: float, wire: bool = True,
         px_per_mm: float | None = None) -> NDArray[np.float32]:
    """One instant's picture on the fine grid (without the SMA wire if not ``wire``), the
    bed at ``px_per_mm`` (:data:`PX_PER_MM` by default)."""
    img = background.copy()
    p = points_px(theta_deg, px_per_mm)
    s = SUPERSAMPLE * (PX_PER_MM if px_per_mm is None else px_per_mm)
    bar = 0.5 * CRANK_BAR_MM * s
    ab = p["B"] - p["A"]
    n = np.array([-ab[1], ab[0]]) / np.hypot(*ab)
    fa = np.array(_fine(p["A"])) / 16.0
    fb = np.array(_fine(p["B"])) / 16.0
    corners = np.array([fa + bar * n, fb + bar * n, fb - bar * n, fa - bar * n])
    cv2.fillPoly(img, [np.round(corners * 16).astype(np.int32)], ALUMINIUM, cv2.LINE_8, 4)
    for q in (fa, fb):  # rounded ends
        cv2.circle(img, tuple(np.round(q * 16).astype(int)), round(bar * 16), ALUMINIUM,
                   -1, cv2.LINE_8, 4)
    radius = 0.5 * MARKER_MM * s
    for name, colour in (("A", GREEN), ("B", RED), ("C", BLUE)):
        cv2.circle(img, _fine(p[name]), round(radius * 16), colour, -1, cv2.LINE_8, 4)
    if wire:
        # The wire, tied at B, runs to C over the pivot's marker.
        cv2.line(img, _fine(p["B"]), _fine(p["C"]), WIRE, max(1, round(WIRE_MM * s)),
                 cv2.LINE_8, 4)
    return img


@dataclass(frozen=True)
class Camera:
    """What the camera does to the picture: its lens's blur (σ, frame px), its sensor's
    noise (σ, DN), its H.264 quality (crf), and the room's lamp: its light swings by
    ``flicker`` (a fraction) either way at twice the mains frequency, :data:`MAINS_HZ`
    (:func:`lamp`)."""

    lens_blur_px: float = LENS_BLUR_PX
    noise_dn: float = NOISE_DN
    crf: int = 20
    flicker: float = 0.0

    def tag(self) -> str:
        """A file-name suffix for a camera other than the default one."""
        return "".join(f"_{k}{v:g}" for k, v, d in (
            ("blur", self.lens_blur_px, LENS_BLUR_PX), ("noise", self.noise_dn, NOISE_DN),
            ("crf", self.crf, 20), ("flicker", self.flicker, 0.0)) if v != d)


#: The mains frequency, Hz: a lamp on it flickers at twice this.
MAINS_HZ = 50.0


def lamp(times: NDArray, flicker: float) -> float:
    """The lamp's light over an exposure sampled at ``times`` (s), relative to its mean:
    1 + ``flicker``·cos(2π·2·:data:`MAINS_HZ`·t), averaged. Filmed at 30 fps with a short
    exposure, a 100 Hz flicker is seen at 10 Hz: light 1 + f, 1 − f/2, 1 − f/2, …"""
    return float(np.mean(1.0 + flicker * np.cos(2.0 * np.pi * 2.0 * MAINS_HZ * times)))


def frame(background: NDArray[np.float32], heating: Heating, t: float, exposure_s: float,
          rng: np.random.Generator, wire: bool = True, camera: Camera = Camera(),
          px_per_mm: float | None = None) -> NDArray[np.uint8]:
    """The camera's picture at frame time ``t`` (s): the exposure's average, the lens's
    blur, down to frame pixels, sensor noise, 8 bits; the bed at ``px_per_mm``."""
    times = [t] if exposure_s <= 0 else t + exposure_s * (
        (np.arange(EXPOSURE_SAMPLES) + 0.5) / EXPOSURE_SAMPLES - 0.5)
    theta, _ = heating.theta(np.asarray(times))
    acc = sum(draw(background, th, wire, px_per_mm) for th in theta) / len(theta)
    acc = acc * lamp(np.asarray(times), camera.flicker)
    acc = cv2.GaussianBlur(acc, (0, 0), camera.lens_blur_px * SUPERSAMPLE)
    small = cv2.resize(acc, SIZE, interpolation=cv2.INTER_AREA)
    small = small + rng.normal(0, camera.noise_dn, small.shape)
    return np.clip(np.round(small), 0, 255).astype(np.uint8)


def render(path: Path, heating: Heating, seconds: float, fps: float, exposure_s: float,
           seed: int, wire: bool = True, camera: Camera = Camera()) -> None:
    """The clip as H.264 4:2:0 (``camera.crf``) at ``path``."""
    rng = np.random.default_rng(seed)
    background = board(np.random.default_rng(1000 + seed))
    with av.open(str(path), mode="w") as out:
        stream = out.add_stream("libx264", rate=Fraction(fps).limit_denominator(1001))
        stream.width, stream.height = SIZE
        stream.pix_fmt = "yuv420p"
        # mbtree=0: with macroblock-tree rate control libx264 coded the same frames
        # differently from run to run, and no seed made a render again.
        stream.options = {"crf": str(camera.crf), "preset": "fast",
                          "x264-params": "mbtree=0"}
        n = round(seconds * fps)
        for k in range(n):
            picture = av.VideoFrame.from_ndarray(
                frame(background, heating, k / fps, exposure_s, rng, wire, camera,
                      px_per_mm_at(k / fps, (n - 1) / fps)),
                format="rgb24")
            for packet in stream.encode(picture):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)


@dataclass(frozen=True)
class Case:
    name: str
    heating: Heating
    exposure_s: float


CASES = (
    Case("Table 2.3, 125→98°, wire clear of A", Heating(), 0.0),
    Case("Table 2.3, 125→98°, exposure 1/60 s", Heating(), 1 / 60),
    Case("176→160°, wire across A", Heating(176.0, 160.0), 0.0),
    Case("176→160°, wire across A, exposure 1/60 s", Heating(176.0, 160.0), 1 / 60),
)


def measure(case: Case, seed: int, folder: Path, seconds: float, fps: float,
            wire: bool = True, camera: Camera = Camera()) -> dict[str, float]:
    """Render, track with ``cranktrack`` (A–C = L1 as the known length), compare."""
    tag = ("" if wire else "_nowire") + camera.tag() + (
        f"_px{PX_PER_MM:g}" if PX_PER_MM != BED_PX_PER_MM else "") + (
        f"_nearer{NEARER:g}" if NEARER != 1.0 else "")
    video = folder / f"sma_apart_{seed}{tag}.mp4"
    if not video.exists():
        # A render kept by --keep is used again: the writer is deterministic
        # (tests/test_video.py), so the same case and seed give the same clip.
        render(video, case.heating, seconds, fps, case.exposure_s, seed, wire, camera)
    runs = folder / f"run_{seed}{tag}"
    shutil.rmtree(runs, ignore_errors=True)
    run = track_run(video, runs, ("A", "C", L1_MM))
    tracks, kin = run.tracks, run.kinematics
    t = tracks["t_s"].to_numpy(float)
    last_t = (round(seconds * fps) - 1) / fps
    drawn = [points_px(th, px_per_mm_at(ti, last_t))
             for th, ti in zip(case.heating.theta(t)[0], t, strict=True)]
    out: dict[str, float] = {"frames": len(t)}
    for m in "ABC":
        ok = tracks[f"{m}_ok"].to_numpy(bool)
        truth = np.array([d[m] for d in drawn])[ok]
        err = tracks.loc[ok, [f"{m}_x_px", f"{m}_y_px"]].to_numpy(float) - truth
        sig = tracks.loc[ok, f"{m}_sigma_px"].to_numpy(float)
        out |= {f"{m}_found": ok.mean(),
                f"{m}_rms_px": float(np.sqrt(np.mean(np.sum(err**2, axis=1) / 2))),
                f"{m}_worst_px": float(np.abs(err).max()),
                f"{m}_cov": float(np.mean(np.abs(err) <= sig[:, None])),
                f"{m}_sigma": float(np.median(sig))}
    theta_true, omega_true = case.heating.theta(kin["t_s"].to_numpy(float))
    th = kin["theta_deg"].to_numpy(float)
    th_s = kin["theta_deg_sigma"].to_numpy(float)
    om = kin["omega_rad_s"].to_numpy(float)
    om_s = kin["omega_rad_s_sigma"].to_numpy(float)
    have = np.isfinite(th) & np.isfinite(th_s)
    have_w = np.isfinite(om) & np.isfinite(om_s)
    d = th[have] - theta_true[have]
    dw = om[have_w] - omega_true[have_w]
    return out | {
        "theta_n": int(have.sum()),
        "theta_rms_deg": float(np.sqrt(np.mean(d**2))),
        "theta_bias_deg": float(np.mean(d)),
        "theta_cov": float(np.mean(np.abs(d) <= th_s[have])),
        "theta_sigma_deg": float(np.median(th_s[have])),
        "omega_rms": float(np.sqrt(np.mean(dw**2))),
        "omega_cov": float(np.mean(np.abs(dw) <= om_s[have_w])),
    }


def _each(rows: list[dict[str, float]], key: str, fmt: str) -> str:
    """One figure of every render, separated by slashes."""
    return " / ".join(fmt.format(r[key]) for r in rows)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="renders per case (sensor noise)")
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--fps", type=float, default=30.0)
    parser.add_argument("--case", type=int, action="append",
                        help="which of the cases (0-based; repeatable; all by default)")
    parser.add_argument("--keep", type=Path,
                        help="keep the renders and runs in this folder; renders found "
                             "there are used again")
    parser.add_argument("--no-wire", action="store_true",
                        help="draw no SMA wire: what is left is the bar's and the codec's")
    parser.add_argument("--lens-blur", type=float, default=LENS_BLUR_PX,
                        help=f"the lens's blur, σ in frame px (default {LENS_BLUR_PX}; "
                             "2 or more is a camera out of focus)")
    parser.add_argument("--noise", type=float, default=NOISE_DN,
                        help=f"the sensor's noise, σ in DN (default {NOISE_DN})")
    parser.add_argument("--crf", type=int, default=20,
                        help="H.264's quality: 18 is near lossless, 28 a phone's, 35 poor "
                             "(default 20)")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="film the bed this many times closer (frame, px/mm; 3.2 gives "
                             "markers of 33 px radius in 3072×1728)")
    parser.add_argument("--nearer", type=float, default=1.0,
                        help="the bed comes nearer over the clip, growing to this many "
                             "times its size by the last frame (in a frame as much larger)")
    parser.add_argument("--flicker", type=float, default=0.0,
                        help="the lamp's light swings by this fraction either way at "
                             f"{2 * MAINS_HZ:g} Hz (default 0: a steady light)")
    args = parser.parse_args(argv)
    print(f"libraries: {versions_line()}")
    if args.scale != 1.0:
        film_closer(args.scale)
    if args.nearer != 1.0:
        come_nearer(args.nearer)
    cases = [CASES[i] for i in args.case] if args.case else list(CASES)
    camera = Camera(args.lens_blur, args.noise, args.crf, args.flicker)
    print(f"SMA bed, second renderer: {SIZE[0]}×{SIZE[1]}, {args.fps:g} fps, {args.seconds:g} s, "
          f"{PX_PER_MM} px/mm, markers {MARKER_MM:g} mm ({MARKER_MM * PX_PER_MM / 2:.1f} px "
          f"radius), noise {camera.noise_dn:g} DN, H.264 crf {camera.crf}; {args.seeds} seeds "
          "per case"
          + ("; no wire drawn" if args.no_wire else "")
          + (f"; coming nearer, to {NEARER:g}× by the last frame" if NEARER != 1.0 else "")
          + (f"; lens blur {camera.lens_blur_px:g} px"
             if camera.lens_blur_px != LENS_BLUR_PX else "")
          + (f"; lamp flicker ±{camera.flicker:.0%} at {2 * MAINS_HZ:g} Hz"
             if camera.flicker else ""))
    for case in cases:
        rows = []
        for seed in range(args.seeds):
            folder = (args.keep / f"{CASES.index(case)}") if args.keep else None
            with tempfile.TemporaryDirectory() as tmp:
                where = folder or Path(tmp)
                where.mkdir(parents=True, exist_ok=True)
                try:
                    rows.append(measure(case, seed, where, args.seconds, args.fps,
                                        not args.no_wire, camera))
                except CranktrackError as e:
                    print(f"\n{case.name}, seed {seed}: cranktrack refused: {e}")
        if not rows:
            continue
        theta_pooled = float(np.mean([r["theta_cov"] for r in rows]))
        print(f"\n{case.name}:")
        for m in "ABC":
            print(f"  {m}: found {_each(rows, f'{m}_found', '{:.0%}')}, RMS error "
                  f"{_each(rows, f'{m}_rms_px', '{:.3f}')} px per axis (largest "
                  f"{_each(rows, f'{m}_worst_px', '{:.2f}')}; σ median "
                  f"{_each(rows, f'{m}_sigma', '{:.3f}')}), in ±1σ "
                  f"{_each(rows, f'{m}_cov', '{:.0%}')}")
        print(f"  θ over {_each(rows, 'theta_n', '{:.0f}')} frames: RMS "
              f"{_each(rows, 'theta_rms_deg', '{:.4f}')}° (mean "
              f"{_each(rows, 'theta_bias_deg', '{:+.4f}')}°, σ median "
              f"{_each(rows, 'theta_sigma_deg', '{:.4f}')}°), in ±1σ "
              f"{_each(rows, 'theta_cov', '{:.0%}')} (pooled {theta_pooled:.0%}; aim 60–75 %)")
        print(f"  ω: RMS {_each(rows, 'omega_rms', '{:.4f}')} rad/s, in ±1σ "
              f"{_each(rows, 'omega_cov', '{:.0%}')}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
