"""The tracker on public real clips, against a peer's tracks and the physics in them.

The clips and projects are the example files of Tracker (Open Source Physics,
https://github.com/OpenSourcePhysics/tracker, ``examples/``): a ``.trz`` is a zip
holding the video and a ``.trk`` XML in which a Tracker user clicked the object in
each frame. They are not committed here (their licence is Tracker's); give the
path of a checkout, or of the git directory ``fetch`` leaves, and the bench
extracts them to ``bench/.cache/real_footage``:

    .venv/bin/python bench/real_footage.py /path/to/OpenSourcePhysics/tracker

Per clip it prints: found % over the frames the peer clicked; where ``cranktrack
inspect`` lists the object the peer clicked; RMS px against the peer's track after
removing the constant offset between a click and a centre; the physics residual (a
parabola for a ball in flight) and the figure it gives (g, with the peer's own tape
measure on the metre stick as the known length, and again with the stick's own
painted tenths), the same figure from the peer's clicks; ±1σ coverage of our σ against that
parabola; and the wall time of tracking against decoding alone (PyAV's own loop to
RGB arrays, :func:`common.decode_only`), each the median of three runs in turn. For an
animation that loops (jmoljana, a Jmol vibration), the physics is the loop: a
frame and the one a period later (the period taken from the peer's clicks)
must agree, which gives each track's own scatter and our σ's coverage. Without the path
it says so and exits 0.

``--pendulum`` adds a student's pendulum clip (the swing and the string's length),
``--capsule`` a second one (bartekpacia/pendulum: a capsule swinging on 0.62 m, and
one recording at four sizes, whose tracks must agree with each other, :func:`run_sizes`),
and
``--yupi`` (or ``--rover``) two of yupi's clips: the rover wheel (a green LED on an arm
turning about a red pivot: rest, then a circle, a greenness centroid made here;
:func:`run_rover`) and a render of balls in a box (the blue ball against where it was
drawn, at whole pixels; :func:`run_balls`), each with ``--yupi-python`` yupi's own colour
tracker as the peer:

    .venv/bin/python bench/real_footage.py --yupi /path/to/yupidevs/yupi_examples \
        --yupi-python /path/to/a/venv/with/yupi/bin/python
"""

from __future__ import annotations

import argparse
import itertools
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parent))
import free_fall
from common import CACHE, Scorecard, decode_only, sure_of_nothing
from pendulum import G, plane_swing, sphere_swing

from cranktrack.calibration.plane import add_plane_coordinates
from cranktrack.calibration.readout import readout_from_flight, tilted_plane_residual
from cranktrack.calibration.ruler import Ruler, ruler_calibration
from cranktrack.environment import versions_line
from cranktrack.errors import CranktrackError
from cranktrack.kinematics.motion import marker_motion
from cranktrack.loop.flight import fit_flight
from cranktrack.loop.rotation import fit_rotation
from cranktrack.loop.swing import SwingLoop, arc_radius, fit_swing
from cranktrack.pipeline import track_run
from cranktrack.tracker.markers import parse_markers
from cranktrack.tracker.survey import frame_and_later, survey
from cranktrack.tracker.track import TrackResult, track
from cranktrack.tracker.video import FrameSource, open_frames
from cranktrack.warmup import compile_kernels

HERE = CACHE / "real_footage"


@dataclass(frozen=True)
class Clip:
    """A Tracker project: the ``.trz`` in ``examples/``, the point mass the peer
    tracked, and the ``--marker`` a user would give for it (after ``inspect``)."""

    trz: str
    mass: str
    marker: str
    #: "parabola": free flight under gravity; "periodic": an animation that repeats
    #: itself exactly, so a frame and the one a period later must agree; "": none.
    physics: str
    #: Which ``.trk`` of the project, when it holds several (part of its name).
    trk: str = ""
    #: The falling mass in paper clips, for "drag" (terminal speed² ∝ mass).
    mass_clips: float = float("nan")
    #: Another file in ``examples/`` holding the same footage, tracked in place of the
    #: project's video; the peer's frame k is its frame ``first + step·k``.
    video: str = ""
    first: int = 0
    step: int = 1


def score_common(card: Scorecard, clip: str, result: TrackResult, name: str,
                 track_s: float, decode_s: float) -> None:
    """The aims every clip has: no ``ok`` row unsure of itself, and tracking at 0.9 of
    decoding's speed or more on a clip over 10 s."""
    unsure = sure_of_nothing(result, name)
    card.add(clip, f"ok rows with σ ≥ radius or not finite ({name})", str(unsure), "0",
             unsure == 0)
    t = result.tracks["t_s"].to_numpy(float)
    if len(t) and t[-1] - t[0] > 10.0:
        card.add(clip, "decode/track speed", f"{decode_s / track_s:.2f}", "≥ 0.9",
                 decode_s / track_s >= 0.9)


CLIPS = (
    Clip("BallToss.trz", "ball", "ball=white@131,208", "parabola"),
    # The same toss at the camera's 30 fps, every frame: the project's clip is every
    # other one of these (its frame k is frame 2k + 6 here, the same pixels to the
    # codec's noise), played at 66.0 ms a frame where the file's clock says 66.7.
    # Tracker ships it twice, as H.264 in .mp4 and in .mov.
    Clip("BallToss.trz", "ball", "ball=white@131,208", "parabola",
         video="BallTossOut.mp4", first=6, step=2),
    Clip("BallToss.trz", "ball", "ball=white@131,208", "parabola",
         video="BallTossOut.mov", first=6, step=2),
    # A Jmol rendering of a vibrating molecule (1920×1080): shaded spheres behind
    # bonds and other atoms of the same colour; the peer followed one cyan atom.
    # The vibration is an animation loop, so the physics is its repetition.
    Clip("jmoljana.trz", "mass A", "atom=cyan@504,354", "periodic"),
    # A diabolo run along its string in front of a chalkboard, 240 fps (1536×848): a
    # pale, partly transparent spool about 40 px across, not a marker, against a white
    # wall at the top of its path; the peer's "CM trajectory" holds its centre of mass
    # in all 410 frames, smooth to 0.17 px (not hand clicks). Our track is the centre
    # of its bright face, which turns as it spins. Not free flight (the peer's track
    # fits a parabola of g = 1.8 m/s² with 62 px RMS left), so there is no physics to
    # check it against, only the peer.
    Clip("Diabolo.trz", "masa A", "diabolo=white@457,500", "",
         "CM trajectory 2"),
    # A toy car run round a loop (240 fps, 1280×720 JPEG pictures): white and green,
    # streaked by its motion and half hidden by the loop's rails, behind a hand; no
    # part of it is a marker (`inspect` offers none on it). The peer clicked it in all
    # 53 frames. Tracked as a white blob from where it enters, to say what a user
    # gets.
    Clip("car.trz", "masa A", "car=white@737,540", ""),
    # Paper cupcake cups dropped side by side (Flashmedia 1997, 320×240 JPEG pictures
    # 99 ms apart): small white strips on a dark board, each carrying a number of
    # paper clips, falling against quadratic drag. Tracker's project holds the peer's
    # clicks on two of them: "cup 3" (2 clips) and "cup 7" (6 clips). The physics:
    # each falls as y = (v_t²/g)·ln cosh(g·t/v_t), and with the same shape and drag
    # v_t² is proportional to the mass, cup + clips (the frame says a cup is 0.9
    # clips), so v_t(cup 7)/v_t(cup 3) = √(6.9/2.9) = 1.54.
    Clip("CupsClips.zip", "cup 3", "cup3=white@204,35", "drag", mass_clips=2.9),
    Clip("CupsClips.zip", "cup 7", "cup7=white@252,36", "drag", mass_clips=6.9),
)


def _extract(repo: Path, name: str, folder: str = "examples") -> Path | None:
    """The file ``folder/name`` from a checkout or a bare git directory, copied into
    the cache."""
    out = HERE / name
    if out.exists():
        return out
    HERE.mkdir(parents=True, exist_ok=True)
    inside = f"{folder}/{name}" if folder else name
    if (repo / inside).exists():
        out.write_bytes((repo / inside).read_bytes())
        return out
    try:
        blob = subprocess.run(["git", "-C", str(repo), "show", f"HEAD:{inside}"],
                              capture_output=True, check=True).stdout
    except (subprocess.CalledProcessError, FileNotFoundError):
        return None
    out.write_bytes(blob)
    return out


def _extracted_or_said(repo: Path, name: str, folder: str) -> Path | None:
    """:func:`_extract`, saying so where the file is not in ``repo``."""
    video = _extract(repo, name, folder=folder)
    if video is None:
        print(f"\n{name}: not in {repo}; skipped")
    return video


def _props(obj: ET.Element) -> dict[str, ET.Element]:
    return {p.get("name"): p for p in obj.findall("property")}


def peer_project(trz: Path, mass: str, which: str = ""
                 ) -> tuple[Path, float | None, dict[int, tuple[float, float]], float]:
    """The project's video (extracted: a file, or the folder of its pictures), its frame
    rate when it is pictures (from Tracker's ``delta_t``, ms), the peer's clicks
    {frame: (x, y) px} on the point mass ``mass``, and the scale (px per metre) of its
    tape measure or coordinate system. ``which`` picks the ``.trk`` whose name holds
    it, when the project has several."""
    folder = trz.with_suffix("")
    with zipfile.ZipFile(trz) as z:
        z.extractall(folder)
        trk = next(n for n in z.namelist() if n.endswith(".trk") and which in n)
    root = ET.parse(folder / trk).getroot()
    path = next(p.text for p in root.iter("property")
                if p.get("name") == "path"
                and (p.text or "").lower().endswith((".mp4", ".mov", ".jpg", ".png")))
    video, fps = (folder / trk).parent / path, None
    if video.suffix.lower() in (".jpg", ".png"):
        delta = next(p.text for p in root.iter("property") if p.get("name") == "delta_t")
        video, fps = video.parent, 1000.0 / float(delta)
    clicks: dict[int, tuple[float, float]] = {}
    scale = float("nan")
    for obj in root.iter("object"):
        kind = obj.get("class", "")
        props = _props(obj)
        if kind.endswith("ImageCoordSystem$FrameData") and "xscale" in props:
            scale = float(props["xscale"].text)
        if kind.endswith("PointMass") and props.get("name") is not None \
                and props["name"].text == mass:
            for item in props["framedata"].findall("property"):
                frame = int(item.get("name").strip("[]"))
                data = _props(item.find("object"))
                clicks[frame] = (float(data["x"].text), float(data["y"].text))
    return video, fps, clicks, scale


def tape_ends(trz: Path) -> NDArray | None:
    """The ends (2, 2) px of the first tape measure in a project's ``.trk``, or None."""
    folder = trz.with_suffix("")
    for trk in folder.rglob("*.trk"):
        for obj in ET.parse(trk).getroot().iter("object"):
            if obj.get("class", "").endswith("TapeMeasure$FrameData"):
                p = _props(obj)
                return np.array([[float(p["x1"].text), float(p["y1"].text)],
                                 [float(p["x2"].text), float(p["y2"].text)]])
    return None


def tool_g(tracks: pd.DataFrame, name: str, ruler: Ruler, size: tuple[int, int],
           rows: NDArray[np.bool_]) -> tuple[float, float]:
    """g (m/s²) as a user of ``cranktrack track --ruler`` reads it off motion.csv: minus
    the median of marker ``name``'s ``ay`` over ``rows`` (in flight), and the median of
    its σ. The tool's own calibration and differentiator, against the parabolas fitted
    in this bench."""
    mm = add_plane_coordinates(tracks, ruler_calibration(ruler, size), (name,))
    motion, _ = marker_motion(mm, (name,))
    ay = motion[f"{name}_ay_mm_s2"].to_numpy(float)[rows]
    sig = motion[f"{name}_ay_mm_s2_sigma"].to_numpy(float)[rows]
    return -float(np.nanmedian(ay)) / 1e3, float(np.nanmedian(sig)) / 1e3


def flight_line(tracks: pd.DataFrame, name: str, ruler: Ruler, size: tuple[int, int],
                rows: NDArray[np.bool_]) -> str:
    """What ``cranktrack fit RUN --model flight`` makes of marker ``name``'s flight over
    ``rows`` with ``ruler``'s scale (:func:`.loop.flight.fit_flight`, a joint least
    squares apart from ``calibrate readout``'s search): the effect it takes, its
    look-alikes, the readout and g with it."""
    cal = ruler_calibration(ruler, size)
    mm = add_plane_coordinates(tracks, cal, (name,))[rows]
    loop = fit_flight(mm["t_s"].to_numpy(float),
                      mm[[f"{name}_x_mm", f"{name}_y_mm"]].to_numpy(float),
                      mm[f"{name}_y_px"].to_numpy(float), size[1],
                      float(np.nanmedian(mm[f"{name}_sigma_mm"])), cal.scale_sigma)
    shutter = loop.candidates["rolling shutter"]
    alike = f" (alike: {', '.join(loop.look_alikes)})" if loop.look_alikes else ""
    return (f"`fit --model flight`: takes {loop.accepted or 'the parabola alone'}{alike}; "
            f"ΔBIC rolling shutter {loop.delta_bic['rolling shutter']:.0f}, tilted plane "
            f"{loop.delta_bic['tilted plane']:.0f}, quadratic drag "
            f"{loop.delta_bic['quadratic drag']:.0f}; with the shutter a readout of "
            f"{shutter.values['readout_ms']:.2f} ms and g = {shutter.g_mm_s2 / 1e3:.3f} ± "
            f"{shutter.g_sigma_mm_s2 / 1e3:.3f} m/s², the parabola's "
            f"{loop.base.g_mm_s2 / 1e3:.3f} ± {loop.base.g_sigma_mm_s2 / 1e3:.3f}; with "
            f"what it takes, {loop.final.rms_mm:.3f} mm left (the parabola "
            f"{loop.base.rms_mm:.3f}) and g = {loop.final.g_mm_s2 / 1e3:.3f} ± "
            f"{loop.final.g_sigma_mm_s2 / 1e3:.3f} m/s² "
            f"({100 * (loop.final.g_mm_s2 / 9800 - 1):+.1f} %)"
            + (f"; then {', '.join(f'{k} {v:.0f}' for k, v in loop.later[0].delta_bic.items())}"
               if loop.later else ""))


def stick_divisions(video: Path, fps: float | None, ends: NDArray, per_m: int = 10
                    ) -> tuple[float, int, float]:
    """The scale (px per metre) of a metre stick read from its own divisions: the dark
    gaps between its painted tenths, along the line through ``ends`` (px, where the
    peer laid a tape on it) in the clip's median picture (a ball passing in front is
    gone from it). Returns px/m, the number of gaps, and the RMS (px) of the gaps
    about evenly spaced ones."""
    grey = np.median([cv2.cvtColor(f.rgb, cv2.COLOR_RGB2GRAY) for f in
                      open_frames(video, fps).frames()], axis=0).astype(np.float32)
    along = ends[1] - ends[0]
    length = float(np.hypot(*along))
    unit, across = along / length, np.array([-along[1], along[0]]) / length
    s = np.arange(-15.0, length + 15.0, 0.25)

    def band(w: NDArray) -> NDArray:
        pts = ends[0] + s[:, None, None] * unit + w[None, :, None] * across
        return cv2.remap(grey, pts[..., 0].astype(np.float32),
                         pts[..., 1].astype(np.float32), cv2.INTER_LINEAR)

    # The tape need not lie on the stick's middle (on BallToss it is 8 px beside it):
    # the profile is read along the brightest line parallel to it within 20 px.
    offsets = np.arange(-20.0, 20.5, 1.0)
    middle = offsets[int(np.argmax(np.median(band(offsets), axis=0)))]
    profile = band(middle + np.arange(-3.0, 3.5, 1.0)).mean(axis=1)
    # A gap is a dip of at least 20 DN below the paint on either side, within 3 px.
    gaps = []
    for i in range(12, len(profile) - 12):
        if profile[i] == profile[i - 12:i + 13].min() and \
                min(profile[i - 12:i].max(), profile[i + 1:i + 13].max()) - profile[i] > 20:
            a, b, c = profile[i - 1:i + 2]
            gaps.append(s[i] + 0.25 * 0.5 * (a - c) / (a - 2 * b + c))
    gaps = np.array(gaps)
    if len(gaps) < 3:
        return float("nan"), len(gaps), float("nan")
    k = np.arange(len(gaps))
    slope, icept = np.polyfit(k, gaps, 1)
    rms = float(np.sqrt(np.mean((gaps - (slope * k + icept)) ** 2)))
    return float(slope * per_m), len(gaps), rms


def parabola_g(t: np.ndarray, xy: np.ndarray, px_per_m: float
               ) -> tuple[float, np.ndarray]:
    """|acceleration| (m/s²) of quadratics fitted to x(t) and y(t), and the fit's
    residual (px, per frame and axis). The magnitude needs no axis direction."""
    X = np.vander(t - t.mean(), 3)
    coef = np.linalg.lstsq(X, xy, rcond=None)[0]
    return float(np.hypot(*(2 * coef[0])) / px_per_m), xy - X @ coef


def drag_fall(t: NDArray, y: NDArray) -> tuple[float, NDArray]:
    """Terminal speed (in ``y``'s units per s) of a fall from rest against quadratic
    drag, y = y0 + (v²/g)·ln cosh(g·(t − t0)/v) with g = :data:`G` (y in metres,
    down), fitted by least squares over y0, t0 and v; and the fit's residual."""
    from scipy.optimize import least_squares

    def model(p: NDArray) -> NDArray:
        y0, t0, v = p
        return y0 + v**2 / G * np.log(np.cosh(G * (t - t0) / v))

    slope = float(np.max(np.diff(y) / np.diff(t)))
    fit = least_squares(lambda p: model(p) - y, [y[0], t[0], max(slope, 0.1)])
    return float(fit.x[2]), y - model(fit.x)


def period_frames(xy: NDArray, shortest: int = 5) -> int:
    """The lag (frames) at which a track best repeats itself: the smallest RMS
    difference between each point and the one that lag later."""
    n = len(xy)
    lags = range(shortest, n // 2)
    rms = [np.sqrt(np.nanmean(np.sum((xy[lag:] - xy[:-lag]) ** 2, axis=1))) for lag in lags]
    return int(lags[int(np.nanargmin(rms))])


def repeat_scatter(xy: NDArray, lag: int) -> float:
    """Per-point RMS scatter (px, 2-D) of a track that repeats every ``lag`` frames:
    a difference of two independent points has twice a point's variance."""
    d = xy[lag:] - xy[:-lag]
    return float(np.sqrt(np.nanmean(np.sum(d**2, axis=1)) / 2.0))


def repeat_coverage(xy: NDArray, sigma: NDArray, lag: int) -> float:
    """Fraction of per-axis differences between points a period apart within ±1σ of
    their own σ, σ² = σ_i² + σ_(i+lag)² (68 % for an honest σ)."""
    d = xy[lag:] - xy[:-lag]
    s = np.sqrt(sigma[lag:] ** 2 + sigma[:-lag] ** 2)[:, None]
    keep = np.isfinite(d) & np.isfinite(s)
    return float(np.mean(np.abs(d[keep]) <= np.broadcast_to(s, d.shape)[keep]))


def _same_pixels(video: Path, other: Path, clip: Clip) -> str:
    """How alike the first frame of ``video`` and its frame in ``other`` are (DN, grey),
    against the frames either side there: the check that the frame map is right."""
    def grey(path: Path) -> list[NDArray]:
        return [f.rgb.mean(axis=2) for f in open_frames(path, None).frames()]

    a, b = grey(video), grey(other)
    k = clip.first + clip.step
    diffs = [float(np.mean(np.abs(a[1] - b[j]))) for j in (k - 1, k, k + 1)]
    return f"{diffs[1]:.2f} DN, against {diffs[0]:.2f} and {diffs[2]:.2f} a frame either side"


#: Tracking and decoding are each timed this many times, in turn, and the medians taken:
#: on this 2-core machine one timing of the pendulum's decoding ranged over 0.08-0.21 s
#: between runs, in some processes mostly under 0.13 s, in others over 0.14 s.
TIMINGS = 3


def decode_seconds(video: Path, fps: float | None) -> float:
    """Seconds to decode ``video`` to RGB arrays and nothing else: PyAV's own loop for a
    file (:func:`common.decode_only`), OpenCV's ``imread`` for a folder of images."""
    if not video.is_dir():
        return decode_only(video)[1]
    t0 = time.perf_counter()
    for f in open_frames(video, fps).frames():
        f.rgb  # noqa: B018 - reading the images is all decoding is here
    return time.perf_counter() - t0


def timed(specs: tuple, video: Path, fps: float | None) -> tuple[TrackResult, float, float]:
    """The tracking of ``specs`` through ``video``, and the seconds tracking took and
    decoding alone took (:func:`decode_seconds`): each the median of :data:`TIMINGS`
    runs, a decoding and a tracking in turn so that both meet the machine alike (every
    run gives the same tracks)."""
    decode_s, track_s, result = [], [], None
    for _ in range(TIMINGS):
        decode_s.append(decode_seconds(video, fps))
        t0 = time.perf_counter()
        result = track(open_frames(video, fps), specs)
        track_s.append(time.perf_counter() - t0)
    return result, float(np.median(track_s)), float(np.median(decode_s))


def timed_track(video: Path, fps: float | None, marker: str
                ) -> tuple[TrackResult, str, float, float]:
    """Track one ``--marker`` through ``video``: the tracking, the marker's name, and the
    seconds taken by tracking and by decoding alone (:func:`timed`)."""
    specs = parse_markers([marker])
    result, track_s, decode_s = timed(specs, video, fps)
    return result, specs[0].name, track_s, decode_s


def inspect_rank(video: Path, fps: float | None, frame: int, xy: tuple[float, float]
                 ) -> tuple[int | None, int]:
    """Where ``cranktrack inspect`` lists the object the peer clicked at ``xy`` in
    ``frame`` (1 = first; None: not listed), and how many candidates it lists in all."""
    first, later = frame_and_later(open_frames(video, fps).frames(),
                                   lambda f: f.index >= frame)
    if first is None or first.index != frame:
        return None, 0
    table = survey(first.rgb, most=1000, later=None if later is None else later.rgb)
    gap = np.hypot(table["x_px"] - xy[0], table["y_px"] - xy[1])
    near = np.flatnonzero(gap <= np.maximum(table["radius_px"], 6.0) + 3.0)
    return (int(near[0]) + 1 if len(near) else None), len(table)


@dataclass(frozen=True)
class Footage:
    """A clip's files: its project, the project's own video, the video tracked (the
    project's, or :attr:`Clip.video`) at ``fps`` (None: its own clock), the peer's
    clicks by frame of that video, and the peer's scale (px/m)."""

    trz: Path
    project_video: Path
    video: Path
    fps: float | None
    clicks: dict[int, tuple[float, float]]
    scale: float


def footage(repo: Path, clip: Clip) -> Footage | None:
    """The files of ``clip`` in ``repo`` (extracted to the cache), or None, said, where
    one is not there."""
    trz = _extract(repo, clip.trz)
    if trz is None:
        print(f"{clip.trz}: not in {repo}; skipped")
        return None
    video, fps, clicks, scale = peer_project(trz, clip.mass, clip.trk)
    if not clip.video:
        return Footage(trz, video, video, fps, clicks, scale)
    other = _extract(repo, clip.video)
    if other is None:
        print(f"{clip.video}: not in {repo}; skipped")
        return None
    return Footage(trz, video, other, None,
                   {clip.first + clip.step * k: xy for k, xy in clicks.items()}, scale)


def add_clip_paths(ap: argparse.ArgumentParser) -> None:
    """The checkouts the real-footage benches read, as options of ``ap``."""
    ap.add_argument("tracker", nargs="?", type=Path,
                    help="a checkout of OpenSourcePhysics/tracker, or its git directory")
    ap.add_argument("--pendulum", type=Path,
                    help="a checkout of juangomez177/Pendulum_Oscillatory_Motion, or its "
                         "git directory")
    ap.add_argument("--capsule", type=Path,
                    help="a checkout of bartekpacia/pendulum, or its git directory: a "
                         "capsule swinging on 0.62 m, and one recording at four sizes")
    ap.add_argument("--yupi", "--rover", dest="rover", type=Path,
                    help="a checkout of yupidevs/yupi_examples, or its git directory: its "
                         "rover wheel and its balls in a box")
    ap.add_argument("--yupi-python", type=Path,
                    help="a Python with yupi installed, to make yupi's own tracks of the "
                         "rover's LED and the blue ball (bench/yupi_peer.py)")
    ap.add_argument("--free-fall", type=Path,
                    help="a checkout of SantiagoGiraldoM17/LaboratorioCaidaLibre, or its git "
                         "directory: a steel ball falling past a tape measure (bench/free_fall.py)")
    ap.add_argument("--mosse-python", type=Path,
                    help="a Python with opencv-contrib installed, to make the student's own "
                         "MOSSE track of the falling ball (bench/mosse_peer.py)")


def run_clip(repo: Path, clip: Clip, card: Scorecard) -> dict[str, float]:
    """Track one clip, print its figures (and score them on ``card``), and return those a
    later line compares across clips (a drag fall's terminal speed, ours and the peer's,
    m/s)."""
    found = footage(repo, clip)
    if found is None:
        return {}
    trz, video, fps, clicks, scale = found.trz, found.video, found.fps, found.clicks, found.scale
    if clip.video:
        print(f"\n{clip.video}: the footage of {clip.trz} at its own clock; the peer's "
              f"frame k is frame {clip.first} + {clip.step}·k here "
              f"(mean |difference| {_same_pixels(found.project_video, video, clip)})")
    result, name, track_s, decode_s = timed_track(video, fps, clip.marker)
    tab = result.tracks
    label = f"{clip.video or clip.trz} ({clip.mass})"
    peer_frames = np.array(sorted(clicks))
    rows = tab.set_index("frame").loc[peer_frames]
    ok = rows[f"{name}_ok"].to_numpy(bool)
    ours = rows[[f"{name}_x_px", f"{name}_y_px"]].to_numpy(float)
    theirs = np.array([clicks[f] for f in peer_frames])
    print(f"{'' if clip.video else chr(10)}{clip.trz} ({video.name}, {len(tab)} frames; "
          "the peer clicked "
          f"{len(peer_frames)}): `--marker {clip.marker}`")
    print(f"  found in {ok.sum()} of the {len(peer_frames)} frames the peer clicked "
          f"({100 * ok.mean():.0f} %); statuses elsewhere: "
          f"{ {k: int(v) for k, v in rows.loc[~ok, f'{name}_status'].value_counts().items()} }")
    card.add(label, "found where the peer clicked", f"{100 * ok.mean():.0f} %", "≥ 95 %",
             ok.mean() >= 0.95)
    # What a new user sees first: where `inspect` lists the object, in the frame in the
    # middle of those the peer clicked (the peer's choice is the truth of which it is).
    middle = int(peer_frames[len(peer_frames) // 2])
    rank, listed = inspect_rank(video, fps, middle, clicks[middle])
    print(f"  `inspect` at frame {middle} lists the object the peer clicked "
          f"{'not at all' if rank is None else f'{rank}.'} of {listed} candidates "
          "(it prints the first 12)")
    if ok.sum() < max(4, 0.25 * len(peer_frames)):
        print("  too few frames found to compare with the peer or the physics")
        print(f"  time (median of {TIMINGS} runs each): tracking {track_s:.2f} s, PyAV "
              f"decoding to RGB alone {decode_s:.2f} s "
              f"(ratio decode/track {decode_s / track_s:.2f})")
        score_common(card, label, result, name, track_s, decode_s)
        return {}
    diff = ours[ok] - theirs[ok]
    offset = diff.mean(axis=0)
    rms = float(np.sqrt(np.mean(np.sum((diff - offset) ** 2, axis=1))))
    print(f"  against the peer's clicks: offset ({offset[0]:+.2f}, {offset[1]:+.2f}) px, "
          f"RMS after removing it {rms:.2f} px")
    card.add(label, "RMS against the peer", f"{rms:.2f} px", "≤ 1 px", rms <= 1.0)
    t = rows["t_s"].to_numpy(float)
    if clip.physics == "parabola":
        # Every frame found in flight, between the peer's first and last click (on a
        # clip at the camera's own rate, the frames between those the peer clicked).
        between = tab[(tab["frame"] >= peer_frames[0]) & (tab["frame"] <= peer_frames[-1])]
        span = between[between[f"{name}_ok"].astype(bool)]
        flight = span[[f"{name}_x_px", f"{name}_y_px"]].to_numpy(float)
        t_flight = span["t_s"].to_numpy(float)
        g_ours, resid = parabola_g(t_flight, flight, scale)
        g_peer, resid_peer = parabola_g(t, theirs, scale)
        sigma = span[f"{name}_sigma_px"].to_numpy(float)
        print(f"  in flight: found in {len(span)} of the {len(between)} frames from the peer's "
              "first click to its last")
        inside = np.abs(resid) <= sigma[:, None]
        print(f"  parabola: g = {g_ours:.3f} m/s² from our track "
              f"({100 * (g_ours / 9.80 - 1):+.1f} % against 9.80), {g_peer:.3f} from the "
              "peer's clicks; residual RMS "
              f"{np.sqrt(np.mean(resid**2)):.2f} px ours, {np.sqrt(np.mean(resid_peer**2)):.2f} "
              f"px the peer's (scale {scale:.1f} px/m from the peer's metre stick)")
        ends = tape_ends(trz)
        if ends is not None:
            frame_size = open_frames(video, fps)
            ruler = Ruler(tuple(ends[0]), tuple(ends[1]),
                          1e3 * float(np.hypot(*(ends[1] - ends[0]))) / scale)
            in_flight = (tab["frame"].between(peer_frames[0], peer_frames[-1])
                         & tab[f"{name}_ok"].astype(bool)).to_numpy()
            g_tool, g_tool_sigma = tool_g(tab, name, ruler, (frame_size.width,
                                                            frame_size.height), in_flight)
            print(f"  `--ruler {ruler.text()}` (the peer's tape): motion.csv's ay, median "
                  f"over the flight, gives g = {g_tool:.3f} m/s² (its σ a frame "
                  f"{g_tool_sigma:.2f}), against the parabola's {g_ours:.3f} here")
            print("  " + flight_line(tab, name, ruler, (frame_size.width, frame_size.height),
                                     in_flight))
            # The scale again, from the stick's own tenths rather than the peer's tape.
            per_m, n_gaps, gap_rms = stick_divisions(video, fps, ends)
            print(f"  the stick's own divisions ({n_gaps} dark gaps between its tenths, "
                  f"{gap_rms:.2f} px RMS from even spacing) give {per_m:.1f} px/m against "
                  f"the peer's tape {scale:.1f}: g = {g_ours * scale / per_m:.3f} m/s² "
                  f"({100 * (g_ours * scale / per_m / 9.80 - 1):+.1f} %)")
        print(f"  ±1σ coverage of our σ (median {np.median(sigma):.3f} px) against the "
              f"parabola: {100 * inside.mean():.0f} % of coordinates (aim 50–90 %)")
        off_g = g_ours / 9.80 - 1
        card.add(label, "g, the peer's tape on the metre stick", f"{100 * off_g:+.1f} %",
                 "within 2 %", abs(off_g) <= 0.02)
        card.add(label, "±1σ coverage against the parabola", f"{100 * inside.mean():.0f} %",
                 "50–90 %", 0.5 <= inside.mean() <= 0.9)
        # A camera that reads its rows one after another (a rolling shutter) takes
        # the ball lower in the frame later than the frame's time says: one more
        # parameter, fitted to our track and, apart, to the peer's clicks.
        height = open_frames(video, fps).height
        rolled = readout_from_flight(t_flight, flight, height)
        rolled_peer = readout_from_flight(t, theirs, height)
        acc, dof = rolled.acceleration_px_s2, np.sqrt(flight.size / (flight.size - 7))
        g_stick = f", {acc / per_m:.3f} with the stick's" if ends is not None else ""
        print(f"  with a rolling shutter (`cranktrack calibrate readout`: row y taken ρ·y "
              f"after the top row): a readout of {rolled.readout_s * 1e3:.2f} ± "
              f"{rolled.readout_sigma_s * 1e3:.2f} ms over the {height} rows, and "
              f"{rolled_peer.readout_s * 1e3:.2f} ± {rolled_peer.readout_sigma_s * 1e3:.2f} "
              f"from the peer's clicks alone; g = {acc / scale:.3f} m/s² "
              f"({100 * (acc / scale / 9.80 - 1):+.1f} %) with the peer's scale{g_stick}, "
              f"{rolled_peer.acceleration_px_s2 / scale:.3f} from the peer's clicks; residual "
              f"RMS {rolled.residual_px:.2f} px ours, {rolled_peer.residual_px:.2f} px the "
              f"peer's; ±1σ coverage "
              f"{100 * np.mean(dof * np.abs(rolled.residual) <= sigma[:, None]):.0f} %")
        card.add(label, "g, with the rolling shutter's readout",
                 f"{100 * (acc / scale / 9.80 - 1):+.1f} %", "within 2 %",
                 abs(acc / scale / 9.80 - 1) <= 0.02)
        # One toss cannot tell a readout from a flight plane turned to the camera: both
        # bend the image parabola. Fitted together, the readout says which took the bend.
        print(f"  a flight plane turned to the camera, all rows at once, leaves "
              f"{rolled.residual_tilted_px:.3f} px ours, {rolled_peer.residual_tilted_px:.3f} "
              f"px the peer's, against the readout's {rolled.residual_px:.3f} / "
              f"{rolled_peer.residual_px:.3f}: "
              + ("the plane's tilt explains the bend at least as well, so the readout is "
                 "not told apart" if rolled.tilt_explains_it
                 else "the readout explains the bend better"))
        # A residual that is smooth from frame to frame is the parabola's own error
        # (perspective, drag), not tracking noise; the lag-1 correlation says which.
        r1 = [float(np.corrcoef(resid[:-1, i], resid[1:, i])[0, 1]) for i in range(2)]
        print(f"  parabola residual lag-1 correlation x {r1[0]:+.2f}, y {r1[1]:+.2f} "
              "(near 0 for noise; near +1 when the residual is the model's, not the track's)")
        # The same flight in a plane that need not face the camera: what is left is
        # closer to the track's own error (still with drag and spin in it).
        tilted = tilted_plane_residual(t_flight, flight)
        dof = np.sqrt(tilted.size / (tilted.size - 8))  # 8 parameters fitted
        print(f"  against a flight in a tilted plane (perspective parabola): residual RMS "
              f"{np.sqrt(np.mean(tilted**2)):.3f} px ours, "
              f"{np.sqrt(np.mean(tilted_plane_residual(t, theirs)**2)):.3f} px the peer's; "
              f"±1σ coverage {100 * np.mean(dof * np.abs(tilted) <= sigma[:, None]):.0f} %")
        # Where both tracks leave the same residual, it is in the scene (the flight is
        # not quite that model), not in either track: the peer clicked by hand.
        if ok.sum() >= 10:
            both = [tilted_plane_residual(t[ok], xy) for xy in (ours[ok], theirs[ok])]
            shared = [float(np.corrcoef(both[0][:, i], both[1][:, i])[0, 1]) for i in range(2)]
            print(f"  on the {ok.sum()} frames both tracked, the two residuals against that "
                  f"model correlate x {shared[0]:+.2f}, y {shared[1]:+.2f} (what they share "
                  "is the scene's, not a track's)")
    figures: dict[str, float] = {}
    if not clip.physics and ok.sum() >= 20:
        # With no physics, each track's own frame-to-frame scatter (third differences:
        # 20σ² for white noise) says whether what lies between them is noise.
        def third(xy: NDArray) -> float:
            return float(np.sqrt(np.nanmean(np.diff(xy, n=3, axis=0) ** 2) / 20.0))

        mine = np.where(ok[:, None], ours, np.nan)
        print(f"  no physics to check against; frame-to-frame scatter (third differences) "
              f"{third(mine):.2f} px ours, {third(theirs):.2f} px the peer's, "
              f"{third(mine - theirs):.2f} px of their difference: the {rms:.2f} px between "
              "the tracks is which point of the object each follows, not noise")
    if clip.physics == "drag":
        # Down the image in metres (the peer's scale), from rest on the bar.
        v_ours, resid = drag_fall(t[ok], ours[ok, 1] / scale)
        v_peer, resid_peer = drag_fall(t, theirs[:, 1] / scale)
        sigma = rows[f"{name}_sigma_px"].to_numpy(float)[ok]
        inside = np.abs(resid * scale) <= sigma
        figures = {"v_ours": v_ours, "v_peer": v_peer}
        print(f"  quadratic drag: terminal speed {v_ours:.3f} m/s from our track, "
              f"{v_peer:.3f} from the peer's clicks; residual RMS "
              f"{np.sqrt(np.mean(resid**2)) * scale:.2f} px ours, "
              f"{np.sqrt(np.mean(resid_peer**2)) * scale:.2f} px the peer's "
              f"(scale {scale:.1f} px/m from the peer's coordinate system)")
        print(f"  ±1σ coverage of our σ (median {np.median(sigma):.3f} px) against the "
              f"drag fall (y): {100 * inside.mean():.0f} % (aim 50–90 %); residual lag-1 "
              f"correlation {float(np.corrcoef(resid[:-1], resid[1:])[0, 1]):+.2f}")
        card.add(label, "±1σ coverage against the drag fall", f"{100 * inside.mean():.0f} %",
                 "50–90 %", 0.5 <= inside.mean() <= 0.9)
    if clip.physics == "periodic":
        # The period from the peer's clicks, so that our track is not judged by itself.
        theirs_all = np.array([clicks.get(f, (np.nan, np.nan)) for f in tab["frame"]])
        ours_all = tab[[f"{name}_x_px", f"{name}_y_px"]].to_numpy(float, copy=True)
        ok_all = tab[f"{name}_ok"].to_numpy(bool)
        ours_all[~ok_all] = np.nan
        lag = period_frames(theirs_all)
        sig_all = np.where(ok_all, tab[f"{name}_sigma_px"].to_numpy(float), np.nan)
        s_ours, s_peer = repeat_scatter(ours_all, lag), repeat_scatter(theirs_all, lag)
        print(f"  repeats every {lag} frames (from the peer's clicks): a point's scatter "
              f"{s_ours:.2f} px ours, {s_peer:.2f} px the peer's; together they predict "
              f"{np.hypot(s_ours, s_peer):.2f} px RMS between the two tracks")
        covered = repeat_coverage(ours_all, sig_all, lag)
        print(f"  ±1σ coverage of our σ (median {np.nanmedian(sig_all):.3f} px) against the "
              f"repetition: {100 * covered:.0f} % of coordinates (aim 50–90 %)")
        card.add(label, "±1σ coverage against the repetition", f"{100 * covered:.0f} %",
                 "50–90 %", 0.5 <= covered <= 0.9)
    print(f"  time (median of {TIMINGS} runs each): tracking {track_s:.2f} s, PyAV decoding "
          f"to RGB alone {decode_s:.2f} s "
          f"(ratio decode/track {decode_s / track_s:.2f}; aim ≥ 0.9 on clips over 10 s)")
    score_common(card, label, result, name, track_s, decode_s)
    return figures


def compare_drag(falls: dict[Clip, dict[str, float]]) -> None:
    """Terminal speeds against each other: v_t² ∝ mass for cups of one shape."""
    done = [(c, f) for c, f in falls.items() if f]
    for (a, fa), (b, fb) in itertools.pairwise(done):
        want = np.sqrt(b.mass_clips / a.mass_clips)
        for who in ("ours", "peer"):
            got = fb[f"v_{who}"] / fa[f"v_{who}"]
            source = "our track" if who == "ours" else "the peer's clicks"
            print(f"  terminal speed {b.mass} / {a.mass} from {source}: {got:.3f} against "
                  f"√({b.mass_clips}/{a.mass_clips}) = {want:.3f} "
                  f"({100 * (got / want - 1):+.1f} %)")


@dataclass(frozen=True)
class Swing:
    """A real pendulum clip: the file in its repository, the ``--marker`` that follows
    the bob, the string's length its author gives (m, pivot to the bob's centre), and
    whether the bob on a sphere (:func:`pendulum.sphere_swing`) is fitted and scored,
    with a second centre made here (:func:`colour_centroids`) from the bob's channel
    (0 red, 1 green, 2 blue) within ``half`` px of our fix."""

    name: str
    marker: str
    length_m: float
    about: str
    #: On the capsule's 1844 fixes (stop 70) the sphere took 254 s and left 2.10 px,
    #: against the tool's sinusoid's 1.27; its blueness centroid is its lower half's, which turns
    #: with it.
    sphere: bool = True
    channel: int = 0
    half: int = 35


#: A red glass bauble on a string before a white wall, filmed with a phone on a stand
#: (640×352 H.264, 29.75 fps, 305 frames over 10.3 s), from the public repository
#: juangomez177/Pendulum_Oscillatory_Motion (a digital image processing course at the
#: University of Antioquia). Its report gives the string as 1.7 m; nobody's per-frame
#: track is published, so the peer is that length and the physics is the swing.
PENDULUM = Swing("pendulum.mp4", "bob=red", 1.7, "a red bauble on 1.7 m")
#: A toy capsule (blue below, clear above, about 4 cm across) on a string of 0.62 m
#: before a beige wall (550×310 H.264, 60 fps, 30.7 s; the phone's trim hides 3.5 s
#: before it), from the public repository bartekpacia/pendulum, whose README gives the
#: length for its clips and whose own tool times the swing by frame differences. It
#: swings 82 px either way on an arc of 774 px (650 px before stop 71 held the rim's
#: circle at its learned radius), about 6°, as the README asks (under 10°);
#: its rate rises by 0.3 % over the clip as the swing narrows by 15 %, which a free
#: wide-swing β took for a swing on a 153 px string (:data:`.loop.swing.LENGTH_BAND`).
CAPSULE = Swing("film2_vga.mp4", "bob=210@345,117", 0.62, "a blue capsule on 0.62 m",
                sphere=False)


def colour_centroids(video: Path, frames: NDArray, near: NDArray, channel: int,
                     floor: float, half: int) -> NDArray:
    """In each of ``frames`` (indices), the centroid (px) of how much more ``channel``
    (0 red, 1 green, 2 blue) a pixel has than the larger of the other two, less
    ``floor`` (DN, clipped at 0), within ``half`` px of ``near`` (n, 2) px: a coloured
    object's centre by a method that shares nothing with the tracker's fits."""
    where = dict(zip(frames.tolist(), near, strict=True))
    others = [c for c in range(3) if c != channel]
    out = []
    for frame in open_frames(video, None).frames():
        if frame.index not in where:
            continue
        x, y = where[frame.index]
        rgb = frame.rgb.astype(float)
        i0, j0 = max(round(y) - half, 0), max(round(x) - half, 0)
        patch = rgb[i0:round(y) + half + 1, j0:round(x) + half + 1]
        w = np.clip(patch[..., channel] - patch[..., others].max(axis=2) - floor, 0.0, None)
        ii, jj = np.mgrid[0:w.shape[0], 0:w.shape[1]]
        out.append(((w * (jj + j0)).sum() / w.sum(), (w * (ii + i0)).sum() / w.sum()))
    return np.array(out)


def _tracked(repo: Path, name: str, folder: str, marker: str
             ) -> tuple[Path, TrackResult, str, float, float, NDArray] | None:
    """The clip ``folder/name`` of ``repo`` tracked with one ``--marker`` (None, said,
    where it is not there): the video, :func:`timed_track`'s figures, and in which
    frames the marker was found."""
    video = _extracted_or_said(repo, name, folder)
    if video is None:
        return None
    result, label, track_s, decode_s = timed_track(video, None, marker)
    return (video, result, label, track_s, decode_s,
            result.tracks[f"{label}_ok"].to_numpy(bool))


def tool_swing(t: NDArray, xy: NDArray, sigma: NDArray, length_m: float) -> SwingLoop:
    """The tool's own pendulum loop (`fit --model pendulum`) on a track (px): a damped
    sinusoid along the track's longest direction, written apart from this bench, and
    its effects in turn; its figures printed, g with the author's ``length_m``."""
    # The swing's angle as the tool reads it without a scale (width over the arc's
    # radius), the arc the tool's own circle through the path, which also bounds a wide
    # swing's slowing there.
    arc = arc_radius(xy)
    along = np.linalg.svd(xy - xy.mean(axis=0), full_matrices=False)[2][0]
    tool = fit_swing(t, (xy - xy.mean(axis=0)) @ along, float(np.median(sigma)), arc)
    g_small, _ = replace(tool.base, envelope=np.empty(0)).g(1e3 * length_m)
    if arc is None:
        print("  the tool finds no arc through the bob's path: its swing is taken for a "
              "small one")
        arc = np.inf  # every envelope then 0 mm: a small swing's g
    g_tool, g_tool_sigma = replace(tool.base, envelope=tool.base.envelope * 1e3 * length_m
                                   / arc).g(1e3 * length_m)
    final = tool.final
    g_final, g_final_sigma = replace(final, envelope=final.envelope * 1e3 * length_m
                                     / arc).g(1e3 * length_m)
    print(f"  `fit --model pendulum --length-mm {1e3 * length_m:g}`: a damped sinusoid along "
          f"the swing, period {tool.base.period_s:.4f} ± {tool.base.period_sigma_s:.4f} s, "
          f"g = {g_tool / 1e3:.3f} ± {g_tool_sigma / 1e3:.3f} m/s² with the swing's angle "
          f"over an arc of {arc:.0f} px ({g_small / 1e3:.3f} as a small swing), residual "
          f"{tool.base.rms:.2f} px; takes {tool.accepted or 'no effect'} "
          f"({tool.independent:.0f} independent samples of {tool.samples}): residual "
          f"{final.rms:.2f} px ({tool.unexplained:.1f}× our σ), period "
          f"{final.period_s:.4f} ± {final.period_sigma_s:.4f} s, g = {g_final / 1e3:.3f} ± "
          f"{g_final_sigma / 1e3:.3f} m/s² ({100 * (g_final / 1e3 / G - 1):+.1f} % against "
          f"{G})")
    return tool


def sphere_figures(name: str, t: NDArray, xy: NDArray, sigma: NDArray, other: NDArray,
                   colour: str, source: FrameSource, length_m: float, card: Scorecard
                   ) -> None:
    """The bob on a sphere seen by a pinhole (:func:`pendulum.sphere_swing`), fitted to
    our track and to the second centre ``other`` (px); its length against the author's,
    and our σ's coverage against it (scored on ``card``)."""
    period_guess = 2 * np.pi * np.sqrt(length_m / G)
    swing = sphere_swing(t, xy, (source.width, source.height), length_m, period_guess)
    r = swing.residual
    dof = np.sqrt(r.size / (r.size - swing.parameters))
    print(f"  a bob on a sphere seen by a pinhole ({swing.parameters} parameters) leaves "
          f"{np.sqrt(np.mean(r**2)):.2f} px")
    print(f"  its period {swing.period_s:.4f} s gives a string of {swing.length_m:.3f} m "
          f"(g = {G}) against the author's {length_m} m "
          f"({100 * (swing.length_m / length_m - 1):+.1f} %); with their length, g = "
          f"{G * length_m / swing.length_m:.3f} m/s²")
    # Where the second centre's residual against the same swing matches ours, what is
    # left is in the swing, not in either centre.
    r2 = sphere_swing(t, other, (source.width, source.height), length_m, period_guess).residual
    shared = [float(np.corrcoef(r[:, i], r2[:, i])[0, 1]) for i in range(2)]
    print(f"  a second centre (the centroid of the bob's {colour}, made in this bench) leaves "
          f"{np.sqrt(np.mean(r2**2)):.2f} px against its own fit of that swing; it lies "
          f"{np.sqrt(np.mean(np.sum((other - xy - (other - xy).mean(axis=0))**2, axis=1))):.2f}"
          f" px RMS from ours, yet the two residuals correlate x {shared[0]:+.2f}, "
          f"y {shared[1]:+.2f}: what is left is the swing's")
    r1 = [float(np.corrcoef(r[:-1, i], r[1:, i])[0, 1]) for i in range(2)]
    covered = float(np.mean(dof * np.abs(r) <= sigma[:, None]))
    card.add(name, "±1σ coverage against the swing", f"{100 * covered:.0f} %", "50–90 %",
             0.5 <= covered <= 0.9)
    print(f"  ±1σ coverage of our σ (median {np.median(sigma):.3f} px) against that swing: "
          f"{100 * covered:.0f} % (aim 50–90 %); residual "
          f"lag-1 correlation x {r1[0]:+.2f}, y {r1[1]:+.2f} (near +1: the swing model's "
          "error, not the track's)")


def loop_coverage(sigma: NDArray, tool: SwingLoop) -> None:
    """Where no sphere is fitted: our σ's coverage against the tool's loop's own fit
    (printed, not scored: that fit is the tool's, not a truth written apart)."""
    r = tool.final.residual
    dof = np.sqrt(r.size / (r.size - tool.final.parameters))
    covered = float(np.mean(dof * np.abs(r) <= sigma))
    r1 = float(np.corrcoef(r[:-1], r[1:])[0, 1])
    print(f"  ±1σ coverage of our σ (median {np.median(sigma):.3f} px) against the loop's "
          f"own fit along the swing: {100 * covered:.0f} % (not scored: not a truth written "
          f"apart); residual lag-1 correlation {r1:+.2f}")


def run_pendulum(repo: Path, card: Scorecard, swing_clip: Swing = PENDULUM) -> None:
    """Track the bob of ``swing_clip``, fit the swing of :mod:`pendulum`, print its
    figures (and score them on ``card``)."""
    name, marker, length_m = swing_clip.name, swing_clip.marker, swing_clip.length_m
    found = _tracked(repo, name, "", marker)
    if found is None:
        return
    video, result, bob, track_s, decode_s, ok = found
    tab = result.tracks
    print(f"\n{name} (a pendulum: {swing_clip.about}; {len(tab)} frames, "
          f"{tab['t_s'].iloc[-1]:.1f} s): `--marker {marker}`")
    print(f"  found in {ok.sum()} of {len(tab)} frames ({100 * ok.mean():.0f} %; the bob is in "
          "view in every frame)")
    card.add(name, "found (the bob is always in view)", f"{100 * ok.mean():.0f} %", "≥ 95 %",
             ok.mean() >= 0.95)
    if ok[0]:
        at0 = tab[[f"{bob}_x_px", f"{bob}_y_px"]].to_numpy(float)[0]
        rank, listed = inspect_rank(video, None, 0, (float(at0[0]), float(at0[1])))
        print(f"  `inspect` at frame 0 lists the bob "
              f"{'not at all' if rank is None else f'{rank}.'} of {listed} candidates")
    t = tab["t_s"].to_numpy(float)[ok]
    xy = tab[[f"{bob}_x_px", f"{bob}_y_px"]].to_numpy(float)[ok]
    sigma = tab[f"{bob}_sigma_px"].to_numpy(float)[ok]
    period_guess = 2 * np.pi * np.sqrt(length_m / G)
    _, flat = plane_swing(t, xy, period_guess)
    print(f"  a plane swing seen square-on leaves {np.sqrt(np.mean(flat**2)):.2f} px RMS")
    tool = tool_swing(t, xy, sigma, length_m)
    if swing_clip.sphere:
        other = colour_centroids(video, tab["frame"].to_numpy()[ok], xy, swing_clip.channel,
                                 30.0, swing_clip.half)
        colour = ("redness", "greenness", "blueness")[swing_clip.channel]
        sphere_figures(name, t, xy, sigma, other, colour, open_frames(video, None), length_m,
                       card)
    else:
        loop_coverage(sigma, tool)
    print(f"  time (median of {TIMINGS} runs each): tracking {track_s:.2f} s, PyAV decoding "
          f"to RGB alone {decode_s:.2f} s "
          f"(ratio decode/track {decode_s / track_s:.2f}; aim ≥ 0.9 on clips over 10 s)")
    score_common(card, name, result, bob, track_s, decode_s)


#: A shorter swing of the same capsule (bartekpacia/pendulum's ``film1``: 60 fps, 1535
#: frames, 25.6 s, its string's length not given), which the author put up at four
#: sizes made from one recording: what a track says of the scene is the same in each,
#: and a difference between two sizes' tracks is an error of one or the other. The
#: marker's place is given on the 550×310 copy and scaled to each.
SIZES = ("film1_vga.mp4", "film1_sd.mp4", "film1_hd.mp4", "film1_fhd.mp4")
SIZES_PLACE = (214, 123)


def run_sizes(repo: Path, card: Scorecard) -> None:
    """Track the capsule in each copy of :data:`SIZES`, in the smallest copy's px, and
    print and score how far each pair of tracks lies apart against their σ (the
    constant offset between them removed, as between a hand click and a centre)."""
    tracks = {}
    for name in SIZES:
        video = _extracted_or_said(repo, name, "")
        if video is None:
            continue
        source = open_frames(video, None)
        kx, ky = source.width / 550.0, source.height / 310.0
        marker = f"bob=210@{SIZES_PLACE[0] * kx:.0f},{SIZES_PLACE[1] * ky:.0f}"
        result, bob, track_s, decode_s = timed_track(video, None, marker)
        tab = result.tracks
        ok = tab[f"{bob}_ok"].to_numpy(bool)
        xy = tab[[f"{bob}_x_px", f"{bob}_y_px"]].to_numpy(float) / [kx, ky]
        xy[~ok] = np.nan
        sigma = tab[f"{bob}_sigma_px"].to_numpy(float)[:, None] / [[kx, ky]]
        sideways = xy[ok] - xy[ok].mean(axis=0)
        along = np.linalg.svd(sideways, full_matrices=False)[2][0]
        loop = fit_swing(tab["t_s"].to_numpy(float)[ok], sideways @ along,
                         float(np.median(sigma[ok])), arc_radius(xy[ok]))
        rank, listed = (inspect_rank(video, None, 0, (xy[0, 0] * kx, xy[0, 1] * ky)) if ok[0]
                        else (None, 0))
        print(f"\n{name} ({source.width}×{source.height}, {len(tab)} frames): `--marker "
              f"{marker}` found in {ok.sum()} ({100 * ok.mean():.1f} %); `inspect` at frame 0 "
              f"lists the bob {'not at all' if rank is None else f'{rank}.'} of {listed}; "
              "σ median "
              f"{np.median(sigma[ok, 0]):.3f}, {np.median(sigma[ok, 1]):.3f} px of 550×310 "
              f"(x, y); the swing's period {loop.base.period_s:.5f} ± "
              f"{loop.base.period_sigma_s:.5f} s; tracking {track_s:.2f} s, PyAV decoding to "
              f"RGB alone {decode_s:.2f} s (ratio {decode_s / track_s:.2f})")
        card.add(name, "found (the bob is always in view)", f"{100 * ok.mean():.0f} %",
                 "≥ 95 %", ok.mean() >= 0.95)
        score_common(card, name, result, bob, track_s, decode_s)
        tracks[name] = (xy, sigma)
    if len(tracks) < 2:
        return
    print("the same recording at its sizes, each pair's tracks apart (px of 550×310, the "
          "constant offset removed) against their σ combined:")
    inside = []
    for (a, (xa, sa)), (b, (xb, sb)) in itertools.combinations(tracks.items(), 2):
        d = xa - xb
        both = np.all(np.isfinite(d), axis=1)
        d = d[both] - d[both].mean(axis=0)
        within = np.abs(d) <= np.hypot(sa[both], sb[both])
        inside.append(within)
        print(f"  {a} and {b}: RMS x {np.sqrt(np.mean(d[:, 0]**2)):.2f}, y "
              f"{np.sqrt(np.mean(d[:, 1]**2)):.2f}; median |difference| "
              f"{np.median(np.abs(d[:, 0])):.2f}, {np.median(np.abs(d[:, 1])):.2f} against "
              f"σ combined {np.median(np.hypot(sa[both, 0], sb[both, 0])):.2f}, "
              f"{np.median(np.hypot(sa[both, 1], sb[both, 1])):.2f}; ±1σ coverage "
              f"{100 * within[:, 0].mean():.0f} %, {100 * within[:, 1].mean():.0f} %")
    pooled = np.concatenate(inside)
    for axis, label in enumerate("xy"):
        covered = float(pooled[:, axis].mean())
        card.add("film1 at 4 sizes", f"±1σ coverage of each pair's difference, {label}",
                 f"{100 * covered:.0f} %", "50–90 %", 0.5 <= covered <= 0.9)


#: A scaled rover wheel driven over sand on an arm that turns about a central pivot,
#: filmed from above (700×480 H.264, 30 fps, 390 frames), from the public repository
#: yupidevs/yupi_examples (``resources/videos/Viera2017.mp4``; Viera-López et al.,
#: Rev. Sci. Instrum. 88, 086107, 2017). A green LED on the wheel's motor rests for
#: about 5 s, rides round the pivot on the arm for about 1.5 s, and goes out; the
#: pivot is a red disc in a white collar. The crank-slider's own case, A at a pivot
#: and B on the member that turns about it, on a real camera. The peer is yupi's own
#: colour tracker (``bench/yupi_peer.py``); the physics is rest, then a circle.
ROVER = ("Viera2017.mp4", "led=120@423,111", "pivot=red@305,245")
#: The LED is lit in a frame whose greenest pixel (G − max(R, B)) reaches this (DN): a
#: rule made here, apart from both trackers (38–81 while lit, 11–23 after).
LIT_DN = 30
#: The arm has set off in the first frame whose greenest pixel lies this far (px) from
#: where it lay in the first frame.
SET_OFF_PX = 3.0
#: The rover's body is still while its pivot's redness centroid (made here, apart from
#: the tracker) steps less than this (px) from frame to frame: it steps up to 0.72 px
#: while the arm turns, then 1.0–2.5 px a frame from frame 210 as the rover lurches.
#: The circle and the arm's rate hold only while the pivot stands.
BODY_STEP_PX = 1.0
#: The frame `inspect` is asked about: a second in, the rig at rest.
INSPECT_FRAME = 30


def body_still_until(video: Path, place: NDArray, off: int, last: int) -> int:
    """The last frame from ``off`` to ``last`` before the pivot's redness centroid
    (within 20 px of its place at rest, ``place`` px) first steps
    :data:`BODY_STEP_PX` or more from one frame to the next (``last`` where the pivot
    was never found at rest, ``place`` NaN)."""
    if not np.all(np.isfinite(place)):
        return last
    frames = np.arange(off, last + 1)
    centres = colour_centroids(video, frames, np.tile(place, (len(frames), 1)), 0, 10.0, 20)
    steps = np.hypot(*np.diff(centres, axis=0).T)
    moved = np.flatnonzero(steps >= BODY_STEP_PX)
    return int(frames[moved[0]]) if len(moved) else last


def greenest(video: Path) -> tuple[NDArray, NDArray]:
    """Per frame, how much greener than red and blue its greenest pixel is (DN), and
    where it lies (n, 2) px."""
    level, where = [], []
    for frame in open_frames(video, None).frames():
        rgb = frame.rgb.astype(np.int16)
        g = rgb[..., 1] - np.maximum(rgb[..., 0], rgb[..., 2])
        i, j = np.unravel_index(int(np.argmax(g)), g.shape)
        level.append(int(g[i, j]))
        where.append((j, i))
    return np.array(level), np.array(where, float)


def circle_fit(xy: NDArray) -> tuple[NDArray, float, NDArray]:
    """Centre (px), radius (px) and the radial residuals (px) of the circle nearest the
    points ``xy`` (n, 2): Kåsa's algebraic fit, then Gauss–Newton on the distances."""
    A = np.c_[2 * xy, np.ones(len(xy))]
    c = np.linalg.lstsq(A, (xy**2).sum(axis=1), rcond=None)[0]
    centre, radius = c[:2], float(np.sqrt(c[2] + c[0] ** 2 + c[1] ** 2))
    for _ in range(20):
        d = xy - centre
        rho = np.hypot(d[:, 0], d[:, 1])
        J = np.c_[-d / rho[:, None], -np.ones(len(xy))]
        step = np.linalg.lstsq(J, -(rho - radius), rcond=None)[0]
        centre, radius = centre + step[:2], radius + float(step[2])
        if np.abs(step).max() < 1e-9:
            break
    d = xy - centre
    return centre, radius, np.hypot(d[:, 0], d[:, 1]) - radius


def yupi_track(video: Path, python: Path, start: tuple[float, float],
               options: tuple[str, ...] = ()) -> pd.DataFrame | None:
    """The peer's track (``bench/yupi_peer.py`` under ``python``, with ``options``: the
    LED's colours without), or None, said, where it could not be made."""
    script = Path(__file__).resolve().parent / "yupi_peer.py"
    try:
        out = subprocess.run([str(python), str(script), str(video), str(round(start[0])),
                              str(round(start[1])), *options], capture_output=True,
                             text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as e:
        print(f"  yupi's track could not be made with {python} ({e}); skipped")
        return None
    from io import StringIO
    return pd.read_csv(StringIO(out))


def rest_coverage(xy: NDArray, sigma: NDArray) -> float:
    """How often a marker at rest lies within ±σ of the median of its fixes (per
    coordinate), NaN for fewer than 10 fixes."""
    if len(xy) < 10:
        return float("nan")
    return float(np.mean(np.abs(xy - np.median(xy, axis=0)) <= sigma[:, None]))


def at_rest_line(name: str, xy: NDArray, sigma: NDArray) -> str:
    """Scatter about the median of a marker's fixes at rest, its σ and its coverage."""
    if len(xy) < 10:
        return f"{name}: found in {len(xy)} frames, too few to judge"
    d = xy - np.median(xy, axis=0)
    spread = 1.4826 * np.median(np.abs(d), axis=0)
    return (f"{name}: scatter (MAD) x {spread[0]:.3f}, y {spread[1]:.3f} px, largest "
            f"{np.abs(d).max():.2f} px; σ median {np.median(sigma):.3f} px; ±1σ coverage "
            f"{100 * rest_coverage(xy, sigma):.0f} % (aim 50–90 %)")


def rest_second_method(video: Path, pivot: NDArray, frames: NDArray) -> str:
    """Whether the pivot's wander at rest is in the pictures: a redness centroid (within
    20 px of its median fix, 10 DN above green and blue), which shares nothing with the
    tracker's fits, against our fixes in ``frames`` (indices)."""
    if len(frames) < 10:
        return "the pivot at rest: too few fixes for a second method"
    ours = pivot[frames] - np.median(pivot[frames], axis=0)
    place = np.median(pivot[frames], axis=0)
    theirs = colour_centroids(video, frames, np.tile(place, (len(frames), 1)), 0, 10.0, 20)
    theirs -= np.median(theirs, axis=0)
    spread = 1.4826 * np.median(np.abs(theirs), axis=0)
    corr = [np.corrcoef(ours[:, i], theirs[:, i])[0, 1] for i in (0, 1)]
    return (f"the pivot at rest by a redness centroid: scatter (MAD) x {spread[0]:.3f}, "
            f"y {spread[1]:.3f} px; correlation with our fixes x {corr[0]:+.2f}, "
            f"y {corr[1]:+.2f} (near +1: the wander is in the pictures, not our fit's)")


#: The arm's crank length for `--known-length A-B=` (mm): a guess, which sets the mm of
#: the rover's run but not its angles or their rates.
ARM_MM = 66.0


def rotation_line(who: str, t: NDArray, xy: NDArray, sigma: float) -> str:
    """What `fit --model rotation` (:func:`.loop.rotation.fit_rotation`) makes of a track
    of the arm's turn (t s, xy px): the effects taken, the residual before and after, and
    the rate at the track's middle."""
    try:
        loop = fit_rotation(t, xy, sigma)
    except CranktrackError as e:
        return f"`fit --model rotation` on {who}: {e}"
    f = loop.final
    return (f"`fit --model rotation` on {who} ({loop.samples} fixes): a steady turn leaves "
            f"{loop.base.rms:.3f} px, ω {abs(loop.base.omega_rad_s):.4f} ± "
            f"{loop.base.omega_sigma_rad_s:.4f} rad/s; takes {loop.accepted or 'no effect'}"
            f" (ΔBIC {', '.join(f'{k} {v:.0f}' for k, v in loop.delta_bic.items())}): "
            f"{f.rms:.3f} px left, ω {abs(f.omega_rad_s):.4f} ± {f.omega_sigma_rad_s:.4f} "
            "rad/s at the middle"
            + (f", α {f.values['alpha_rad_s2']:+.4f} rad/s²" if "alpha_rad_s2" in f.values
               else ""))


def arm_rate(video: Path, theirs: pd.DataFrame, pivot: NDArray, off: int, last: int) -> None:
    """The product's own kinematics of the arm (``--marker C=none``, the LED as a blob B,
    a 0.2 s window: the one leave-one-out picks is set by the 5 s at rest) against
    yupi's: the mean rate
    over the move, from the first to the last frame both found, of our θ and of the
    angle of yupi's LED about our pivot's fix at rest, and about our pivot's fix in those
    two frames (our θ's own centre)."""
    _, led, pivot_marker = ROVER
    # The LED is no printed disc: B said to be a blob (as disc, it was found in 42 of the
    # 46 frames of the move, and ω spanned 34 of them).
    specs = parse_markers(["A=" + pivot_marker.split("=", 1)[1],
                           "B=" + led.split("=", 1)[1].replace("@", ":blob@"), "C=none"])
    with tempfile.TemporaryDirectory() as tmp:
        run = track_run(video, tmp, ("A", "B", ARM_MM), specs=specs, window_s=0.2)
    kin = run.kinematics.set_index("frame")
    pivots = run.tracks.set_index("frame")[["A_x_px", "A_y_px"]]
    theta = kin["theta_deg"]
    frames = [k for k in theirs.index if off <= k <= last and np.isfinite(theta.get(k, np.nan))]
    if len(frames) < 2:
        print("  the arm's rate: too few frames found by both")
        return
    a, b = frames[0], frames[-1]
    dt = float(kin.loc[b, "t_s"] - kin.loc[a, "t_s"])
    ours = np.radians(theta[b] - theta[a]) / dt
    led_px = theirs.loc[[a, b]].to_numpy(float)

    def swept(centres: NDArray) -> float:
        d = led_px - centres
        turn = np.unwrap(np.arctan2(-d[:, 1], d[:, 0]))  # image y down, the plane's y up
        return float(turn[1] - turn[0]) / dt

    peer = swept(np.tile(pivot, (2, 1)))
    moving = swept(pivots.loc[[a, b]].to_numpy(float))
    omega = kin.loc[a:b, "omega_rad_s"]
    print(f"  the arm's rate over the move (frames {a}–{b}): {ours:.4f} rad/s from our θ "
          f"(`--marker A=… B=…:blob@… C=none`), {peer:.4f} from yupi's LED about our pivot's fix "
          f"at rest ({100 * (ours / peer - 1):+.1f} %), {moving:.4f} about our pivot's fix in "
          f"those two frames ({100 * (ours / moving - 1):+.1f} %); our ω there "
          f"{np.nanmin(omega):.3f}–"
          f"{np.nanmax(omega):.3f} rad/s in the {int(np.isfinite(omega).sum())} frames it has")


def run_rover(repo: Path, yupi_python: Path | None, card: Scorecard) -> None:
    """Track the LED and the pivot, check rest and the circle, compare with yupi (and score
    the figures on ``card``)."""
    name, led_marker, pivot_marker = ROVER
    video = _extracted_or_said(repo, name, "resources/videos")
    if video is None:
        return
    result, track_s, decode_s = timed(parse_markers([led_marker, pivot_marker]), video, None)
    tab = result.tracks
    level, brightest = greenest(video)
    lit = level >= LIT_DN
    moved = np.hypot(*(brightest - brightest[0]).T) > SET_OFF_PX
    off = int(np.argmax(moved & lit))  # the first frame of the arm's turn
    last = int(np.flatnonzero(lit)[-1])
    ok = tab["led_ok"].to_numpy(bool)
    print(f"\n{name} (yupi's rover wheel, {len(tab)} frames): `--marker {led_marker} "
          f"--marker {pivot_marker}`")
    print(f"  the LED is lit in {lit.sum()} frames (greenest pixel ≥ {LIT_DN} DN above red "
          f"and blue), at rest until frame {off - 1}, on the move in frames {off}–{last}")
    print(f"  LED found in {ok[lit].sum()} of the {lit.sum()} frames it is lit "
          f"({100 * ok[lit].mean():.1f} %; aim ≥ 95 %): {ok[:off][lit[:off]].sum()} of "
          f"{lit[:off].sum()} at rest, {ok[off:last + 1].sum()} of {last + 1 - off} on the "
          f"move; in {ok[~lit].sum()} of the {(~lit).sum()} frames it is out")
    card.add(name, "LED found while lit", f"{100 * ok[lit].mean():.1f} %", "≥ 95 %",
             ok[lit].mean() >= 0.95)
    xy = tab[["led_x_px", "led_y_px"]].to_numpy(float)
    sigma = tab["led_sigma_px"].to_numpy(float)
    pivot = tab[["pivot_x_px", "pivot_y_px"]].to_numpy(float)
    # What a new user sees first: where `inspect` lists the two, a second in (at rest).
    ranks = [inspect_rank(video, None, INSPECT_FRAME, (x, y)) for x, y in
             (xy[INSPECT_FRAME], pivot[INSPECT_FRAME])]
    print(f"  `inspect` at frame {INSPECT_FRAME} lists the LED "
          + " and the pivot ".join('not at all' if k is None else f'{k}.' for k, _ in ranks)
          + f" of {ranks[0][1]} candidates (it prints the first 12)")
    pivot_ok = tab["pivot_ok"].to_numpy(bool)
    rest = np.arange(len(tab)) < off
    print("  at rest, " + at_rest_line("LED", xy[rest & ok], sigma[rest & ok]))
    print("  at rest, " + at_rest_line("pivot", pivot[rest & pivot_ok],
                                       tab["pivot_sigma_px"].to_numpy(float)[rest & pivot_ok]))
    for what, xy_rest, sigma_rest in (
            ("LED", xy[rest & ok], sigma[rest & ok]),
            ("pivot", pivot[rest & pivot_ok],
             tab["pivot_sigma_px"].to_numpy(float)[rest & pivot_ok])):
        covered = rest_coverage(xy_rest, sigma_rest)
        card.add(name, f"±1σ coverage of the {what} at rest", f"{100 * covered:.0f} %",
                 "50–90 %", 0.5 <= covered <= 0.9)
    print("  " + rest_second_method(video, pivot, np.flatnonzero(rest & pivot_ok)))
    still = body_still_until(video, np.median(pivot[rest & pivot_ok], axis=0), off, last)
    turn = ~rest & ok & (np.arange(len(tab)) <= still)
    if turn.sum() < 6:
        print(f"  on the move: found in {turn.sum()} frames, too few for a circle")
        return
    centre, radius, r = circle_fit(xy[turn])
    dof = np.sqrt(r.size / (r.size - 3))
    print(f"  the body stands until frame {still} (its pivot's redness centroid steps under "
          f"{BODY_STEP_PX} px a frame; the LED is lit until {last})")
    covered = float(np.mean(dof * np.abs(r) <= sigma[turn]))
    card.add(name, "±1σ coverage of the LED on its circle", f"{100 * covered:.0f} %", "50–90 %",
             0.5 <= covered <= 0.9)
    print(f"  on the move: a circle through our {turn.sum()} fixes (centre ({centre[0]:.1f}, "
          f"{centre[1]:.1f}), radius {radius:.1f} px; the pivot's fix at rest "
          f"{np.hypot(*(centre - np.median(pivot[rest & pivot_ok], axis=0))):.1f} px from its "
          f"centre) leaves {np.sqrt(np.mean(r**2)):.3f} px RMS across it; ±1σ coverage "
          f"{100 * covered:.0f} % (σ median "
          f"{np.median(sigma[turn]):.3f} px; aim 50–90 %); lag-1 correlation of the "
          f"residual {np.corrcoef(r[:-1], r[1:])[0, 1]:+.2f} (near +1: the arm's own "
          "wobble or a slow error, not noise)")
    t_turn = tab["t_s"].to_numpy(float)[turn]
    print("  " + rotation_line("our LED", t_turn, xy[turn], float(np.median(sigma[turn]))))
    # A second centre made apart from the tracker: where it leaves the same residual
    # against the circle, that residual is the arm's (its wobble), not either centre's.
    other = colour_centroids(video, np.flatnonzero(turn), xy[turn], 1, 10.0, 6)
    _, _, r2 = circle_fit(other)
    print(f"  a second centre (the centroid of the LED's greenness, made in this bench) leaves "
          f"{np.sqrt(np.mean(r2**2)):.3f} px across its own circle; the two residuals "
          f"correlate {np.corrcoef(r, r2)[0, 1]:+.2f} (what they share is the arm's motion)")
    if yupi_python is not None:
        peer = yupi_track(video, yupi_python, tuple(xy[np.flatnonzero(ok)[0]]))
        if peer is not None:
            theirs = peer[peer["found"] == 1].set_index("frame")[["x_px", "y_px"]]
            peer_turn = [k for k in theirs.index if off <= k <= still]
            _, _, r_peer = circle_fit(theirs.loc[peer_turn].to_numpy(float))
            both = [k for k in theirs.index if ok[k]]
            diff = xy[both] - theirs.loc[both].to_numpy(float)
            offset = diff.mean(axis=0)
            rms = float(np.sqrt(np.mean(np.sum((diff - offset) ** 2, axis=1))))
            card.add(name, "LED's RMS against yupi's", f"{rms:.2f} px", "≤ 1 px", rms <= 1.0)
            print(f"  yupi's colour tracker (whole-pixel centroids) found it in "
                  f"{len(theirs)} frames; against it, on the {len(both)} both found: offset "
                  f"({offset[0]:+.2f}, {offset[1]:+.2f}) px, RMS after removing it {rms:.2f} px "
                  f"(aim ≤ 1 px); its own circle over the move leaves "
                  f"{np.sqrt(np.mean(r_peer**2)):.3f} px across it")
            fps = float(1.0 / np.median(np.diff(tab["t_s"].to_numpy(float))))
            print("  " + rotation_line("yupi's LED", np.array(peer_turn) / fps,
                                       theirs.loc[peer_turn].to_numpy(float), 0.0))
            arm_rate(video, theirs, np.median(pivot[rest & pivot_ok], axis=0), off, still)
    else:
        print("  no --yupi-python given: yupi's own track not made")
    print(f"  time (median of {TIMINGS} runs each): tracking {track_s:.2f} s, PyAV decoding "
          f"to RGB alone {decode_s:.2f} s "
          f"(ratio decode/track {decode_s / track_s:.2f}; aim ≥ 0.9 on clips over 10 s)")
    score_common(card, name, result, "led", track_s, decode_s)
    unsure = sure_of_nothing(result, "pivot")
    card.add(name, "ok rows with σ ≥ radius or not finite (pivot)", str(unsure), "0",
             unsure == 0)


#: yupi's introductory clip (yupidevs/yupi_examples, ``resources/videos/demo.avi``): ten
#: grey balls and a blue one, 20 px in radius, dropped into a box and bouncing off its
#: walls and off one another (400×400 MPEG-4 Part 2, 15 fps, 1000 frames). A render by
#: yupi's authors, sharing nothing with ours, that draws the ball at a whole-pixel
#: centre in every frame (:func:`drawn_blue`'s centroids show it): where the ball was
#: drawn is known to the pixel, and a fix's distance to the nearest whole pixel is its
#: error. The peer is yupi's colour tracker with its introduction's bounds.
BALLS = ("demo.avi", "ball=blue@359,260")
YUPI_BALL = ("--low", "180,125,35", "--high", "190,135,45", "--roi", "100")
#: A pixel is the blue ball's where its blue exceeds its red and green by this (DN): the
#: ball reads 55 inside, the grey balls, the white box and MPEG-4's ringing round the
#: ball at most 17.
BLUE_DN = 20
#: The ball is in view in a frame with this many such pixels: a 20 px disc has 1257,
#: and every frame of the clip has 952–1262.
BLUE_SEEN_PX = 500


def drawn_blue(video: Path) -> tuple[NDArray, NDArray, NDArray]:
    """Per frame, the pixels of the blue ball (blue over red and green by
    :data:`BLUE_DN` or more); whether any of them lies on the frame's edge (the edge
    cuts the ball); and the centroid (n, 2) px of its blueness over 10 DN within 26 px
    of those pixels' middle (:func:`colour_centroids`): where the ball is, by a method
    that shares nothing with the tracker's fits (and that a cut pulls inwards)."""
    count, cut, middle = [], [], []
    for frame in open_frames(video, None).frames():
        rgb = frame.rgb.astype(np.int16)
        blue = rgb[..., 2] - np.maximum(rgb[..., 0], rgb[..., 1])
        ii, jj = np.nonzero(blue >= BLUE_DN)
        count.append(len(ii))
        h, w = blue.shape
        cut.append(bool(len(ii)) and (ii.min() == 0 or jj.min() == 0 or ii.max() == h - 1
                                      or jj.max() == w - 1))
        middle.append((np.median(jj), np.median(ii)) if len(ii) else (np.nan, np.nan))
    middle = np.array(middle, float)
    centre = np.full_like(middle, np.nan)
    seen = np.flatnonzero(np.isfinite(middle).all(axis=1))
    centre[seen] = colour_centroids(video, seen, middle[seen], 2, 10.0, 26)
    return np.array(count), np.array(cut), centre


def near_whole(v: NDArray) -> float:
    """The fraction of coordinates ``v`` within 0.1 px of a whole pixel (0.2 for
    coordinates spread evenly)."""
    return float(np.mean(np.abs(v - np.round(v)) <= 0.1))


def run_balls(repo: Path, yupi_python: Path | None, card: Scorecard) -> None:
    """Track yupi's blue ball, check its fixes against where it was drawn and against
    yupi's own track (and score the figures on ``card``)."""
    name, marker = BALLS
    found = _tracked(repo, name, "resources/videos", marker)
    if found is None:
        return
    video, result, ball, track_s, decode_s, ok = found
    tab = result.tracks
    count, cut, other = drawn_blue(video)
    seen = count >= BLUE_SEEN_PX
    print(f"\n{name} (yupi's balls in a box, a render, {len(tab)} frames, "
          f"{tab['t_s'].iloc[-1]:.1f} s): `--marker {marker}`")
    print(f"  the ball is in view in {seen.sum()} frames ({count.min()}–{count.max()} px "
          f"{BLUE_DN} DN bluer than red and green; a 20 px disc covers 1257)")
    rest = tab.loc[seen & ~ok, f"{ball}_status"].value_counts()
    print(f"  found in {ok[seen].sum()} of them ({100 * ok[seen].mean():.1f} %; aim ≥ 95 %)"
          + ("; the rest: " + ", ".join(f"{k} {v}" for k, v in rest.items()) if len(rest)
             else ""))
    card.add(name, "found while in view", f"{100 * ok[seen].mean():.1f} %", "≥ 95 %",
             ok[seen].mean() >= 0.95)
    xy = tab[[f"{ball}_x_px", f"{ball}_y_px"]].to_numpy(float)[ok]
    sigma = tab[f"{ball}_sigma_px"].to_numpy(float)[ok]
    whole = ok & seen & ~cut & np.isfinite(other).all(axis=1)
    gap = tab[[f"{ball}_x_px", f"{ball}_y_px"]].to_numpy(float)[whole] - other[whole]
    print(f"  drawn at whole pixels: {100 * near_whole(other[seen & ~cut]):.0f} % of the "
          f"blueness centroid's coordinates (made here, apart from the tracker) and "
          f"{100 * near_whole(xy[~cut[ok]]):.0f} % of ours lie within 0.1 px of one (20 % "
          f"if spread evenly), in the frames where the ball is clear of the frame's edge; "
          f"there ours and the centroid "
          f"differ by {np.sqrt(np.mean(gap**2, axis=0))[0]:.2f}, "
          f"{np.sqrt(np.mean(gap**2, axis=0))[1]:.2f} px RMS (x, y)")
    error = xy - np.round(xy)
    rms = float(np.sqrt(np.mean(np.sum(error**2, axis=1))))
    covered = float(np.mean(np.abs(error) <= sigma[:, None]))
    edge = cut[ok]
    print(f"  against where it was drawn (the nearest whole pixel): RMS {rms:.3f} px, the "
          f"largest {np.abs(error).max():.2f} px; σ median {np.median(sigma):.3f} px, ±1σ "
          f"coverage {100 * covered:.0f} % (aim 50–90 %)")
    print(f"  the ball touches the frame's edge or is cut by it in {cut.sum()} frames (as few "
          f"as {count.min()} of its pixels left); found in {ok[cut].sum()} of them, RMS "
          f"{np.sqrt(np.mean(np.sum(error[edge]**2, axis=1))):.3f} px from where it was "
          f"drawn (±1σ coverage {100 * np.mean(np.abs(error[edge]) <= sigma[edge, None]):.0f} "
          f"%), where the blueness centroid of what is left lies "
          f"{np.sqrt(np.mean(np.sum((other[ok & cut] - np.round(xy[edge]))**2, axis=1))):.2f}"
          " px RMS from it")
    card.add(name, "RMS against where it was drawn", f"{rms:.2f} px", "≤ 1 px", rms <= 1.0)
    card.add(name, "±1σ coverage against where it was drawn", f"{100 * covered:.0f} %",
             "50–90 %", 0.5 <= covered <= 0.9)
    if yupi_python is not None:
        peer = yupi_track(video, yupi_python, tuple(xy[0]), YUPI_BALL)
        if peer is not None:
            theirs = peer[peer["found"] == 1].set_index("frame")[["x_px", "y_px"]]
            common = [k for k in theirs.index if ok[k]]
            diff = (tab.loc[common, [f"{ball}_x_px", f"{ball}_y_px"]].to_numpy(float)
                    - theirs.loc[common].to_numpy(float))
            offset = diff.mean(axis=0)
            rms_peer = float(np.sqrt(np.mean(np.sum((diff - offset) ** 2, axis=1))))
            theirs_error = theirs.to_numpy(float) - np.round(other[theirs.index])
            card.add(name, "RMS against yupi's", f"{rms_peer:.2f} px", "≤ 1 px",
                     rms_peer <= 1.0)
            print(f"  yupi's colour tracker (whole-pixel centroids of the pixels inside its "
                  f"bounds) found it in {len(theirs)} frames; against it, on the "
                  f"{len(common)} both found: offset ({offset[0]:+.2f}, {offset[1]:+.2f}) px, "
                  f"RMS after removing it {rms_peer:.2f} px (aim ≤ 1 px); yupi's own RMS "
                  f"against where the ball was drawn "
                  f"{np.sqrt(np.mean(np.sum(theirs_error**2, axis=1))):.2f} px")
    else:
        print("  no --yupi-python given: yupi's own track not made")
    print(f"  time (median of {TIMINGS} runs each): tracking {track_s:.2f} s, PyAV decoding "
          f"to RGB alone {decode_s:.2f} s "
          f"(ratio decode/track {decode_s / track_s:.2f}; aim ≥ 0.9 on clips over 10 s)")
    score_common(card, name, result, ball, track_s, decode_s)


def run_free_fall(repo: Path, mosse_python: Path | None, card: Scorecard) -> None:
    """Track the student's falling steel ball by its picture, and check it against the
    tape's scale, g, its outline and the student's MOSSE track (:mod:`free_fall`; and
    score the figures on ``card``)."""
    video = _extracted_or_said(repo, free_fall.CLIP, "")
    if video is None:
        return
    result, ball, track_s, decode_s = timed_track(video, free_fall.FPS, free_fall.MARKER)
    tab = result.tracks
    ok = tab[f"{ball}_ok"].to_numpy(bool)
    spec = parse_markers([free_fall.MARKER])[0]
    radius = spec.template_radius_px
    frames = free_fall.grey_frames(video)
    height = frames[0].shape[0]
    t = tab["t_s"].to_numpy(float)
    xy = tab[[f"{ball}_x_px", f"{ball}_y_px"]].to_numpy(float)
    sigma = tab[f"{ball}_sigma_px"].to_numpy(float)
    falling = ok & (tab["frame"].to_numpy() >= free_fall.FALLING_FROM)
    accel, left, fall = free_fall.parabola(t[falling], xy[falling, 1])
    # In view: the whole ball on the frame, by the parabola (the last frames run past
    # the bottom edge).
    whole = fall(t) + radius < height - 1
    print(f"\n{free_fall.CLIP} (a student's steel ball falling past a tape measure, "
          f"{len(tab)} frames at {free_fall.FPS:.0f} fps): `--fps {free_fall.FPS:.0f} "
          f"--marker {free_fall.MARKER}`")
    print(f"  the ball lies whole on the frame in {whole.sum()} frames; found in "
          f"{ok[whole].sum()} of them ({100 * ok[whole].mean():.1f} %; aim ≥ 95 %)")
    card.add(free_fall.CLIP, "found while whole in view", f"{100 * ok[whole].mean():.1f} %",
             "≥ 95 %", ok[whole].mean() >= 0.95)
    mm, from_cm = free_fall.tape_px_per_mm(frames[0])
    g = accel / mm / 1000.0
    print(f"  the tape's scale: {mm:.4f} px/mm from its millimetre ticks ({from_cm:.4f} from "
          f"its centimetre ticks alone)")

    rms = float(np.sqrt(np.mean(left**2)))
    print(f"  a parabola through the {falling.sum()} fixes from frame "
          f"{free_fall.FALLING_FROM} on leaves {rms:.3f} px RMS: {accel:.0f} px/s², g = "
          f"{g:.3f} m/s² ({100 * (g / free_fall.G - 1):+.1f} % from {free_fall.G}; aim within "
          f"2 %)")
    # A user's ruler: 100 mm of the tape, read off at the scale of its ticks.
    ruler = Ruler((20.0, 100.0), (20.0, 100.0 + 100.0 * mm), 100.0)
    g_tool, g_tool_sigma = tool_g(tab, ball, ruler, (frames[0].shape[1], height), falling)
    print(f"  `--ruler {ruler.text()}` (100 mm of the tape): motion.csv's ay, median over the "
          f"fall, gives g = {g_tool:.3f} m/s² (its σ a frame {g_tool_sigma:.2f}), against the "
          f"parabola's {g:.3f} here")
    card.add(free_fall.CLIP, "g with the tape's ticks as the scale",
             f"{100 * (g / free_fall.G - 1):+.1f} %", "within 2 %",
             abs(g / free_fall.G - 1) <= 0.02)
    covered = float(np.mean(np.abs(left) <= sigma[falling]))
    # A fix's own scatter, apart from any smooth motion: third differences of
    # consecutive fixes, whose variance is 20 times one fix's.
    index = tab["frame"].to_numpy()[falling]
    third = np.diff(xy[falling], 3, axis=0)[index[3:] - index[:-3] == 3]
    scatter = np.std(third, axis=0) / np.sqrt(20.0)
    print(f"  σ median {np.median(sigma[falling]):.3f} px; ±1σ coverage against the parabola "
          f"(y) {100 * covered:.0f} % (aim 50–90 %); the parabola's residual has a lag-1 "
          f"correlation of {np.corrcoef(left[:-1], left[1:])[0, 1]:+.2f}, and the fixes' "
          f"frame-to-frame scatter (third differences) is {scatter[0]:.3f} px in x, "
          f"{scatter[1]:.3f} in y")
    card.add(free_fall.CLIP, "±1σ coverage against the parabola", f"{100 * covered:.0f} %",
             "50–90 %", 0.5 <= covered <= 0.9)
    rim = np.array([free_fall.rim_circle(frames[k], *xy[k], radius) for k in
                    np.flatnonzero(falling & whole)])
    rim_accel, rim_left, _ = free_fall.parabola(t[falling & whole], rim[:, 1])
    drift = np.polyfit(t[falling & whole], xy[falling & whole, 0], 1)[0]
    rim_drift = np.polyfit(t[falling & whole], rim[:, 0], 1)[0]
    print(f"  the ball's outline (a circle fitted to its rim here, sought about our fixes, "
          f"{np.median(rim[:, 2]):.1f} px in radius): g = {rim_accel / mm / 1000.0:.3f} m/s², "
          "its parabola leaving "
          f"{np.sqrt(np.mean(rim_left**2)):.2f} px RMS; across the fall it moves "
          f"{drift * np.ptp(t[falling & whole]):+.2f} px in x by our track and "
          f"{rim_drift * np.ptp(t[falling & whole]):+.2f} px by its outline")
    if mosse_python is not None:
        peer = free_fall.mosse_track(video, mosse_python, *spec.near_px, radius)
        if peer is not None:
            theirs = peer.set_index("frame")
            common = [k for k in theirs.index if ok[k] and whole[k] and theirs.at[k, "found"]]
            diff = xy[common] - theirs.loc[common, ["x_px", "y_px"]].to_numpy(float)
            offset = diff.mean(axis=0)
            rms_peer = float(np.sqrt(np.mean(np.sum((diff - offset) ** 2, axis=1))))
            sel = [k for k in common if falling[k]]
            peer_accel, peer_left, _ = free_fall.parabola(
                t[sel], theirs.loc[sel, "y_px"].to_numpy(float))
            print(f"  the student's MOSSE tracker (whole pixels) against ours on the "
                  f"{len(common)} frames both hold: RMS {rms_peer:.2f} px after removing the "
                  f"offset ({offset[0]:+.2f}, {offset[1]:+.2f}) px (aim ≤ 1 px); its g "
                  f"{peer_accel / mm / 1000.0:.3f} m/s², its parabola leaving "
                  f"{np.sqrt(np.mean(peer_left**2)):.2f} px RMS; its x moves "
                  f"{np.ptp(theirs.loc[common, 'x_px']):.2f} px")
            card.add(free_fall.CLIP, "RMS against the student's MOSSE", f"{rms_peer:.2f} px",
                     "≤ 1 px", rms_peer <= 1.0)
    else:
        print("  no --mosse-python given: the student's MOSSE track not made")
    print(f"  time (median of {TIMINGS} runs each): tracking {track_s:.2f} s, PyAV decoding "
          f"to RGB alone {decode_s:.2f} s (ratio decode/track {decode_s / track_s:.2f}; "
          "aim ≥ 0.9 on clips over 10 s)")
    score_common(card, free_fall.CLIP, result, ball, track_s, decode_s)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_clip_paths(ap)
    args = ap.parse_args()
    print(f"libraries: {versions_line()}")
    given = [p for p in (args.tracker, args.pendulum, args.capsule, args.rover, args.free_fall)
             if p is not None and p.exists()]
    if not given:
        print("usage: bench/real_footage.py [PATH-TO-OpenSourcePhysics/tracker] "
              "[--pendulum PATH-TO-juangomez177/Pendulum_Oscillatory_Motion] "
              "[--capsule PATH-TO-bartekpacia/pendulum] "
              "[--yupi PATH-TO-yupidevs/yupi_examples [--yupi-python PYTHON]] "
              "[--free-fall PATH-TO-SantiagoGiraldoM17/LaboratorioCaidaLibre "
              "[--mosse-python PYTHON]] (checkouts or their git directories); no path given, "
              "nothing measured")
        return
    # The kernels compiled (or read from numba's cache) before any clip is timed.
    compile_kernels()
    card = Scorecard()
    if args.tracker is not None and args.tracker.exists():
        falls = {}
        for clip in CLIPS:
            figures = run_clip(args.tracker, clip, card)
            if clip.physics == "drag":
                falls[clip] = figures
        if falls:
            print("\nCupsClips: terminal speeds against the masses (drag ∝ v², one shape)")
            compare_drag(falls)
    if args.pendulum is not None and args.pendulum.exists():
        run_pendulum(args.pendulum, card)
    if args.capsule is not None and args.capsule.exists():
        run_pendulum(args.capsule, card, CAPSULE)
        run_sizes(args.capsule, card)
    if args.rover is not None and args.rover.exists():
        run_rover(args.rover, args.yupi_python, card)
        run_balls(args.rover, args.yupi_python, card)
    if args.free_fall is not None and args.free_fall.exists():
        run_free_fall(args.free_fall, args.mosse_python, card)
    card.show()


if __name__ == "__main__":
    main()
