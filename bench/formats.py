"""The reader on the formats cameras write: where drawn discs are found, and how fast.

Three discs (the crank-slider's green A, red B and blue C) are drawn at whole pixels
by OpenCV, 16× over and averaged down (``cv2.INTER_AREA``), and coded in each
layout cameras and phones store: 8-bit 4:2:0 in BT.601 and BT.709, full range, 4:2:2
(MJPEG webcams, ProRes), 4:4:4, 10- and 12-bit (a phone's HDR HEVC), a display
rotation (a phone filming upright), non-square pixels (DV, HDV) and interlaced fields
(DV and HDV camcorders), a webcam's raw YUYV, NV12, and a camcorder's MPEG transport
stream, whose clock starts at 1.4 s. The truth is where they were drawn, in the picture a player
shows; it shares no code with cranktrack's reader or tracker. Per format the bench
prints each disc's mean offset from its drawn place along x and y (px, over 20
frames; A moves 2 px a frame along x, B 1 px along y), the frames it was found in,
and tracking time against PyAV decoding the same file to RGB.

    .venv/bin/python bench/formats.py [--frames N] [--speed]

An encoder this FFmpeg lacks is said and left out. With ``--speed`` it also times
tracking 300 frames of ``bench/speed.py``'s 1080p render coded as BT.601 and as
BT.709 (HD video's matrix), three times each in turn, against PyAV decoding them to
RGB (the medians; skipped where ``bench/speed.py`` has not made the render).
"""

from __future__ import annotations

import argparse
import fractions
import sys
import tempfile
import time
from pathlib import Path

import av
import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import CACHE, decode_only

from cranktrack.environment import versions_line
from cranktrack.tracker.track import track
from cranktrack.tracker.video import open_frames

H, W = 240, 320
UP = 4  # drawn this many times larger, then averaged down

#: name, encoder, pixel format, encoder options, container, and what the file says:
#: a display rotation (deg), a sample aspect ratio, interlaced fields.
FORMATS = [
    ("H.264 4:2:0 BT.601", "libx264", "yuv420p", {"crf": "0"}, "mp4", {}),
    ("H.264 4:2:0 BT.709 (HD)", "libx264", "yuv420p", {"crf": "0", "x264-params":
                                                        "colormatrix=bt709"}, "mp4", {}),
    ("H.264 4:2:0 full range", "libx264", "yuvj420p", {"crf": "0"}, "mp4", {}),
    ("H.264 4:2:2", "libx264", "yuv422p", {"crf": "0"}, "mkv", {}),
    ("H.264 4:4:4", "libx264", "yuv444p", {"crf": "0"}, "mkv", {}),
    ("H.264 10-bit 4:2:0", "libx264", "yuv420p10le", {"crf": "0"}, "mkv", {}),
    ("H.264 10-bit 4:2:2", "libx264", "yuv422p10le", {"crf": "0"}, "mkv", {}),
    ("HEVC 10-bit BT.2020 HLG (phone HDR)", "libx265", "yuv420p10le",
     {"x265-params": "log-level=error:lossless=1:colorprim=bt2020:transfer=arib-std-b67:"
                     "colormatrix=bt2020nc"}, "mp4", {}),
    ("MJPEG 4:2:2 (webcam)", "mjpeg", "yuvj422p", {"q:v": "2"}, "avi", {}),
    ("ProRes 4:2:2 10-bit", "prores_ks", "yuv422p10le", {}, "mov", {}),
    ("VP9 4:2:0", "libvpx-vp9", "yuv420p", {"lossless": "1"}, "webm", {}),
    ("H.264, phone upright (rotation 90°)", "libx264", "yuv420p", {"crf": "0"}, "mp4",
     {"rotation": 90}),
    ("H.264, HDV pixels (SAR 4:3)", "libx264", "yuv420p", {"crf": "0"}, "mp4",
     {"sar": fractions.Fraction(4, 3)}),
    ("H.264 interlaced, bottom field first", "libx264", "yuv420p",
     {"crf": "0", "x264-params": "interlaced=1:tff=1"}, "mp4", {"interlaced": True}),
    ("raw YUYV 4:2:2 (a webcam's own)", "rawvideo", "yuyv422", {}, "avi", {}),
    ("raw NV12 (capture cards)", "rawvideo", "nv12", {}, "mkv", {}),
    ("H.264 MPEG-TS (.MTS), clock from 1.4 s", "libx264", "yuv420p", {"crf": "0"}, "ts",
     {"clock_s": 1.4}),
]

#: Where each disc is drawn at time t (s), in the shown picture's pixels (px), at 25 fps.
DISCS = {"A": ((40, 190, 70), lambda t: (80 + 50 * t, 120.0)),
         "B": ((200, 40, 40), lambda t: (160.0, 100 + 25 * t)),
         "C": ((40, 70, 200), lambda t: (250.0, 130.0))}


def draw(t: float, width: int = W) -> np.ndarray:
    """The three discs at time ``t`` (s), radius 12 px, in a picture ``width`` wide (px
    of its own; narrower than :data:`W` squeezes the scene as stored non-square pixels)."""
    big = np.full((H * UP, W * UP, 3), 90, np.uint8)
    for rgb, where in DISCS.values():
        x, y = where(t)
        centre = np.round(((np.array([x, y]) + 0.5) * UP - 0.5) * 64).astype(int)
        cv2.circle(big, (int(centre[0]), int(centre[1])), 12 * UP * 64, rgb, -1, cv2.LINE_AA,
                   6)
    return cv2.resize(big, (width, H), interpolation=cv2.INTER_AREA)


def _field_planes(picture: np.ndarray, parity: int) -> np.ndarray:
    """4:2:0 planes of one field of ``picture`` (its lines ``parity``, ``parity`` + 2, …)."""
    lines = np.ascontiguousarray(picture[parity::2])
    return av.VideoFrame.from_ndarray(lines, format="rgb24").reformat(
        format="yuv420p").to_ndarray()


def _interlaced(t: float) -> av.VideoFrame:
    """A frame of two fields 20 ms apart, the bottom one first, each field's colour coded
    from its own lines (interlaced 4:2:0)."""
    bottom, top = _field_planes(draw(t), 1), _field_planes(draw(t + 0.02), 0)
    planes = np.empty((H * 3 // 2, W), np.uint8)
    planes[0:H:2], planes[1:H:2] = top[:H // 2], bottom[:H // 2]
    for at in (H, H + H // 4):
        chroma = planes[at:at + H // 4].reshape(H // 2, W // 2)
        start = (at - H) // 2 + H // 2
        chroma[0::2] = top[start:start + H // 8].reshape(H // 4, W // 2)
        chroma[1::2] = bottom[start:start + H // 8].reshape(H // 4, W // 2)
    return av.VideoFrame.from_ndarray(planes, format="yuv420p")


def write(path: Path, encoder: str, layout: str, options: dict, says: dict,
          frames: int) -> None:
    """The clip of one format, at 25 frames a second."""
    sar = says.get("sar", fractions.Fraction(1))
    width = round(W / sar)
    turns = says.get("rotation", 0) // 90
    with av.open(str(path), "w") as out:
        s = out.add_stream(encoder, rate=25, options=options)
        stored = np.rot90(np.zeros((H, width)), -turns).shape
        s.height, s.width, s.pix_fmt = stored[0], stored[1], layout
        if sar != 1:
            s.codec_context.sample_aspect_ratio = sar
        if turns:
            s.set_display_rotation(90 * turns)
        for k in range(frames):
            if says.get("interlaced"):
                frame = _interlaced(k / 25)
            else:
                picture = np.ascontiguousarray(np.rot90(draw(k / 25, width), -turns))
                frame = av.VideoFrame.from_ndarray(picture, format="rgb24").reformat(
                    format=layout)
            frame.pts = k + round(25 * says.get("clock_s", 0.0))
            frame.time_base = fractions.Fraction(1, 25)
            out.mux(s.encode(frame))
        out.mux(s.encode())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--speed", action="store_true",
                    help="also time 1080p in BT.601 and BT.709")
    args = ap.parse_args()
    print(f"libraries: {versions_line()}")
    print(f"{'format':38s} found A/B/C   mean offset from the drawn place, px (x, y)"
          "                       track s / decode s")
    with tempfile.TemporaryDirectory() as tmp:
        for name, encoder, layout, options, container, says in FORMATS:
            try:
                av.codec.Codec(encoder, "w")
            except av.codec.codec.UnknownCodecError:
                print(f"{name:38s} (this FFmpeg has no {encoder}; left out)")
                continue
            path = Path(tmp) / f"clip.{container}"
            write(path, encoder, layout, options, says, args.frames)
            track(open_frames(path))  # compiled kernels loaded before timing
            t0 = time.perf_counter()
            tab = track(open_frames(path)).tracks
            track_s = time.perf_counter() - t0
            decode_s = decode_only(path)[1]
            sar = float(says.get("sar", 1))
            found, offsets = [], []
            for m, (_, where) in DISCS.items():
                ok = tab[f"{m}_ok"].to_numpy(bool)
                drawn = np.array([where(t) for t in tab["t_s"]])
                # Stored pixels: a squeezed picture's pixel centres lie at (x + ½)/aspect − ½.
                dx = tab[f"{m}_x_px"].to_numpy()[ok] - ((drawn[ok, 0] + 0.5) / sar - 0.5)
                dy = tab[f"{m}_y_px"].to_numpy()[ok] - drawn[ok, 1]
                found.append(f"{100 * ok.mean():.0f}")
                offsets.append(f"{m} {np.mean(dx):+.3f} {np.mean(dy):+.3f}")
            print(f"{name:38s} {'/'.join(found):11s}   {';  '.join(offsets):46s}"
                  f"   {track_s:.3f} / {decode_s:.3f} ({len(tab)} frames)")
    if args.speed:
        speed()


def speed(frames: int = 300) -> None:
    """Tracking time of 1080p in BT.601 and BT.709 (:func:`main`'s ``--speed``)."""
    render = CACHE / "speed_1080p_900" / "video.mp4"
    if not render.exists():
        print(f"\n--speed: {render} is not there (bench/speed.py makes it); skipped")
        return
    clips = {}
    for matrix in ("smpte170m", "bt709"):
        clips[matrix] = CACHE / "formats" / f"1080p_{matrix}.mp4"
        if clips[matrix].exists():
            continue
        clips[matrix].parent.mkdir(parents=True, exist_ok=True)
        with av.open(str(render)) as src, av.open(str(clips[matrix]), "w") as out:
            s = out.add_stream("libx264", rate=30, options={
                "crf": "18", "preset": "ultrafast", "x264-params": f"colormatrix={matrix}"})
            s.width, s.height, s.pix_fmt = 1920, 1080, "yuv420p"
            for k, frame in enumerate(src.decode(video=0)):
                if k == frames:
                    break
                planes = av.VideoFrame.from_ndarray(frame.to_ndarray(), format="yuv420p")
                planes.pts, planes.time_base = k, fractions.Fraction(1, 30)
                out.mux(s.encode(planes))
            out.mux(s.encode())
    track(open_frames(clips["bt709"]))
    times: dict[str, list[float]] = {m: [] for m in clips}
    decode: dict[str, list[float]] = {m: [] for m in clips}
    for _ in range(3):
        for matrix, path in clips.items():
            t0 = time.perf_counter()
            track(open_frames(path))
            times[matrix].append(time.perf_counter() - t0)
            decode[matrix].append(decode_only(path)[1])
    print(f"\n{frames} frames of 1080p (median of 3 runs each):")
    for matrix in clips:
        t, d = np.median(times[matrix]), np.median(decode[matrix])
        print(f"  {matrix:10s} tracking {t:.2f} s, PyAV decoding to RGB {d:.2f} s "
              f"(ratio decode/track {d / t:.2f})")


if __name__ == "__main__":
    main()
