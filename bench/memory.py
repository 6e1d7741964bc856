"""Peak memory of tracking a 300-frame and a 3,000-frame 1080p video.

The 300-frame video is a 1920×1080 H.264 spool render (cached in
bench/.cache); the 3,000-frame one is the same frames looped ten times with
continuing timestamps. Each is tracked in a fresh process and its peak
resident set size (ru_maxrss) printed, with the ratio. Streaming means the
ratio should stay within 10 %.

    .venv/bin/python bench/memory.py
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import scene

from cranktrack.synthetic.scene import RenderSettings
from cranktrack.synthetic.video import VideoWriter
from cranktrack.tracker.video import open_frames

# VmHWM (peak resident set) belongs to the child's own address space;
# ru_maxrss would not do: Linux carries it over from the parent through fork.
PROBE = """
import sys
from cranktrack.tracker.track import track
from cranktrack.tracker.video import open_frames
n = len(track(open_frames(sys.argv[1])).tracks)
hwm = [ln for ln in open("/proc/self/status") if ln.startswith("VmHWM")][0].split()[1]
print(n, hwm)
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


def peak_kib(video: Path) -> tuple[int, int]:
    out = subprocess.run([sys.executable, "-c", PROBE, str(video)], capture_output=True,
                         text=True, check=True).stdout.split()
    return int(out[0]), int(out[1])


def main() -> None:
    short = scene("memory_1080p_300", RenderSettings(size=(1920, 1080), fps=30.0,
                                                     seconds=10.0, noise_dn=2.5, seed=9))
    long = short.folder / "looped_3000.mp4"
    looped(short.video, long, 10, 30.0)
    n1, m1 = peak_kib(short.video)
    n2, m2 = peak_kib(long)
    print(f"{n1:5d} frames: peak RSS {m1 / 1024:7.1f} MiB")
    print(f"{n2:5d} frames: peak RSS {m2 / 1024:7.1f} MiB")
    print(f"ratio long/short = {m2 / m1:.3f}  (target: within 10 %, i.e. < 1.10)")


if __name__ == "__main__":
    main()
