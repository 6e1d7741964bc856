"""The circle through a ball's rim (tracker/outline.py) on coverages drawn here.

A cap is a disc whose part above a chord is hidden: the coloured lower half of a
capsule, or a ball behind an edge. The drawing (16 sub-samples a pixel, a Gaussian
blur, normal noise) is the truth and shares no code with the fit.
"""

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from cranktrack.tracker.outline import HOLD_BAND, fit_outline

CENTRE = (50.3, 45.7)
RADIUS = 20.0


def cap(chord: float, seed: int, size: int = 100, sub: int = 4) -> np.ndarray:
    """Coverage (0–1) of a disc of :data:`RADIUS` at :data:`CENTRE` below the chord
    ``chord`` px above its centre, blurred by 1 px and with noise of 0.04."""
    cx, cy = CENTRE
    yy, xx = (np.mgrid[0:size * sub, 0:size * sub] + 0.5) / sub - 0.5
    inside = ((xx - cx) ** 2 + (yy - cy) ** 2 < RADIUS**2) & (yy > cy - chord)
    alpha = gaussian_filter(inside.reshape(size, sub, size, sub).mean((1, 3)), 1.0)
    return alpha + np.random.default_rng(seed).normal(0.0, 0.04, alpha.shape)


def fits(chord: float, hold: float | None) -> np.ndarray:
    """(x, y, radius) errors (px) and σ (px) of the fits of 20 noise draws of one cap."""
    guess = (CENTRE[0], CENTRE[1] + 0.3 * RADIUS)  # inside the cap, as a blob's centre is
    out = []
    for seed in range(20):
        c = fit_outline(cap(chord, seed), 0, 0, guess, RADIUS, hold=hold)
        assert c.ok
        out.append((c.x - CENTRE[0], c.y - CENTRE[1], c.radius - RADIUS, c.sigma))
    return np.array(out)


@pytest.mark.parametrize("chord", [-0.2 * RADIUS, 0.0, 0.2 * RADIUS])
def test_a_caps_centre_across_its_chord_is_steadier_at_its_learned_radius(chord):
    # On an arc of half a circle or less the fitted radius and the centre across the
    # chord trade off: free, the centre moves with the radius from one draw to the next.
    free, held = fits(chord, None), fits(chord, RADIUS)
    assert held[:, 1].std() < 0.5 * free[:, 1].std(), (free.std(0), held.std(0))
    assert abs(held[:, 1].mean()) < 0.05 and np.abs(held[:, :2]).max() < 0.2
    # Along the chord nothing trades off, and the radius said is the free fit's.
    assert held[:, 0].std() < 1.5 * free[:, 0].std() + 0.01
    np.testing.assert_allclose(held[:, 2], free[:, 2])
    # Its σ claims no more than holding the radius is worth: per axis, it is at least
    # the free circle's distance from the held one.
    apart2 = 0.5 * ((held[:, 0] - free[:, 0]) ** 2 + (held[:, 1] - free[:, 1]) ** 2)
    assert np.all(held[:, 3] ** 2 >= apart2 - 1e-12)


@pytest.mark.parametrize("hold", [RADIUS / (1.05 * HOLD_BAND), 0.9 * RADIUS])
def test_a_radius_that_does_not_fit_the_rim_is_not_held(hold):
    # Beyond HOLD_BAND the ball's size has changed; held 10 % short, a half disc's
    # circle leaves its rim for a circle 10-16 px off (HOLD_SHIFT). The free fit is
    # taken as it is.
    np.testing.assert_array_equal(fits(0.0, hold), fits(0.0, None))
