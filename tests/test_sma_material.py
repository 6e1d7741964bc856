"""The SMA wire as a material and an actuator (thesis §2.3), and the force maps of §2.4/§2.6."""

import numpy as np
import pytest

from cranktrack.errors import CranktrackError
from cranktrack.models.maps import (
    FORCE_ACTUATORS,
    OK,
    actuator_map,
    default_grid,
    force_actuator,
    rocking_angle_map,
)
from cranktrack.models.sma_material import (
    PRESTRAIN_PCT,
    actuator_curve,
    envelope_stress,
    linear_modulus,
    max_work_map,
    reheat_strain,
    unloaded_strain,
)

WIRE_AREA_MM2 = np.pi * 0.125**2  # the 250 µm wire


def test_envelope_at_100_C_is_eq_2_6_and_cold_isotherm_plateaus_near_100_MPa():
    eps = np.linspace(0.0, 3.2, 17)
    np.testing.assert_allclose(envelope_stress(eps, 100.0), -15.4 * eps**3 + 480 * eps + 21)
    # §2.3.3: detwinned martensite reaches 3.25 % "at the stress level of 100 MPa".
    cold = envelope_stress([1.5, 2.5, PRESTRAIN_PCT], 25.0)
    assert np.all((cold > 90) & (cold < 130)) and np.ptp(cold) < 1.0


def test_hotter_isotherms_carry_more_stress_past_1_2_percent():
    # ∂σ/∂T = 12.5 − 0.03·(480 − 46.2·x²) MPa/°C: positive once x > 1.17 %, and
    # never below −1.9 MPa/°C under it (a property of the fit of eqs. 2.6–2.7).
    T = np.linspace(30.0, 100.0, 30)[:, None]
    high = envelope_stress(np.linspace(1.2, PRESTRAIN_PCT, 30)[None, :], T)
    assert np.all(np.diff(high, axis=0) >= 0)
    low = envelope_stress(np.linspace(0.0, 1.2, 30)[None, :], T)
    assert np.all(np.diff(low, axis=0) >= -1.9 * np.diff(T, axis=0) - 1e-9)
    assert np.all(low >= 0)
    with pytest.raises(CranktrackError):
        unloaded_strain(0.0)


@pytest.mark.parametrize("T_hot", [65.0, 100.0])
def test_actuator_curve_is_the_hot_isotherm_read_from_the_prestrain(T_hot):
    c = actuator_curve(T_hot)
    # The force balance solved spring by spring must land on the isotherm itself.
    np.testing.assert_allclose(c.force_N, WIRE_AREA_MM2 * envelope_stress(
        PRESTRAIN_PCT - c.stroke_pct, T_hot), rtol=1e-9, atol=1e-9)
    # Limits: an infinitely stiff spring blocks (stroke 0), no spring frees it (force 0).
    assert c.stroke_pct[0] == 0 and np.isinf(c.spring[0])
    assert c.force_N[-1] == pytest.approx(0.0, abs=1e-9) and c.spring[-1] == 0
    assert c.free_pct == pytest.approx(PRESTRAIN_PCT - unloaded_strain(T_hot))
    assert np.all(np.diff(c.stroke_pct) > 0) and np.all(np.diff(c.force_N) <= 1e-12)


def test_blocked_force_at_100_C_by_hand():
    # Eq. 2.6's peak at x = √(480/46.2) = 3.2233 %: 1052.50 MPa, +0.1·(3.25 − 3.2233).
    x = np.sqrt(480 / 46.2)
    sigma = -15.4 * x**3 + 480 * x + 21 + 0.1 * (3.25 - x)
    assert actuator_curve(100.0).blocked_N == pytest.approx(sigma * WIRE_AREA_MM2, rel=1e-12)
    assert actuator_curve(100.0).blocked_N == pytest.approx(51.66, abs=0.01)


def test_nonlinear_curve_lies_above_its_linearisation():
    # §2.4.3: "blocking force is always greater in the nonlinear case".
    c = actuator_curve()
    lin = c.linearised()
    assert np.all(c.force_N >= lin.force_N - 1e-9)
    assert lin.work_J_per_m() == pytest.approx(0.5 * c.blocked_N * c.free_pct / 100, rel=1e-12)
    assert c.work_J_per_m() > 1.2 * lin.work_J_per_m()


def test_linear_max_work_analytic_and_trapezoid_agree_and_match_the_closed_form():
    T = np.linspace(25.0, 70.0, 19)
    a = max_work_map(T, T, "linear", "analytic")
    t = max_work_map(T, T, "linear", "trapezoid", n_panels=3)
    np.testing.assert_allclose(t.work_MJ_m3, a.work_MJ_m3, rtol=1e-12, equal_nan=True)
    # ½·E(T_f)·Δε², Δε from the re-heating line (3.2 % over 45 °C), in MJ/m³.
    Ti, Tf = 30.0, 62.5
    de = 3.2 * (Tf - Ti) / 45.0
    E = (0.135 * (Tf - 25.0) + 1.0) / 0.035
    one = max_work_map([Ti], [Tf], "linear", "analytic").work_MJ_m3[0, 0]
    assert one == pytest.approx(0.5 * E * de**2 / 100.0, rel=1e-12)
    assert np.isnan(a.work_MJ_m3[np.tril_indices(len(T))]).all()
    # §2.3.6: the most work comes from the largest temperature change.
    for m in (a, max_work_map(T, T, "nonlinear", "trapezoid")):
        assert m.optimum()[1:] == (25.0, 70.0)


def test_reheat_line_and_linear_modulus_endpoints():
    assert reheat_strain([25.0, 70.0]).tolist() == [3.2, 0.0]
    assert linear_modulus(25.0) == pytest.approx(1 / 0.035)


def test_force_map_torque_work_and_rocking_angle():
    ratio, theta0 = np.array([3.0, 12.0, 40.0]), np.array([70.0, 120.0, 170.0])
    free, force = force_actuator("linear")
    m = actuator_map(ratio, theta0, free, force, n_stroke=401)
    Fb = float(force(0.0))
    rock = rocking_angle_map(ratio, theta0, free)
    np.testing.assert_array_equal(m.rocking_deg, rock.rocking_deg)
    r, th = ratio[None, :], np.radians(theta0)[:, None]
    L3_0 = np.sqrt(r**2 + 1 - 2 * r * np.cos(th))
    # A linear actuator's work is the triangle ½·F_b·u_i.
    ok = np.isfinite(m.work_J)
    np.testing.assert_allclose(m.work_J[ok], (0.5 * Fb * free * L3_0)[ok], rtol=1e-9)
    # The moment arm never exceeds the crank, so torque ≤ F_b·L2.
    assert np.nanmax(m.torque_Nm) <= Fb + 1e-9


def test_work_is_the_integral_of_torque_over_the_rocking_angle():
    # A second route to the work: ∫ torque dθ along the stroke (virtual work).
    free, force = force_actuator("sma")
    r, th0 = 8.0, np.radians(140.0)
    m = actuator_map(np.array([r]), np.array([140.0]), free, force)
    s = np.linspace(0.0, 1.0, 20001)
    L3_0 = np.sqrt(r**2 + 1 - 2 * r * np.cos(th0))
    L3 = L3_0 * (1 - free * s)
    theta = np.arccos((r**2 + 1 - L3**2) / (2 * r))
    torque = force(s) * r * np.sin(theta) / L3
    assert m.work_J[0, 0] == pytest.approx(-np.trapezoid(torque, theta), rel=1e-4)


def test_torque_at_a_right_transmission_angle_is_the_blocked_force():
    free, force = force_actuator("sma")
    r = 10.0
    th0 = np.degrees(np.arccos(1.0 / r))  # L3 ⟂ crank at the start: moment arm = L2
    m = actuator_map(np.array([r]), np.array([th0]), free, force, n_stroke=2001)
    assert m.torque_Nm[0, 0] == pytest.approx(float(force(0.0)), rel=1e-4)


def test_force_maps_are_vectorised_over_the_thesis_grid():
    ratio, theta0 = default_grid(200)
    for name in FORCE_ACTUATORS:
        m = actuator_map(ratio, theta0, *force_actuator(name))
        assert m.work_J.shape == (200, 200)
        np.testing.assert_array_equal(np.isfinite(m.work_J), m.reason == OK)
        assert np.isfinite(m.torque_Nm).sum() > 5000
    with pytest.raises(ValueError):
        force_actuator("rigid")


def test_sweep_cli_torque_and_work(tmp_path, capsys):
    from cranktrack.cli import main

    assert main(["sweep", "work", "--actuator", "sma", "--n", "40", "--out", str(tmp_path)]) == 0
    import pandas as pd

    table = pd.read_csv(tmp_path / "work_sma.csv")
    assert {"rocking_deg", "torque_Nm", "work_J", "incompatibility"} <= set(table.columns)
    assert (tmp_path / "work_sma.png").exists()
    assert "max work" in capsys.readouterr().out
    assert main(["sweep", "torque", "--actuator", "rigid", "--out", str(tmp_path)]) == 1
    assert "no force curve" in capsys.readouterr().err


def test_sweep_cli_actuator_curve_and_max_work(tmp_path, capsys):
    import pandas as pd

    from cranktrack.cli import main

    assert main(["sweep", "actuator-curve", "--out", str(tmp_path)]) == 0
    curve = pd.read_csv(tmp_path / "actuator_curve.csv")
    assert curve["force_N"].iloc[0] == pytest.approx(curve["linear_force_N"].iloc[0])
    assert curve["force_N"].iloc[-1] == pytest.approx(0.0, abs=1e-9)
    assert main(["sweep", "max-work", "--envelope", "linear", "--n", "10",
                 "--out", str(tmp_path)]) == 0
    table = pd.read_csv(tmp_path / "max_work_linear.csv")
    assert len(table) == 100 and table["work_MJ_m3"].notna().sum() == 45
    assert (tmp_path / "max_work_linear_per_K.png").exists()
    assert "T_i = 25.0 °C, T_f = 70.0 °C" in capsys.readouterr().out
