"""The second renderer's SMA bed seen by a tilted camera whose lens bends lines.

A lab camera is rarely square to the rig. ``cranktrack`` answers with a calibration:
board photos for the camera's intrinsics and lens, and one photo of a board lying in
the rig's plane (``cranktrack calibrate camera`` / ``calibrate plane``). Until now that
chain was checked only on the project's own renderer (``bench/calibration.py``,
``tests/test_calibration_truth.py``), which shares its camera with nothing else.

Here every picture is made by code written apart from ``cranktrack``: the bed of
``bench/sma_bed_apart.py`` (its board, bar, printed discs and wire, drawn in the
bed's plane), a pinhole camera with a radial lens written out below (:class:`Lens`),
pitched ``--tilt`` degrees and turned a quarter of that sideways, and chessboards
drawn in their own planes and seen through the same lens. The clip is coded as H.264
4:2:0 (``--rgb``: lossless RGB, the tracker's full-colour path). ``cranktrack`` then
calibrates the camera from the board photos and the plane from the board lying on the
bed, tracks the clip with that calibration and, apart, with the A–C length alone (a
scale for a camera square to the bed), and the bench prints against the bed's truth:
θ's RMS error and mean, the crank's length |AB| (24.1 mm, Table 2.3) and its spread,
and the markers' plane positions in mm.

    .venv/bin/python bench/tilted_bed.py [--tilt 20] [--k1 -0.15] [--case 0] [--k3 auto]
                                         [--rgb] [--keep DIR]
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
import pandas as pd
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parent))
import sma_bed_apart as bed

from cranktrack.calibration.camera import Board, calibrate_camera
from cranktrack.calibration.plane import PlaneCalibration, board_plane
from cranktrack.environment import versions_line
from cranktrack.pipeline import track_run

#: The camera's distance from the bed along its axis, mm, and its focal length, px:
#: 2.6 px/mm where the axis meets the bed, the scale of ``sma_bed_apart``.
DISTANCE_MM = 500.0
FOCAL_PX = bed.PX_PER_MM * DISTANCE_MM
#: Camera pixels drawn per frame pixel before averaging down.
CAMERA_SUPERSAMPLE = 4
#: The board on the bed: inner corners, square side (mm) and its top-left corner on the
#: bed (mm), covering A to C as an A3 print would.
BED_BOARD = ((33, 13), 10.0, (4.0, 5.0))
#: The board photographed for the intrinsics: inner corners and square side (mm).
VIEW_BOARD = ((9, 6), 12.0)
VIEWS = 15
#: px/mm at which the chessboards' plane pictures are drawn.
BOARD_PX_PER_MM = 8.0


@dataclass(frozen=True)
class Lens:
    """A pinhole of focal length ``f`` px and principal point ``c`` px whose lens moves
    a ray at normalised radius ρ to ρ·(1 + k1·ρ²) (k1 < 0: barrel)."""

    f: float
    c: tuple[float, float]
    k1: float

    def to_pixels(self, xn: NDArray, yn: NDArray) -> tuple[NDArray, NDArray]:
        """Normalised ideal coordinates (x/z, y/z) to image px."""
        bend = 1.0 + self.k1 * (xn * xn + yn * yn)
        return self.f * xn * bend + self.c[0], self.f * yn * bend + self.c[1]

    def to_rays(self, u: NDArray, v: NDArray) -> tuple[NDArray, NDArray]:
        """Image px to normalised ideal coordinates: the bend undone by fixed-point
        iteration (it converges for |k1|·ρ² well under 1, as here)."""
        xd, yd = (u - self.c[0]) / self.f, (v - self.c[1]) / self.f
        xn, yn = xd.copy(), yd.copy()
        for _ in range(30):
            bend = 1.0 + self.k1 * (xn * xn + yn * yn)
            xn, yn = xd / bend, yd / bend
        return xn, yn


def rotation(pitch_deg: float, yaw_deg: float, roll_deg: float = 0.0) -> NDArray:
    """World-to-camera rotation: pitch about x, then yaw about y, then roll about z."""
    a, b, c = (math.radians(v) for v in (pitch_deg, yaw_deg, roll_deg))
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
    return rz @ ry @ rx


@dataclass(frozen=True)
class Pose:
    """A plane (z = 0, its x and y in mm) seen by the camera: world-to-camera rotation
    ``r`` and the camera's centre ``centre`` (mm, in the plane's frame)."""

    r: NDArray
    centre: NDArray

    @classmethod
    def looking_at(cls, target_mm: tuple[float, float], r: NDArray, distance_mm: float
                   ) -> Pose:
        """The camera ``distance_mm`` from the plane point ``target_mm`` along its axis."""
        axis = r[2]  # the camera's z axis in the plane's frame
        return cls(r, np.array([target_mm[0], target_mm[1], 0.0]) - distance_mm * axis)

    def project(self, lens: Lens, xy_mm: NDArray) -> NDArray:
        """Plane points (n, 2) mm to image px (n, 2)."""
        p = np.column_stack([xy_mm, np.zeros(len(xy_mm))]) - self.centre
        cam = p @ self.r.T
        u, v = lens.to_pixels(cam[:, 0] / cam[:, 2], cam[:, 1] / cam[:, 2])
        return np.column_stack([u, v])

    def plane_of(self, lens: Lens, u: NDArray, v: NDArray) -> tuple[NDArray, NDArray]:
        """Image px to the plane point each pixel's ray meets (mm)."""
        xn, yn = lens.to_rays(u, v)
        rays = np.stack([xn, yn, np.ones_like(xn)], axis=-1) @ self.r  # camera → plane
        t = -self.centre[2] / rays[..., 2]
        return self.centre[0] + t * rays[..., 0], self.centre[1] + t * rays[..., 1]


def camera_maps(lens: Lens, pose: Pose, size: tuple[int, int], px_per_mm_fine: float,
                offset_fine: float, supersample: int) -> tuple[NDArray, NDArray]:
    """For each pixel of the camera's fine grid (``supersample`` per frame px), where to
    sample a picture of the plane drawn at ``px_per_mm_fine`` (its pixel (0, 0) at
    ``offset_fine`` px from the plane's origin): maps for ``cv2.remap``."""
    w, h = size[0] * supersample, size[1] * supersample
    jj, ii = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    u = (jj - (supersample - 1) / 2) / supersample
    v = (ii - (supersample - 1) / 2) / supersample
    x_mm, y_mm = pose.plane_of(lens, u, v)
    return ((x_mm * px_per_mm_fine + offset_fine).astype(np.float32),
            (y_mm * px_per_mm_fine + offset_fine).astype(np.float32))


def through_camera(plane_picture: NDArray[np.float32], maps: tuple[NDArray, NDArray],
                   size: tuple[int, int], supersample: int, lens_blur_px: float,
                   noise_dn: float, rng: np.random.Generator) -> NDArray[np.uint8]:
    """The camera's 8-bit picture of a plane picture: resampled through ``maps``, the
    lens's blur, averaged down to frame pixels, sensor noise."""
    fine = cv2.remap(plane_picture, maps[0], maps[1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)
    fine = cv2.GaussianBlur(fine, (0, 0), lens_blur_px * supersample)
    small = cv2.resize(fine, size, interpolation=cv2.INTER_AREA)
    if noise_dn:
        small = small + rng.normal(0, noise_dn, small.shape)
    return np.clip(np.round(small), 0, 255).astype(np.uint8)


def chessboard(inner: tuple[int, int], square_mm: float, px_per_mm: float
               ) -> NDArray[np.float32]:
    """A chessboard's plane picture (RGB float, white quiet zone of one square), drawn
    at ``px_per_mm``; its first inner corner lies at (2·square, 2·square) mm."""
    cols, rows = inner[0] + 1, inner[1] + 1
    side = square_mm * px_per_mm
    w, h = round((cols + 2) * side), round((rows + 2) * side)
    img = np.full((h, w, 3), 235.0, np.float32)
    for r in range(rows):
        for c in range(cols):
            if (r + c) % 2 == 0:
                x0, y0 = (c + 1) * side, (r + 1) * side
                cv2.rectangle(img, (round(x0 * 16), round(y0 * 16)),
                              (round((x0 + side) * 16) - 1, round((y0 + side) * 16) - 1),
                              (20.0, 20.0, 20.0), -1, cv2.LINE_8, 4)
    return img


def view_poses(rng: np.random.Generator, n: int) -> list[Pose]:
    """``n`` poses of the intrinsics board, tilted up to 35° and spread over the frame."""
    poses = []
    w_mm = (VIEW_BOARD[0][0] + 3) * VIEW_BOARD[1]
    h_mm = (VIEW_BOARD[0][1] + 3) * VIEW_BOARD[1]
    for _ in range(n):
        r = rotation(rng.uniform(-35, 35), rng.uniform(-35, 35), rng.uniform(-20, 20))
        target = (w_mm / 2 + rng.uniform(-60, 60), h_mm / 2 + rng.uniform(-35, 35))
        poses.append(Pose.looking_at(target, r, rng.uniform(380, 520)))
    return poses


def write_view_photos(lens: Lens, folder: Path, rng: np.random.Generator) -> list[Path]:
    """The intrinsics board's photos through ``lens``, as PNG."""
    scale = BOARD_PX_PER_MM
    picture = chessboard(*VIEW_BOARD, scale)
    paths = []
    for k, pose in enumerate(view_poses(rng, VIEWS)):
        maps = camera_maps(lens, pose, bed.SIZE, scale, -0.5, 2)
        photo = through_camera(picture, maps, bed.SIZE, 2, bed.LENS_BLUR_PX, 1.5, rng)
        path = folder / f"view_{k:02d}.png"
        cv2.imwrite(str(path), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
        paths.append(path)
    return paths


def bed_board_photo(lens: Lens, pose: Pose, rng: np.random.Generator) -> NDArray[np.uint8]:
    """The bed-plane board, lying on the bed, photographed by the clip's camera."""
    inner, square, (bx, by) = BED_BOARD
    scale = BOARD_PX_PER_MM
    picture = chessboard(inner, square, scale)
    # The picture's origin is the board's corner: shift the plane so it lands at (bx, by).
    shifted = Pose(pose.r, pose.centre - np.array([bx, by, 0.0]))
    maps = camera_maps(lens, shifted, bed.SIZE, scale, -0.5, 2)
    return through_camera(picture, maps, bed.SIZE, 2, bed.LENS_BLUR_PX, 1.5, rng)


def render_clip(path: Path, lens: Lens, pose: Pose, case: bed.Case, seconds: float,
                fps: float, seed: int, rgb: bool = False) -> None:
    """The bed's clip through the camera, H.264 4:2:0 crf 20; with ``rgb``, lossless RGB
    (every pixel its own colour: the tracker's full-chroma path)."""
    rng = np.random.default_rng(seed)
    background = bed.board(np.random.default_rng(1000 + seed))
    s = CAMERA_SUPERSAMPLE
    fine = bed.SUPERSAMPLE * bed.PX_PER_MM
    # The bed's picture: frame pixel (0, 0)'s centre at fine (S−1)/2 and at 0 mm.
    maps = camera_maps(lens, pose, bed.SIZE, fine, (bed.SUPERSAMPLE - 1) / 2, s)
    n = round(seconds * fps)
    with av.open(str(path), mode="w") as out:
        stream = out.add_stream("libx264rgb" if rgb else "libx264",
                                rate=Fraction(fps).limit_denominator(1001))
        stream.width, stream.height = bed.SIZE
        stream.pix_fmt = "rgb24" if rgb else "yuv420p"
        stream.options = ({"qp": "0", "preset": "fast"} if rgb else
                          {"crf": "20", "preset": "fast", "x264-params": "mbtree=0"})
        for k in range(n):
            t = k / fps
            times = [t] if case.exposure_s <= 0 else t + case.exposure_s * (
                (np.arange(bed.EXPOSURE_SAMPLES) + 0.5) / bed.EXPOSURE_SAMPLES - 0.5)
            theta, _ = case.heating.theta(np.asarray(times))
            plane = sum(bed.draw(background, th) for th in theta) / len(theta)
            picture = through_camera(plane, maps, bed.SIZE, s, bed.LENS_BLUR_PX,
                                     bed.NOISE_DN, rng)
            for packet in stream.encode(av.VideoFrame.from_ndarray(picture, format="rgb24")):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)


def bed_mm(theta_deg: NDArray) -> dict[str, NDArray]:
    """A, B, C on the bed's plane (mm, the plane's x right and y down), (n, 2) each."""
    pts = [bed.points_px(th) for th in theta_deg]
    return {m: np.array([p[m] for p in pts]) / bed.PX_PER_MM for m in "ABC"}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tilt", type=float, default=20.0,
                    help="the camera's pitch, degrees (its yaw is a quarter of it)")
    ap.add_argument("--k1", type=float, default=-0.15, help="the lens's radial bend")
    ap.add_argument("--case", type=int, default=0,
                    help="which of sma_bed_apart's cases (0-based)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--k3", choices=("auto", "free", "fixed"), default="auto",
                    help="what cranktrack's camera calibration does with k3 (its --k3)")
    ap.add_argument("--rgb", action="store_true",
                    help="code the clip as lossless RGB instead of H.264 4:2:0")
    ap.add_argument("--keep", type=Path, help="keep the pictures and runs in this folder")
    args = ap.parse_args(argv)
    print(f"libraries: {versions_line()}")
    case = bed.CASES[args.case]
    lens = Lens(FOCAL_PX, ((bed.SIZE[0] - 1) / 2 + 7.0, (bed.SIZE[1] - 1) / 2 - 5.0),
                args.k1)
    mid = (bed.SIZE[0] / 2 / bed.PX_PER_MM, bed.SIZE[1] / 2 / bed.PX_PER_MM)
    pose = Pose.looking_at(mid, rotation(args.tilt, args.tilt / 4), DISTANCE_MM)
    print(f"{case.name}; camera {bed.SIZE[0]}×{bed.SIZE[1]}, f {lens.f:.0f} px, k1 {lens.k1:g}, "
          f"pitched {args.tilt:g}° and turned {args.tilt / 4:g}°, {DISTANCE_MM:g} mm from the "
          f"bed; {'lossless RGB' if args.rgb else 'H.264 crf 20'}, noise {bed.NOISE_DN:g} DN")
    with tempfile.TemporaryDirectory() as tmp:
        where = args.keep or Path(tmp)
        where.mkdir(parents=True, exist_ok=True)
        rng = np.random.default_rng(7 + args.seed)
        views = where / "views"
        views.mkdir(exist_ok=True)
        photos = write_view_photos(lens, views, rng)
        camera = calibrate_camera(photos, Board("chessboard", *VIEW_BOARD), k3=args.k3)
        plane_photo = bed_board_photo(lens, pose, rng)
        cv2.imwrite(str(where / "plane.png"), cv2.cvtColor(plane_photo, cv2.COLOR_RGB2BGR))
        plane = board_plane(cv2.cvtColor(plane_photo, cv2.COLOR_RGB2GRAY),
                            Board("chessboard", BED_BOARD[0], BED_BOARD[1]), camera)
        print(f"camera calibrated from {len(photos)} board photos: f {camera.fx:.1f} / "
              f"{camera.fy:.1f} px (drawn {lens.f:.1f}), k1 {camera.distortion[0]:+.4f} "
              f"(drawn {lens.k1:+.4f}), k3 {camera.distortion[4]:+.3f} (drawn 0; --k3 "
              f"{args.k3}), reprojection RMS {camera.rms_px:.3f} px; the board on "
              f"the bed: homography residual {plane.quality['homography_rms_px']:.3f} px")
        calibration_alone(plane, lens, pose, case)
        video = where / f"tilted_{args.case}_{args.seed}{'_rgb' * args.rgb}.mp4"
        if not video.exists():
            render_clip(video, lens, pose, case, args.seconds, args.fps, args.seed, args.rgb)
        for label, kw in (("camera + plane calibration", {"calibration": plane}),
                          ("the A–C length alone", {})):
            out = where / ("run_" + label.split()[0].replace("–", ""))
            shutil.rmtree(out, ignore_errors=True)
            run = track_run(video, out, ("A", "C", bed.L1_MM), **kw)
            report(label, run.tracks, run.kinematics, case)
            in_pixels(run.tracks, lens, pose, case)
            said = [w for w in run.warnings if "ellipse" in w or "rigid length" in w]
            for w in said:
                print(f"    the run says: {w[:160]}{'…' * (len(w) > 160)}")


def calibration_alone(plane: PlaneCalibration, lens: Lens, pose: Pose, case: bed.Case) -> None:
    """θ and |AB| from the markers' drawn centres (projected by the bench's own camera,
    no tracking) through ``cranktrack``'s calibration: what the calibration alone costs."""
    truth_deg = np.linspace(*sorted((case.heating.theta0_deg, case.heating.theta1_deg)), 25)
    mm = {m: plane.plane_points(pose.project(lens, xy)) for m, xy in bed_mm(truth_deg).items()}
    ab, ac = mm["B"] - mm["A"], mm["C"] - mm["A"]
    # The angle from A–C to A–B, whichever way round the board's own frame turns.
    theta = np.degrees(np.abs(np.arctan2(ac[:, 0] * ab[:, 1] - ac[:, 1] * ab[:, 0],
                                         np.sum(ac * ab, axis=1))))
    print(f"  the calibration alone (the drawn centres through it): θ off by up to "
          f"{np.max(np.abs(theta - truth_deg)):.3f}°, |AB| by "
          f"{np.max(np.abs(np.hypot(*ab.T) - bed.L2_MM)):.3f} mm")


def in_pixels(tracks: pd.DataFrame, lens: Lens, pose: Pose, case: bed.Case) -> None:
    """Each marker's fixes against its drawn centre sent through the bench's own camera
    (px): RMS error per axis, median σ and ±1σ coverage (per coordinate)."""
    truth = bed_mm(case.heating.theta(tracks["t_s"].to_numpy(float))[0])
    parts = []
    for m in "ABC":
        ok = tracks[f"{m}_ok"].to_numpy(bool)
        xy = tracks[[f"{m}_x_px", f"{m}_y_px"]].to_numpy(float)[ok]
        err = xy - pose.project(lens, truth[m])[ok]
        sigma = tracks[f"{m}_sigma_px"].to_numpy(float)[ok]
        parts.append(f"{m} {math.sqrt(np.mean(err ** 2)):.3f} px, σ {np.median(sigma):.3f}, "
                     f"{100 * np.mean(np.abs(err) <= sigma[:, None]):.0f} %")
    print("    in px against the drawn centres (RMS per axis, median σ, ±1σ coverage): "
          + "; ".join(parts))


def report(label: str, tracks: pd.DataFrame, kin: pd.DataFrame, case: bed.Case) -> None:
    """θ, |AB| and the markers' plane positions against the bed's truth."""
    t = kin["t_s"].to_numpy(float)
    truth_deg, _ = case.heating.theta(t)
    th = kin["theta_deg"].to_numpy(float)
    have = np.isfinite(th)
    d = th[have] - truth_deg[have]
    ab = np.hypot(tracks["B_x_mm"] - tracks["A_x_mm"], tracks["B_y_mm"] - tracks["A_y_mm"])
    ab = ab.to_numpy(float)
    ab = ab[np.isfinite(ab)]
    truth = bed_mm(case.heating.theta(tracks["t_s"].to_numpy(float))[0])
    # The run's plane frame has A at its origin and C on +x: so has the truth, moved.
    origin = truth["A"][0]
    pos = []
    for m in "ABC":
        xy = tracks[[f"{m}_x_mm", f"{m}_y_mm"]].to_numpy(float)
        # The run's y is 90° counter-clockwise as the camera sees it: the bed's −y.
        true = (truth[m] - origin) * np.array([1.0, -1.0])
        pos.append(np.hypot(*(xy - true).T))
    pos = np.concatenate(pos)
    pos = pos[np.isfinite(pos)]
    print(f"  {label}: θ over {have.sum()} frames RMS {math.sqrt(np.mean(d ** 2)):.3f}° "
          f"(mean {np.mean(d):+.3f}°, largest {np.max(np.abs(d)):.3f}°); |AB| "
          f"{np.mean(ab):.3f} mm (drawn {bed.L2_MM:g}, spread {np.ptp(ab):.3f}); positions "
          f"RMS {math.sqrt(np.mean(pos ** 2)):.3f} mm")


if __name__ == "__main__":
    main()
