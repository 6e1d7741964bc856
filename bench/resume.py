"""Ctrl-C at random moments, then --resume: is the result the uninterrupted run's, byte for byte?

Runs ``cranktrack track`` on one clip (a cached 10 s 640×360 H.264 spool render, or
``--video``) once without interruption, timing it; then ``--points`` times (10) as a
separate process that gets a real SIGINT, as Ctrl-C sends it, after a random delay
between 0.05 s and the uninterrupted run's wall time. Each interrupted run is
continued as its message advises (``--resume`` when it says the run can be resumed,
the same command again when it says no frame was finished) and its tables are
compared byte for byte with the uninterrupted run's.

Prints, per point: the delay, where the run was (frames in the partial
``tracks.csv``, or "before the first frame", or "finished" if the signal came after
the end), what the message advised, and whether tracks.csv, kinematics.csv and
calibration.json are identical; then the count.

    .venv/bin/python bench/resume.py [--points 10] [--seed 1] [--video clip.mp4]
"""

from __future__ import annotations

import argparse
import filecmp
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import scene

from cranktrack.synthetic.scene import RenderSettings

COMPARED = ("tracks.csv", "kinematics.csv", "calibration.json")


def _command(video: Path, out: Path, known: str) -> list[str]:
    exe = Path(sys.executable).with_name("cranktrack")
    return [str(exe), "track", str(video), "--out", str(out), "--known-length", known,
            "--quiet"]


def _frames_in(path: Path) -> int:
    try:
        return max(0, len(path.read_text().splitlines()) - 1)
    except OSError:
        return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--video", type=Path, help="a clip with green/red/blue markers A, B, C")
    ap.add_argument("--known-length", default="A-C=160.8")
    a = ap.parse_args()
    video = a.video or scene("resume_640_10s", RenderSettings(size=(640, 360), seconds=10.0,
                                                            noise_dn=2.5, seed=5)).video
    work = Path(tempfile.mkdtemp(prefix="cranktrack-resume-"))
    try:
        t0 = time.perf_counter()
        subprocess.run(_command(video, work / "full", a.known_length), check=True,
                       capture_output=True)
        wall = time.perf_counter() - t0
        print(f"uninterrupted: {wall:.2f} s wall, {_frames_in(work / 'full/tracks.csv')} "
              f"frames ({video})")
        rng = random.Random(a.seed)
        same = 0
        for k in range(a.points):
            delay = rng.uniform(0.05, wall)
            out = work / f"cut{k}"
            p = subprocess.Popen(_command(video, out, a.known_length), stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True)
            time.sleep(delay)
            p.send_signal(signal.SIGINT)
            _, err = p.communicate(timeout=300)
            if p.returncode == 0:
                where, advice, again = "finished", "-", []
            elif not err.strip():
                # Python hands SIGINT back to the system as it shuts down; a signal in that
                # last moment ends the process with no word, after everything was written.
                where, advice, again = f"exit (rc {p.returncode}, nothing said)", "-", []
            else:
                frames = _frames_in(out / "tracks.csv")
                where = f"{frames} frames" if frames else "before the first frame"
                resumable = "--resume" in err
                advice = "--resume" if resumable else "run again"
                again = ["--resume"] if resumable else []
            if p.returncode != 0 and err.strip():
                r = subprocess.run(_command(video, out, a.known_length) + again,
                                   capture_output=True, text=True)
                if r.returncode != 0:
                    print(f"  point {k}: the continued run failed: {r.stderr.strip()}")
                    continue
            equal = all(filecmp.cmp(work / "full" / n, out / n, shallow=False)
                        for n in COMPARED)
            same += equal
            said = err.strip().splitlines()[-1] if err.strip() else ""
            traceback = " (with a TRACEBACK)" if "Traceback" in err else ""
            print(f"  point {k}: SIGINT after {delay:.2f} s, at {where}, advised {advice}"
                  f"{traceback}: {'identical' if equal else 'DIFFERENT'}"
                  + (f"\n    it said: {said}" if said else ""))
        print(f"identical to the uninterrupted run: {same} of {a.points}")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
