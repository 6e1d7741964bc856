"""Peak memory of ``cranktrack track`` on 900 and 9,000 frames of 1080p, against
decoding alone.

The 900-frame video is a 30 s 1920×1080 H.264 spool render (cached in
bench/.cache, shared with bench/speed.py); the 9,000-frame one is the same
frames looped ten times with continuing timestamps. For each, in fresh
processes, it prints the peak resident set size of:

- decode only: PyAV decoding every frame to RGB arrays, nothing else;
- the whole command: ``cranktrack track VIDEO --out RUN --known-length …``
  (tracking, kinematics, tables, figure and report);

and their ratio (target ≤ 1.5, #24), then the command's long/short ratio
(streaming: it should stay flat in video length).

    .venv/bin/python bench/memory.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import clip_1080p, track_command

from cranktrack.environment import versions_line
from cranktrack.synthetic.video import VideoWriter
from cranktrack.tracker.video import open_frames

# ru_maxrss of the children, read by a small Python parent: Linux carries a
# child's high-water mark over from its parent through fork, so the parent that
# forks must itself be small (this one is ~10 MB, far below what is measured).
PEAK = """
import resource, subprocess, sys
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
"""

DECODE = """
import sys, av
with av.open(sys.argv[1]) as c:
    s = c.streams.video[0]
    s.thread_type = "AUTO"
    for f in c.decode(s):
        f.to_ndarray(format="rgb24")
"""


def looped(src: Path, dst: Path, times: int, fps: float) -> None:
    if dst.exists():
        return
    source = open_frames(src)
    with VideoWriter(dst, source.width, source.height, fps) as out:
        k = 0
        for _ in range(times):  # re-decode each pass: streaming, like the tracker
            for frame in source.frames():
                out.write(frame.rgb, k / fps)
                k += 1


def peak_mib(command: list[str]) -> float:
    """Peak resident set (MiB) of ``command`` run in a fresh process."""
    out = subprocess.run([sys.executable, "-c", PEAK, *command], capture_output=True,
                         text=True, check=True).stdout
    return int(out.split()[-1]) / 1024


def main() -> None:
    print(f"libraries: {versions_line()}")
    short = clip_1080p(900)
    long = short.folder / "looped_9000.mp4"
    looped(short.video, long, 10, 30.0)
    command_peaks = []
    for video, frames in ((short.video, 900), (long, 9000)):
        decode = peak_mib([sys.executable, "-c", DECODE, str(video)])
        with tempfile.TemporaryDirectory() as tmp:
            track = peak_mib(track_command(short, Path(tmp) / "run", video))
        command_peaks.append(track)
        print(f"{frames:5d} frames: peak RSS decode only {decode:6.1f} MiB, cranktrack track "
              f"{track:6.1f} MiB, ratio {track / decode:.2f}  (target ≤ 1.5)", flush=True)
    print(f"cranktrack track, 9000/900 frames: {command_peaks[1] / command_peaks[0]:.3f}  "
          "(flat in video length: close to 1)")


if __name__ == "__main__":
    main()
