"""Reading frames: container timestamps, image folders, timing reports."""

import cv2
import numpy as np
import pytest

from cranktrack.errors import CranktrackError
from cranktrack.synthetic.video import VideoWriter
from cranktrack.tracker.video import open_frames, timing_report


def test_variable_frame_rate_timestamps_are_read_not_assumed(tmp_path):
    # Written with uneven times and two dropped frames; index/fps would be wrong.
    times = [0.0, 0.033, 0.067, 0.100, 0.200, 0.233, 0.280, 0.300]
    with VideoWriter(tmp_path / "vfr.mp4", 64, 48, 30.0, lossless=True) as w:
        for t in times:
            w.write(np.full((48, 64, 3), 128, np.uint8), t)
    src = open_frames(tmp_path / "vfr.mp4")
    got = [f.t_s for f in src.frames()]
    np.testing.assert_allclose(got, times, atol=1e-4)
    rep = timing_report(np.array(got), src.nominal_fps)
    assert rep["variable_rate"]
    assert rep["gaps"] == 1 and rep["dropped_frames_estimate"] == 2


def test_constant_rate_report():
    rep = timing_report(np.arange(100) / 25.0, 25.0)
    assert not rep["variable_rate"] and rep["gaps"] == 0
    assert rep["median_fps"] == pytest.approx(25.0)
    dup = timing_report(np.array([0.0, 0.04, 0.04, 0.08]))
    assert dup["duplicated_timestamps"] == 1


def test_image_folder_in_natural_order(tmp_path):
    for i in (10, 2, 1):
        img = np.full((20, 30, 3), i, np.uint8)
        cv2.imwrite(str(tmp_path / f"frame_{i}.png"), img)
    src = open_frames(tmp_path, fps=10.0)
    frames = list(src.frames())
    assert [int(f.rgb[0, 0, 0]) for f in frames] == [1, 2, 10]
    assert [f.t_s for f in frames] == [0.0, 0.1, 0.2]
    with pytest.raises(CranktrackError, match="--fps"):
        open_frames(tmp_path)


def test_empty_folder_and_missing_path(tmp_path):
    with pytest.raises(CranktrackError, match="no images"):
        open_frames(tmp_path)
    with pytest.raises(CranktrackError, match="does not exist"):
        open_frames(tmp_path / "missing.mp4")
