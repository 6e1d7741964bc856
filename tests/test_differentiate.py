"""The local-polynomial differentiator: exact on polynomials, honest σ, no gap crossing."""

import numpy as np
import pytest

from cranktrack.kinematics.differentiate import local_polynomial, segments


def test_exact_on_a_quadratic_with_uneven_timestamps():
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.02, 0.05, 80))
    y = 2.0 - 3.0 * t + 4.5 * t**2
    d = local_polynomial(t, y, window=7, order=2)
    np.testing.assert_allclose(d.value, y, atol=1e-9)
    np.testing.assert_allclose(d.d1, -3.0 + 9.0 * t, atol=1e-7)
    np.testing.assert_allclose(d.d2, 9.0, atol=1e-6)


def test_sine_derivative_converges():
    t = np.arange(0, 2, 1 / 240)
    d = local_polynomial(t, np.sin(3 * t), window=9, order=3)
    assert np.max(np.abs(d.d1 - 3 * np.cos(3 * t))) < 1e-3


def test_propagated_sigma_matches_monte_carlo():
    # Second method: the spread of estimates over many noise draws.
    rng = np.random.default_rng(1)
    t = np.arange(40) / 30.0
    sigma = 0.01 + 0.02 * rng.random(40)
    draws = np.array([local_polynomial(t, rng.normal(0, sigma), sigma, 7, 2).d1
                      for _ in range(3000)])
    d = local_polynomial(t, np.zeros(40), sigma, 7, 2)
    np.testing.assert_allclose(draws.std(axis=0), d.d1_sigma, rtol=0.06)


def test_gaps_are_not_crossed():
    t = np.arange(40) / 30.0
    y = t.copy()
    y[10] = np.nan  # a missing frame
    y[11:] += 5.0  # a jump hidden in the gap must not leak into either side
    y[30] = y[32] = np.nan  # leaves frame 31 alone, shorter than any window
    d = local_polynomial(t, y, window=5, order=2)
    assert np.isnan(d.d1[[10, 30, 31, 32]]).all()
    np.testing.assert_allclose(d.d1[:10], 1.0, atol=1e-9)
    np.testing.assert_allclose(d.d1[11:30], 1.0, atol=1e-9)
    assert segments(np.isfinite(y)) == [(0, 10), (11, 30), (31, 32), (33, 40)]


def test_bad_window_is_refused():
    with pytest.raises(ValueError):
        local_polynomial(np.arange(10.0), np.arange(10.0), window=4, order=2)
