"""A printed disc seen at a slant, without a calibration: its ellipse is learned while it
stands still (tracker/ellipse.py). The truth is drawn here: each pixel coloured by the
fraction of an ellipse written in this file that covers it (8×8 sub-samples), sharing
no code with the tracker's model."""

import math

import cv2
import numpy as np
import pytest

from cranktrack.tracker.ellipse import SHAPE_FRAMES, axis_ratio, long_axis_deg, settled_metric
from cranktrack.tracker.markers import DEFAULT_MARKERS
from cranktrack.tracker.track import track
from cranktrack.tracker.video import open_frames

#: The crank-slider's three printed discs: centre (px), colour.
DISCS = [((60.3, 92.6), (40.0, 170.0, 70.0)), ((110.7, 58.2), (200.0, 40.0, 45.0)),
         ((190.4, 95.1), (40.0, 70.0, 200.0))]


def draw_ellipses(long_px: float, ratio: float, angle_deg: float, seed: int,
                  size=(240, 180)) -> np.ndarray:
    """RGB uint8: :data:`DISCS` as ellipses of semi-axes ``long_px`` and
    ``ratio · long_px``, the longer at ``angle_deg`` from +x toward +y, on a pale board,
    with 1.5 DN of noise."""
    w, h = size
    sub = 8
    y, x = (np.mgrid[0:h * sub, 0:w * sub] + 0.5) / sub - 0.5
    image = np.zeros((h, w, 3)) + np.array((200.0, 190.0, 170.0))
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    for (cx, cy), rgb in DISCS:
        along = (x - cx) * c + (y - cy) * s
        across = -(x - cx) * s + (y - cy) * c
        inside = (along / long_px) ** 2 + (across / (ratio * long_px)) ** 2 < 1.0
        cover = inside.reshape(h, sub, w, sub).mean((1, 3))
        image += cover[..., None] * (np.array(rgb) - image)
    image += np.random.default_rng(seed).normal(0.0, 1.5, image.shape)
    return np.clip(image.round(), 0, 255).astype(np.uint8)


def standing_clip(folder, ratio: float, angle_deg: float, frames: int = 30):
    folder.mkdir()
    for k in range(frames):
        image = draw_ellipses(10.0, ratio, angle_deg, seed=k)
        cv2.imwrite(str(folder / f"{k:03d}.png"), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    return track(open_frames(folder, 10.0), DEFAULT_MARKERS)


def test_a_slanted_discs_ellipse_is_learned_and_fitted(tmp_path):
    result = standing_clip(tmp_path / "slant", 0.9, 30.0)
    t = result.tracks
    for m, ((x, y), _) in zip("ABC", DISCS, strict=True):
        learned = result.learned[m]
        assert learned["ellipse_axes_ratio"] == pytest.approx(0.9, abs=0.01), learned
        assert learned["ellipse_long_axis_deg"] == pytest.approx(30.0, abs=3.0), learned
        start = learned["ellipse_from_frame"]
        assert start is not None and start < 25
        ok = t[f"{m}_ok"].to_numpy(bool)
        assert ok.all()
        err = np.hypot(t[f"{m}_x_px"] - x, t[f"{m}_y_px"] - y).to_numpy()
        sigma = t[f"{m}_sigma_px"].to_numpy()
        after = t["frame"].to_numpy() >= start
        # Fitted as the ellipse, the centre stays where it was drawn, and the σ no
        # longer carries a circle's misfit to an ellipse.
        assert np.max(err[after]) < 0.05, err[after]
        assert np.median(sigma[after]) < 0.5 * np.median(sigma[~after]), (m, sigma)
    said = [p for p in result.problems if "seen as an ellipse" in p]
    assert len(said) == 3 and "calibrate plane" in said[0], said


def test_round_discs_stay_round(tmp_path):
    result = standing_clip(tmp_path / "square", 1.0, 0.0)
    for m in "ABC":
        assert result.learned[m]["ellipse_axes_ratio"] is None, result.learned[m]
    assert not [p for p in result.problems if "ellipse" in p]


def test_only_a_clear_ellipse_is_settled():
    rng = np.random.default_rng(3)
    assert settled_metric([(0.1, 0.0)] * (SHAPE_FRAMES - 1)) is None  # too few yet
    # Within the noise of round: not taken.
    noisy = [tuple(rng.normal(0.0, 0.01, 2)) for _ in range(SHAPE_FRAMES)]
    assert settled_metric(noisy) is None
    # Round enough whatever the noise: a ratio above 0.96 (u of 0.03 is 0.970).
    assert settled_metric([(0.03, 0.0)] * SHAPE_FRAMES) is None
    # A 0.9 : 1 ellipse, measured a little apart each time.
    e = (1 - 0.9 ** 2) / (1 + 0.9 ** 2)
    u, v = e * math.cos(math.radians(240.0)), e * math.sin(math.radians(240.0))
    got = settled_metric([(u + rng.normal(0, 0.002), v + rng.normal(0, 0.002))
                          for _ in range(SHAPE_FRAMES)])
    assert got is not None
    assert axis_ratio(*got) == pytest.approx(0.9, abs=0.003)
    # The longer axis lies at half the angle of (−u, −v): (240° − 180°) / 2.
    assert long_axis_deg(*got) == pytest.approx(30.0, abs=1.0)


@pytest.mark.parametrize("p", [(30.2, 40.7, 9.0, 0.6, 0.9, 0.05, 0.12, -0.2),
                               (31.0, 39.5, 6.5, 1.8, 1.1, -0.1, -0.4, 0.25),
                               (30.0, 40.0, 12.0, 0.3, 0.8, 0.0, 0.0, 0.0)])
def test_the_ellipse_fits_jacobian_is_its_models_slope(p):
    from scipy.optimize import approx_fprime
    from scipy.special import ndtr

    from cranktrack.tracker.ellipse import ellipse_jacobian, metric_of

    # The second method: differences of the model written out here, by scipy.
    yy, xx = np.mgrid[25:56, 15:46]
    X, Y = xx.ravel().astype(float), yy.ravel().astype(float)

    def model(q: np.ndarray, i: int) -> float:
        g11, g12, g22 = metric_of(q[6], q[7])
        dx, dy = X[i] - q[0], Y[i] - q[1]
        d = math.sqrt(g11 * dx * dx + 2 * g12 * dx * dy + g22 * dy * dy)
        return q[5] + q[4] * ndtr((q[2] - d) / q[3])

    p = np.array(p)
    J = ellipse_jacobian(p, X, Y)
    for i in range(0, len(X), 37):
        numeric = approx_fprime(p, model, 1e-7, i)
        assert np.allclose(J[i], numeric, rtol=1e-4, atol=1e-5), (i, J[i], numeric)
