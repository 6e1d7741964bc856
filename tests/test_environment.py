"""run.json says which libraries made a run: read from the installed metadata, checked
here against what the imported modules say of themselves."""

import json

import av
import cv2
import numpy as np

from cranktrack.environment import library_versions, versions_line


def test_the_library_versions_are_those_of_the_modules_imported():
    v = library_versions()
    assert v["numpy"] == np.__version__ and v["av"] == av.__version__
    # OpenCV's wheel adds a build number to the library's own version (5.0.0.93).
    assert v["opencv"].startswith(cv2.__version__ + ".")
    assert v["libavcodec"] == ".".join(map(str, av.library_versions["libavcodec"]))
    assert all(v[k] != "absent" for k in ("cranktrack", "numba", "pandas", "scipy"))
    assert f"opencv {v['opencv']}" in versions_line()


def test_a_run_records_them(tmp_path, small_h264):
    from cranktrack.cli import main

    run = tmp_path / "run"
    assert main(["track", str(small_h264.video), "--out", str(run), "--quiet"]) == 0
    info = json.loads((run / "run.json").read_text())
    assert info["libraries"] == library_versions()
    assert info["cranktrack"] == info["libraries"]["cranktrack"]
    report = (run / "report.md").read_text()
    assert f"opencv {info['libraries']['opencv']}" in report
    assert f"libavcodec {info['libraries']['libavcodec']}" in report
