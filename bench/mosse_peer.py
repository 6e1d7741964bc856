"""A peer's track of a ball, made the way the student who filmed it made theirs.

SantiagoGiraldoM17/LaboratorioCaidaLibre (``AnalisisCaidaLibre.py``) follows a steel
ball falling past a tape measure with OpenCV's MOSSE correlation-filter tracker
(``cv2.legacy.TrackerMOSSE``, from opencv-contrib): a box drawn round the ball in
the first frame, updated frame by frame. The student drew the box by hand; here it
is the square of side 2R about the place given. Nothing of cranktrack is used.

MOSSE is in ``opencv-contrib-python``, which would sit beside the project's
``opencv-python-headless`` in one environment, so it runs in a Python of its own
(``python -m venv /tmp/mosse && /tmp/mosse/bin/pip install
opencv-contrib-python-headless``) and ``bench/real_footage.py --free-fall PATH
--mosse-python /tmp/mosse/bin/python`` calls this script:

    /tmp/mosse/bin/python bench/mosse_peer.py VIDEO X Y R

It prints ``frame,x_px,y_px,found`` per frame: the box's centre (px), and whether
the tracker says it still holds the ball.
"""

from __future__ import annotations

import argparse
import itertools
import sys

import cv2


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("video")
    ap.add_argument("x", type=float)
    ap.add_argument("y", type=float)
    ap.add_argument("r", type=float)
    args = ap.parse_args()
    capture = cv2.VideoCapture(args.video)
    ok, frame = capture.read()
    if not ok:
        sys.exit(f"could not read {args.video}")
    tracker = cv2.legacy.TrackerMOSSE.create()
    side = 2.0 * args.r
    tracker.init(frame, (args.x - args.r, args.y - args.r, side, side))
    print("frame,x_px,y_px,found")
    print(f"0,{args.x},{args.y},1")
    for index in itertools.count(1):
        ok, frame = capture.read()
        if not ok:
            return
        held, (left, top, w, h) = tracker.update(frame)
        print(f"{index},{left + w / 2.0},{top + h / 2.0},{int(held)}")


if __name__ == "__main__":
    main()
