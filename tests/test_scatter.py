"""The scatter floor under a centre's σ, on tracks whose noise is drawn here."""

import numpy as np
import pytest

from cranktrack.tracker.scatter import scatter_sigma, with_scatter_floor


@pytest.mark.parametrize("noise", [0.03, 0.5])
def test_scatter_reads_the_noise_under_fast_smooth_motion(noise):
    # B on a crank turning at 1 Hz, r = 100 px, at 30 fps: second differences of
    # the motion alone are 4.4 px, so only a higher order can see 0.03 px of noise.
    rng = np.random.default_rng(3)
    t = np.arange(600) / 30.0
    xy = np.c_[320 + 100 * np.cos(2 * np.pi * t), 240 + 100 * np.sin(2 * np.pi * t)]
    s = scatter_sigma(xy + rng.normal(0, noise, xy.shape))
    assert 0.8 * noise < np.median(s) < 1.25 * noise


def test_a_gap_is_not_differenced_across():
    rng = np.random.default_rng(4)
    xy = rng.normal(0, 0.1, (200, 2))
    xy[100:] += 50.0  # a jump hidden in a gap must not read as scatter
    xy[98:102] = np.nan
    s = scatter_sigma(xy)
    assert np.nanmax(s) < 0.2


def test_the_floor_raises_an_overconfident_sigma_and_never_lowers_one():
    rng = np.random.default_rng(5)
    xy = np.c_[np.linspace(0, 300, 120), np.full(120, 80.0)] + rng.normal(0, 0.4, (120, 2))
    raised = with_scatter_floor(np.full(120, 0.01), xy)
    kept = with_scatter_floor(np.full(120, 2.0), xy)
    assert 0.3 < np.median(raised) < 0.5
    assert np.all(kept == 2.0)
    # ±1σ now holds about 68 % of the true errors, as a 1σ should.
    err = np.abs(xy - np.c_[np.linspace(0, 300, 120), np.full(120, 80.0)])
    assert 0.5 < np.mean(err <= raised[:, None]) < 0.85
