"""A peer's track of the green LED on yupi's rover-wheel clip, made by yupi itself.

yupi (https://github.com/yupidevs/yupi, MIT) publishes this clip with an example
that follows the LED by colour: its ``ColorMatching`` detector with the example's
BGR bounds (80, 170, 90)–(190, 255, 190), inside a 50×50 px ``ROI`` that follows the
detection. That example starts with a window to click the LED in; here the ROI is
placed where the LED starts instead, and the frames are fed one by one as its
``TrackingScenario`` feeds them. Nothing of cranktrack is used.

yupi needs ``opencv-python``, which would sit beside the project's
``opencv-python-headless`` in one environment, so it runs in a Python of its own
(``python -m venv /tmp/yupi && /tmp/yupi/bin/pip install yupi``) and
``bench/real_footage.py --yupi-python /tmp/yupi/bin/python`` calls this script:

    /tmp/yupi/bin/python bench/yupi_peer.py VIDEO X Y > peer.csv

It prints ``frame,x_px,y_px,found`` per frame after the first (yupi's centroids are
whole pixels; ``found`` 0 where its mask was empty and the ROI stayed put).
"""

from __future__ import annotations

import logging
import sys

import cv2
from yupi.tracking import ROI, ColorMatching, ObjectTracker


def main() -> None:
    video, x, y = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    logging.disable(logging.WARNING)  # yupi says so on each frame its mask is empty
    tracker = ObjectTracker("led", ColorMatching((80, 170, 90), (190, 255, 190)),
                            ROI((50, 50), init_mode=ROI.CENTER_INIT_MODE))
    capture = cv2.VideoCapture(video)
    ok, frame = capture.read()
    if not ok:
        sys.exit(f"could not read {video}")
    # The ROI's place, as its click window would have set it (yupi's own fields).
    roi = tracker.roi
    roi._global_height, roi._global_width = frame.shape[:2]
    roi._centroid = roi._prev_centroid = (x, y)
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
