"""Property-based: whatever bytes or JSON a user hands over, no traceback."""

import functools
import json
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cranktrack.calibration.file import load_calibration
from cranktrack.cli import main
from cranktrack.errors import CranktrackError

MP4_HEAD = b"\x00\x00\x00\x20ftypisom\x00\x00\x02\x00isomiso2avc1mp41"


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(body=st.binary(max_size=4096), mp4_header=st.booleans())
def test_random_bytes_as_a_video_never_crash(body, mp4_header):
    with tempfile.TemporaryDirectory() as tmp:
        video = Path(tmp) / "clip.mp4"
        video.write_bytes((MP4_HEAD if mp4_header else b"") + body)
        # 0: decoded something; 1: one clear sentence. Anything else raises here.
        assert main(["track", str(video), "--out", str(Path(tmp) / "run"),
                     "--known-length", "A-C=160.8"]) in (0, 1)


@functools.cache
def _clip() -> bytes:
    """A small real render's bytes (160×120, 1 s), made once."""
    from cranktrack.synthetic.scenarios import SpoolScenario
    from cranktrack.synthetic.scene import RenderSettings, render_scene

    with tempfile.TemporaryDirectory() as tmp:
        settings = RenderSettings(size=(160, 120), fps=30.0, seconds=1.0, seed=4)
        return render_scene(SpoolScenario(), Path(tmp), settings).video.read_bytes()


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(flips=st.lists(st.tuples(st.floats(0, 1), st.integers(1, 255)), min_size=1,
                      max_size=8), in_header=st.booleans())
def test_a_real_clip_with_flipped_bytes_never_crashes(flips, in_header):
    # Bytes flipped in the container's header and index (the first 2 kB: ftyp, moov)
    # or anywhere in the file; 0 or one clear sentence, never a traceback.
    data = bytearray(_clip())
    span = min(2048, len(data)) if in_header else len(data)
    for where, mask in flips:
        data[min(int(where * span), span - 1)] ^= mask
    with tempfile.TemporaryDirectory() as tmp:
        video = Path(tmp) / "clip.mp4"
        video.write_bytes(bytes(data))
        assert main(["track", str(video), "--out", str(Path(tmp) / "run"), "--quiet"]) in (0, 1)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                                 max_size=5),
    max_leaves=20)
calibration_like = st.fixed_dictionaries(
    {"schema": st.sampled_from([1, 2, 3, "2", None])},
    optional={"kind": st.sampled_from(["plane", "camera", "other"]),
              "method": json_values, "image_size": json_values, "mm_per_px": json_values,
              "origin_px": json_values, "x_axis_deg": json_values,
              "homography_px_to_mm": json_values, "camera": json_values})


@settings(max_examples=150, deadline=None)
@given(data=st.one_of(json_values, calibration_like))
def test_random_calibration_json_is_refused_cleanly(data):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "cal.json"
        path.write_text(json.dumps(data))
        try:
            load_calibration(path, (640, 480))
        except CranktrackError:
            pass

