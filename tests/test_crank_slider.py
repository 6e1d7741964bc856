"""The analytic crank-slider against the thesis, closure identities and finite differences."""

import numpy as np
import pytest

from cranktrack.errors import CranktrackError
from cranktrack.models.crank_slider import (
    CrankSlider,
    Incompatibility,
    KinematicIncompatibilityError,
    SliderState,
    crank_state,
    incompatibility,
    l3_from_theta,
    theta_from_l3,
    vB_via_slider,
)
from cranktrack.models.spool import SpoolDrive

L1, L2, L3_0 = 160.8, 72.4, 105.4  # thesis Table 2.2


def test_table_2_2_starting_angle_is_30_9_degrees():
    # The thesis quotes θ0 ≈ 30.9° for the Table 2.2 bed.
    assert np.degrees(CrankSlider(L1, L2).theta(L3_0)) == pytest.approx(30.9, abs=0.05)


def test_table_2_2_stroke_limit_is_17_mm():
    # Stroke cannot exceed L3_0 − (L1 − L2) = 105.4 − 88.4 = 17 mm (θ reaches 0).
    bed = CrankSlider(L1, L2)
    assert bed.max_stroke(L3_0) == pytest.approx(17.0, abs=1e-9)
    assert bed.theta(L3_0 - 17.0) == pytest.approx(0.0, abs=1e-6)
    with pytest.raises(KinematicIncompatibilityError) as e:
        bed.theta(L3_0 - 17.5)
    assert e.value.kind is Incompatibility.CRANK_TOO_SHORT


def test_right_triangle_limit():
    # 3-4-5 triangle: θ = 90° between legs 3 and 4.
    assert l3_from_theta(np.pi / 2, 3.0, 4.0) == pytest.approx(5.0)
    assert theta_from_l3(5.0, 3.0, 4.0) == pytest.approx(np.pi / 2)


@pytest.mark.parametrize("branch", [1, -1])
def test_closure_round_trip_both_branches(branch):
    rng = np.random.default_rng(3)
    L1_, L2_ = rng.uniform(1, 300, 50), rng.uniform(1, 300, 50)
    theta = branch * rng.uniform(0.01, np.pi - 0.01, 50)
    for a, b, th in zip(L1_, L2_, theta, strict=True):
        L3 = l3_from_theta(th, a, b)
        assert theta_from_l3(L3, a, b, branch) == pytest.approx(th, abs=1e-9)
        # positions close the loop: |AB| = L2, |BC| = L3, |AC| = L1
        bed = CrankSlider(a, b, branch)
        p = bed.positions(th)
        assert np.hypot(*p["B"]) == pytest.approx(b)
        assert np.hypot(*(p["B"] - p["C"])) == pytest.approx(L3)
        assert np.hypot(*p["C"]) == pytest.approx(a)
        assert np.sign(p["B"][1]) == branch


def test_both_incompatibilities_of_fig_2_5_are_named():
    # L1 + L3 < L2: frame plus wire shorter than the crank.
    assert incompatibility(1.0, 10.0, [5.0])[0] is Incompatibility.FRAME_TOO_SHORT
    # L2 + L3 < L1: crank plus wire shorter than the frame.
    assert incompatibility(10.0, 1.0, [5.0])[0] is Incompatibility.CRANK_TOO_SHORT
    assert incompatibility(10.0, 1.0, [12.0])[0] is Incompatibility.WIRE_TOO_LONG
    assert incompatibility(10.0, 1.0, [10.0])[0] is None
    with pytest.raises(KinematicIncompatibilityError, match="shorter than the crank"):
        theta_from_l3([9.0, 3.0], 1.0, 10.0)
    # It is a user-facing error, not a silent NaN.
    with pytest.raises(CranktrackError):
        theta_from_l3(3.0, 1.0, 10.0)


def _smooth_slider(t):
    # A slider motion with non-zero L3'' everywhere, kept inside the closable range.
    L3 = 100.0 + 5.0 * np.sin(1.3 * t) + 2.0 * t
    return SliderState(L3, 5.0 * 1.3 * np.cos(1.3 * t) + 2.0, -5.0 * 1.69 * np.sin(1.3 * t))


def _fd(f, t, h):
    # 6th-order central difference of the first derivative.
    c = np.array([-1, 9, -45, 0, 45, -9, 1]) / 60.0
    return sum(ci * f(t + (k - 3) * h) for k, ci in enumerate(c)) / h


@pytest.mark.parametrize("branch", [1, -1])
def test_analytic_rates_match_high_order_finite_differences(branch):
    bed = CrankSlider(L1, L2, branch)
    t = np.linspace(0.2, 3.0, 40)
    h = 1e-3
    s = crank_state(bed, _smooth_slider(t))

    def omega(tt):
        return crank_state(bed, _smooth_slider(tt)).omega

    def B(tt):
        return crank_state(bed, _smooth_slider(tt)).B

    def vB(tt):
        return crank_state(bed, _smooth_slider(tt)).vB

    # omega and alpha are rates of the internal angle θ (unsigned).
    np.testing.assert_allclose(s.omega, _fd(lambda tt: crank_state(bed, _smooth_slider(tt)).theta,
                                            t, h), rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(s.alpha, _fd(omega, t, h), rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(s.vB, _fd(B, t, h), rtol=1e-7, atol=1e-7)  # eq. 2.2
    np.testing.assert_allclose(s.aB, _fd(vB, t, h), rtol=1e-6, atol=1e-6)  # eq. 2.4


@pytest.mark.parametrize("branch", [1, -1])
def test_eq_2_2_and_eq_2_3_give_the_same_velocity_of_B(branch):
    # Two independent routes: rotation of the crank about A (2.2), and the
    # slider's own rate plus the rotation of the wire about C (2.3).
    bed = CrankSlider(L1, L2, branch)
    slider = _smooth_slider(np.linspace(0, 3, 30))
    s = crank_state(bed, slider)
    np.testing.assert_allclose(vB_via_slider(bed, slider, s.omega3), s.vB, rtol=1e-9, atol=1e-9)


def test_spool_drive_profile():
    d = SpoolDrive(start_s=0.5, stroke_mm=14.0)
    assert d.stop_s == pytest.approx(1.5)
    s = d.slider(np.array([0.0, 0.5, 1.0, 1.5, 2.0]))
    np.testing.assert_allclose(s.L3, [105.4, 105.4, 98.4, 91.4, 91.4])
    # The rate steps at 0.5 s and 1.5 s: there it has no value.
    np.testing.assert_allclose(s.L3_rate, [0, np.nan, -14, np.nan, 0])
    # Contracting the wire closes the crank: ω < 0 while the spool runs.
    st = crank_state(d.bed, d.slider(np.array([1.0])))
    assert st.omega[0] < 0
    with pytest.raises(CranktrackError, match="stroke"):
        SpoolDrive(stroke_mm=17.5)
