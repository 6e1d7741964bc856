"""A printed disc seen by a camera not square to its plane: the metric the plane's map
gives, and the disc fit that takes it.

The truth is written here, apart from the fit: a disc on a plane, drawn into pixels by
sampling each pixel at 8×8 points mapped to the plane by a map written in the test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cranktrack.tracker.disc import fit_disc
from cranktrack.tracker.foreshortening import foreshortening_of


def _affine(a: np.ndarray, shift: tuple[float, float] = (0.0, 0.0)):
    """Image px → plane mm through the 2×2 matrix ``a`` (mm per px)."""
    def to_plane(x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        return (a[0, 0] * x + a[0, 1] * y + shift[0], a[1, 0] * x + a[1, 1] * y + shift[1])
    return to_plane


def _homography(h: np.ndarray):
    def to_plane(x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        w = h[2, 0] * x + h[2, 1] * y + h[2, 2]
        return ((h[0, 0] * x + h[0, 1] * y + h[0, 2]) / w,
                (h[1, 0] * x + h[1, 1] * y + h[1, 2]) / w)
    return to_plane


def test_an_affine_map_gives_its_own_metric_everywhere_with_determinant_one():
    a = np.array([[0.10, 0.02], [-0.01, 0.07]])
    f = foreshortening_of(_affine(a), (200, 120), step_px=16)
    g = a.T @ a / abs(np.linalg.det(a))
    for x, y in [(0, 0), (37.3, 91.2), (199, 119), (500, -40)]:
        assert np.allclose(f.at(x, y), (g[0, 0], g[0, 1], g[1, 1]), atol=1e-9)
    g11, g12, g22 = f.at(60, 60)
    assert g11 * g22 - g12 ** 2 == pytest.approx(1.0, abs=1e-9)
    # The axes' ratio of the ellipse a circle on the plane becomes: √ of the metric's
    # eigenvalues' ratio.
    lam = np.linalg.eigvalsh(g)
    assert f.most_stretched == pytest.approx(math.sqrt(lam[1] / lam[0]), rel=1e-9)


def test_between_nodes_the_metric_of_a_perspective_map_is_its_own_within_1e_4():
    h = np.array([[0.1, 0.01, -5.0], [0.0, 0.09, -3.0], [2e-4, 1e-4, 1.0]])
    f = foreshortening_of(_homography(h), (960, 540))
    exact = foreshortening_of(_homography(h), (960, 540), step_px=1.0)
    for x, y in [(123.4, 456.7), (800.5, 20.25), (480.0, 270.0)]:
        assert np.allclose(f.at(x, y), exact.at(round(x), round(y)), atol=2e-3)
        assert np.allclose(f.at(x, y), exact.at(x, y), atol=1e-4)
    assert f.most_stretched > 1.05  # the test's map is well off square


def test_a_map_that_folds_the_frame_is_refused():
    # The plane's y runs through 0 at image row 50: flattened there.
    with pytest.raises(ValueError, match="folds or flattens"):
        foreshortening_of(lambda x, y: (0.1 * np.asarray(x, float),
                                        1e-3 * (np.asarray(y, float) - 50.0) ** 2), (100, 100))


def _drawn_disc(a: np.ndarray, centre_px: tuple[float, float], radius_mm: float,
                size: int = 48, blur_px: float = 0.6) -> np.ndarray:
    """Coverage of a disc of ``radius_mm`` on the plane, centred where image px
    ``centre_px`` lands, seen through the affine map ``a``: each pixel the fraction of
    its 8×8 sample points inside, then blurred by a Gaussian of ``blur_px``."""
    k = 8
    off = (np.arange(k) + 0.5) / k - 0.5
    yy, xx = np.mgrid[0:size, 0:size].astype(float)
    inside = np.zeros((size, size))
    for dy in off:
        for dx in off:
            u = (xx + dx - centre_px[0], yy + dy - centre_px[1])
            pu = a[0, 0] * u[0] + a[0, 1] * u[1]
            pv = a[1, 0] * u[0] + a[1, 1] * u[1]
            inside += (pu * pu + pv * pv <= radius_mm ** 2)
    inside /= k * k
    taps = np.arange(-4, 5)
    kern = np.exp(-0.5 * (taps / blur_px) ** 2)
    kern /= kern.sum()
    out = np.apply_along_axis(lambda r: np.convolve(r, kern, "same"), 1, inside)
    return np.apply_along_axis(lambda c: np.convolve(c, kern, "same"), 0, out)


@pytest.mark.parametrize("squash", [0.82, 0.7])
def test_a_foreshortened_disc_is_fitted_as_its_ellipse(squash):
    # A camera pitched about a tilted axis: one image direction shortened to `squash`
    # of the other (cos 35° ≈ 0.82), 0.1 mm per px, discs of 1.5 mm (15 px).
    turn = math.radians(25.0)
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    a = 0.1 * rot @ np.diag([1.0, 1.0 / squash]) @ rot.T  # mm per px
    centre = (23.37, 24.81)
    alpha = _drawn_disc(a, centre, 1.5)
    f = foreshortening_of(_affine(a), (48, 48))
    guess = (centre[0] + 0.6, centre[1] - 0.4)
    round_fit = fit_disc(alpha, 0, 0, guess, 13.0)
    ellipse = fit_disc(alpha, 0, 0, guess, 13.0, stretch=f.at(*centre))
    assert ellipse.ok
    assert math.hypot(ellipse.x - centre[0], ellipse.y - centre[1]) < 0.01
    # The edge is the drawn blur (0.6 px, with a pixel's averaging 0.67) along the
    # metric; a circle takes the rim's misfit for blur.
    assert ellipse.params[3] == pytest.approx(math.hypot(0.6, 1 / math.sqrt(12)), abs=0.12)
    assert round_fit.params[3] > ellipse.params[3] + 0.4
    # Its radius is the circle of the same area: 1.5 mm over √|det a|.
    assert ellipse.params[2] == pytest.approx(1.5 / math.sqrt(abs(np.linalg.det(a))), rel=0.01)
    assert ellipse.rms_residual < 0.3 * round_fit.rms_residual


def test_the_round_metric_leaves_the_disc_fit_as_it_was_to_the_last_bit():
    a = 0.1 * np.eye(2)
    alpha = _drawn_disc(a, (20.3, 21.7), 1.2)
    plain = fit_disc(alpha, 0, 0, (20.0, 22.0), 12.0)
    given = fit_disc(alpha, 0, 0, (20.0, 22.0), 12.0, stretch=(1.0, 0.0, 1.0))
    assert plain == given


def _plane_file(path, homography: np.ndarray, size: tuple[int, int]):
    from cranktrack.calibration.file import save_calibration
    from cranktrack.calibration.plane import PlaneCalibration

    return save_calibration(path, PlaneCalibration("points", homography, size))


def test_a_calibration_that_folds_the_frame_is_one_sentence_before_any_folder(
        small_h264, tmp_path, capsys):
    from cranktrack.cli import main

    # Its horizon (w = 0) runs across the frame's row 120: no camera sees a plane so.
    h = np.array([[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.01, -1.2]])
    cal = _plane_file(tmp_path / "plane.json", h, (320, 240))
    assert main(["track", str(small_h264.video), "--out", str(tmp_path / "run"),
                 "--calibration", str(cal)]) == 1
    err = capsys.readouterr().err
    assert "folds or flattens" in err and err.count("\n") == 1
    assert not (tmp_path / "run").exists()


def test_a_run_with_a_perspective_calibration_says_how_stretched_its_discs_are(
        small_h264, tmp_path):
    import json

    from cranktrack.pipeline import track_run

    # A homography whose scale grows by 10 % along x over the 320 px frame: discs on
    # the right are seen squashed along x against those on the left.
    w = 0.1 / 320
    h = np.array([[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [w, 0.0, 1.0]])
    from cranktrack.calibration.file import load_calibration

    cal = load_calibration(_plane_file(tmp_path / "plane.json", h, (320, 240)), (320, 240))
    track_run(small_h264.video, tmp_path / "run", calibration=cal)
    said = json.loads((tmp_path / "run" / "run.json").read_text())["tracking"]
    # x' = 0.2x/D, y' = 0.2y/D with D = 1 + wx: J = 0.2/D²·[[1, 0], [−wy, D]], whose
    # singular values' ratio is the ellipse's axes' (largest at a right-hand corner).
    ratios = []
    for x in (0.0, 319.0):
        for y in (0.0, 239.0):
            sv = np.linalg.svd(np.array([[1.0, 0.0], [-w * y, 1 + w * x]]), compute_uv=False)
            ratios.append(sv[0] / sv[1])
    assert said["discs_as_ellipses_up_to"] == pytest.approx(max(ratios), abs=2e-4)
    flat = load_calibration(_plane_file(tmp_path / "flat.json", np.diag([0.2, 0.2, 1.0]),
                                        (320, 240)), (320, 240))
    track_run(small_h264.video, tmp_path / "flat", calibration=flat)
    said = json.loads((tmp_path / "flat" / "run.json").read_text())["tracking"]
    assert said["discs_as_ellipses_up_to"] == pytest.approx(1.0, abs=1e-9)


def test_the_luminance_edge_of_a_foreshortened_disc_is_fitted_along_its_ellipse():
    # Full-colour pixels: a red disc on a grey board, the disc seen 35° from square;
    # the luminance edge refit (edges.fit_edges) starts from the chroma fit.
    from cranktrack.tracker.edges import fit_edges

    squash = 0.82
    turn = math.radians(-40.0)
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    a = 0.1 * rot @ np.diag([1.0, 1.0 / squash]) @ rot.T
    centre = (24.61, 23.28)
    cover = _drawn_disc(a, centre, 1.0)  # 10 px
    board, red = np.array([120.0, 120.0, 120.0]), np.array([200.0, 40.0, 40.0])
    rgb = (board + cover[..., None] * (red - board)).round().clip(0, 255).astype(np.uint8)
    stretch = foreshortening_of(_affine(a), (48, 48)).at(*centre)
    guess = (centre[0] - 0.3, centre[1] + 0.5)
    chroma = fit_disc(cover, 0, 0, guess, 9.0, stretch=stretch)
    ellipse = fit_edges(rgb, cover, 0, 0, chroma, 9.0, stretch=stretch)
    circle = fit_edges(rgb, cover, 0, 0, fit_disc(cover, 0, 0, guess, 9.0), 9.0)
    # Given the round edge, the same chroma fit is pulled 0.3 px off (0.4 px from the
    # round chroma fit): the sectors' edges are taken where a circle's would be.
    round_edges = fit_edges(rgb, cover, 0, 0, chroma, 9.0)
    assert ellipse is not None
    assert math.hypot(ellipse.x - centre[0], ellipse.y - centre[1]) < 0.02
    for off in (round_edges, circle):
        assert off is None or math.hypot(off.x - centre[0], off.y - centre[1]) > 0.1
    # Its σ is the scatter the 8-bit rounding leaves, not a circle's misfit.
    assert ellipse.sigma < 0.01
    assert circle is None or circle.sigma > 5 * ellipse.sigma
