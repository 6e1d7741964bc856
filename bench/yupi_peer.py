"""A peer's track of an object in one of yupi's example clips, made by yupi itself.

yupi (https://github.com/yupidevs/yupi, MIT) publishes its clips with examples that
follow an object by colour: its ``ColorMatching`` detector with BGR bounds, inside a
square ``ROI`` that follows the detection. The defaults are those of its rover-wheel
example (the green LED: (80, 170, 90)–(190, 255, 190), 50 px); its introduction
tracks the blue ball of ``demo.avi`` with (180, 125, 35)–(190, 135, 45) and 100 px.
Those examples start with a window to click the object in; here the ROI is placed
where the object starts instead, and the frames are fed one by one as its
``TrackingScenario`` feeds them. Nothing of cranktrack is used.

yupi needs ``opencv-python``, which would sit beside the project's
``opencv-python-headless`` in one environment, so it runs in a Python of its own
(``python -m venv /tmp/yupi && /tmp/yupi/bin/pip install yupi``) and
``bench/real_footage.py --yupi-python /tmp/yupi/bin/python`` calls this script:

    /tmp/yupi/bin/python bench/yupi_peer.py VIDEO X Y [--low B,G,R --high B,G,R --roi PX]

It prints ``frame,x_px,y_px,found`` per frame after the first (yupi's centroids are
whole pixels; ``found`` 0 where its mask was empty and the ROI stayed put).
"""

from __future__ import annotations

import argparse
import logging
import sys

import cv2
from yupi.tracking import ROI, ColorMatching, ObjectTracker


def _bgr(text: str) -> tuple[int, int, int]:
    b, g, r = (int(v) for v in text.split(","))
    return b, g, r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("video")
    ap.add_argument("x", type=int)
    ap.add_argument("y", type=int)
    ap.add_argument("--low", type=_bgr, default=(80, 170, 90))
    ap.add_argument("--high", type=_bgr, default=(190, 255, 190))
    ap.add_argument("--roi", type=int, default=50)
    args = ap.parse_args()
    logging.disable(logging.WARNING)  # yupi says so on each frame its mask is empty
    tracker = ObjectTracker("object", ColorMatching(args.low, args.high),
                            ROI((args.roi, args.roi), init_mode=ROI.CENTER_INIT_MODE))
    capture = cv2.VideoCapture(args.video)
    ok, frame = capture.read()
    if not ok:
        sys.exit(f"could not read {args.video}")
    # The ROI's place, as its click window would have set it (yupi's own fields).
    roi = tracker.roi
    roi._global_height, roi._global_width = frame.shape[:2]
    roi._centroid = roi._prev_centroid = (args.x, args.y)
    print("frame,x_px,y_px,found")
    index = 0
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        index += 1
        tracker._track(frame)
        roi._prev_centroid = roi._centroid
        found = tracker.mask is not None and bool(tracker.mask.any())
        print(f"{index},{roi._centroid[0]},{roi._centroid[1]},{int(found)}")


if __name__ == "__main__":
    main()
