"""The renderer: exact marker centres, truth written beside the video, real timestamps."""

import json

import av
import numpy as np
import pandas as pd
import pytest

from cranktrack.synthetic.camera import Camera, PinholeCamera
from cranktrack.synthetic.render import Style, capsule_coverage, render_frame, to_uint8
from cranktrack.synthetic.scenarios import SpoolScenario
from cranktrack.synthetic.video import VideoWriter
from cranktrack.tables import kinematics_columns, track_mm_columns, track_px_columns


@pytest.mark.parametrize("radius", [3.7, 15.0])
def test_disc_coverage_has_the_right_area_and_centre(radius):
    # Independent check: area π r² and the coverage-weighted centroid at the
    # true centre, for random sub-pixel positions.
    rng = np.random.default_rng(7)
    xs = ys = np.arange(64.0)
    X, Y = np.meshgrid(xs, ys)
    worst = 0.0
    for _ in range(50):
        c = np.array([31.0, 32.0]) + rng.random(2)
        a = capsule_coverage(xs, ys, c, c, radius, 4).astype(float)
        assert a.sum() == pytest.approx(np.pi * radius**2, rel=2e-3)
        est = np.array([(a * X).sum(), (a * Y).sum()]) / a.sum()
        worst = max(worst, float(np.hypot(*(est - c))))
    # "exact to well under 0.01 px": 0.001 px at r = 15 px, 0.005 px at r = 3.7 px.
    assert worst < (0.002 if radius > 10 else 0.006)


def test_rendered_marker_centroid_matches_camera_projection():
    # A whole frame, noise-free and quantised to 8 bits: the marker's
    # background-subtracted intensity centroid lands on the projected centre.
    cam = Camera(640, 360, 4.3, (100.3, 250.7))
    # Links in the background colour, so each marker sits on a uniform ground.
    bg = Style().background
    style = Style(frame_link=bg, crank=bg, wire=bg)
    rng = np.random.default_rng(2)
    for _ in range(5):
        pts_mm = {"A": np.zeros(2), "B": rng.uniform([20, 10], [60, 40]),
                  "C": np.array([120.0, 0.0])}
        pts = {k: cam.project(v) for k, v in pts_mm.items()}
        img = to_uint8(render_frame(pts, (640, 360), cam.px_per_mm, style)).astype(float)
        r = style.marker_radius_mm * cam.px_per_mm
        cx, cy = pts["B"]
        x0, y0 = int(cx - r - 3), int(cy - r - 3)
        patch = img[y0 : y0 + int(2 * r + 7), x0 : x0 + int(2 * r + 7)]
        red = np.array(style.markers["B"])
        # Coverage per pixel: where the pixel lies between background and marker colour.
        ground = np.array(bg)
        w = np.clip(((patch - ground) @ (red - ground)) / ((red - ground) @ (red - ground)), 0, 1)
        yy, xx = np.mgrid[y0 : y0 + patch.shape[0], x0 : x0 + patch.shape[1]]
        inner = np.hypot(xx - cx, yy - cy) < r + 1.5
        w = w * inner
        est = np.array([(w * xx).sum(), (w * yy).sum()]) / w.sum()
        # 8-bit rounding of the edge pixels leaves a few thousandths of a pixel.
        assert np.hypot(*(est - pts["B"])) < 0.01


@pytest.mark.parametrize("tilt", [0.0, 10.0, 35.0])
def test_a_tilted_camera_draws_a_disc_as_the_ellipse_it_sees(tilt):
    # A disc of 6 mm on the plane, drawn through a pinhole tilted about the image's
    # x axis. Two truths written here, apart from the drawing:
    # - analytic: where the optical axis meets the plane, the image is squashed
    #   across the tilt axis by cos(tilt), to first order in the disc's size;
    # - the circle's rim sent forward through the camera (4000 points) bounds a
    #   polygon whose area and centroid the coverage must have.
    cam = PinholeCamera.framing(640, 360, [-80.0, -80.0], [170.0, 80.0], tilt_deg=tilt)
    to_plane = cam.canvas_to_plane((0.0, 0.0))
    R = 6.0
    for where, analytic in ((np.array(cam.target_mm), True), (np.array([150.0, 60.0]), False)):
        c = cam.ideal_project(where)
        xs = np.arange(int(c[0]) - 30, int(c[0]) + 31, dtype=float)
        ys = np.arange(int(c[1]) - 30, int(c[1]) + 31, dtype=float)
        cov = capsule_coverage(xs, ys, where, where, R, 4, to_plane).astype(float)
        X, Y = np.meshgrid(xs, ys)
        area = cov.sum()
        centroid = np.array([(cov * X).sum(), (cov * Y).sum()]) / area
        phi = np.linspace(0, 2 * np.pi, 4001)[:-1]
        rim = cam.ideal_project(where + R * np.stack([np.cos(phi), np.sin(phi)], 1))
        x, y = rim[:, 0], rim[:, 1]
        x2, y2 = np.roll(x, -1), np.roll(y, -1)
        cross = x * y2 - x2 * y
        poly_area = cross.sum() / 2
        poly_centroid = np.array([((x + x2) * cross).sum(), ((y + y2) * cross).sum()]) / (
            6 * poly_area)
        assert area == pytest.approx(abs(poly_area), rel=5e-4)
        np.testing.assert_allclose(centroid, poly_centroid, atol=0.003)
        if analytic:
            m = np.cov(np.stack([X.ravel(), Y.ravel()]), aweights=cov.ravel(), bias=True)
            ev, vec = np.linalg.eigh(m)
            assert np.sqrt(ev[0] / ev[1]) == pytest.approx(np.cos(np.radians(tilt)), abs=2e-3)
            if tilt:
                assert abs(vec[1, 0]) > 0.999  # the short axis is the image's y


def test_camera_framing_centres_the_motion_and_flips_y():
    cam = Camera.framing(320, 240, [0, 0], [160, 40], fill=0.8)
    assert cam.px_per_mm == pytest.approx(0.8 * 320 / 160)
    centre = cam.project(np.array([80.0, 20.0]))
    np.testing.assert_allclose(centre, [159.5, 119.5])
    up = cam.project(np.array([0.0, 10.0])) - cam.project(np.array([0.0, 0.0]))
    assert up[1] < 0 and up[0] == pytest.approx(0)  # plane +y is image up


def test_lossless_video_is_bit_exact_with_exact_timestamps(tmp_path):
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, (48, 64, 3), dtype=np.uint8) for _ in range(5)]
    times = [0.0, 0.04, 0.08, 0.2, 0.24]  # uneven on purpose: 0.12 and 0.16 are "dropped"
    with VideoWriter(tmp_path / "v.mp4", 64, 48, 25.0, lossless=True) as w:
        for f, t in zip(frames, times, strict=True):
            w.write(f, t)
    with av.open(str(tmp_path / "v.mp4")) as c:
        got = [(fr.time, fr.to_ndarray(format="rgb24")) for fr in c.decode(video=0)]
    assert [round(t, 6) for t, _ in got] == times
    for (_, a), b in zip(got, frames, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not list(tmp_path.glob(".*partial*"))


def test_render_writes_truth_and_scene_with_the_contract_columns(small_lossless):
    truth = pd.read_csv(small_lossless.truth)
    expected = set(track_px_columns()) | set(track_mm_columns()) | set(kinematics_columns())
    assert expected <= set(truth.columns)
    assert len(truth) == 60
    np.testing.assert_allclose(np.diff(truth["t_s"]), 1 / 30)
    scene = json.loads(small_lossless.scene.read_text())
    assert scene["scenario"]["name"] == "spool"
    assert scene["render"]["frames"] == 60
    # Truth is the model: at t = 0 the crank sits at θ0 ≈ 30.9° (Table 2.2).
    assert truth["theta_deg"].iloc[0] == pytest.approx(30.85, abs=0.01)
    # Rigid links in the truth: |AB| = L2 in mm on every frame.
    ab = np.hypot(truth["B_x_mm"] - truth["A_x_mm"], truth["B_y_mm"] - truth["A_y_mm"])
    np.testing.assert_allclose(ab, 72.4)


def test_truth_pixels_are_the_projection_of_truth_millimetres(small_lossless):
    truth = pd.read_csv(small_lossless.truth)
    scene = json.loads(small_lossless.scene.read_text())
    c = scene["camera"]
    cam = Camera(c["width"], c["height"], c["px_per_mm"], tuple(c["origin_px"]),
                 c["rotation_deg"])
    uv = cam.project(truth[["B_x_mm", "B_y_mm"]].to_numpy())
    np.testing.assert_allclose(uv, truth[["B_x_px", "B_y_px"]].to_numpy(), atol=1e-6)


def test_sensor_noise_has_the_requested_sigma():
    img = np.full((200, 200, 3), 100.0, dtype=np.float32)
    out = to_uint8(img, 2.5, np.random.default_rng(0)).astype(float)
    # 8-bit rounding adds 1/12 DN² of variance.
    assert out.std() == pytest.approx(np.sqrt(2.5**2 + 1 / 12), rel=0.02)


def test_spool_scenario_motion_matches_the_drive():
    sc = SpoolScenario()
    m = sc.motion(np.array([0.0, sc.drive.stop_s + 0.1]))
    # After the stroke the wire is L3_0 − stroke long.
    assert m.L3_mm[1] == pytest.approx(105.4 - 15.0)
    assert np.hypot(*(m.points_mm["B"][1] - m.points_mm["C"][1])) == pytest.approx(90.4)
