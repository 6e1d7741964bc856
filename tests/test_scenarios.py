"""Scenarios driven by the models: the free response of chapter 3 and the SMA bed of §2.5.3."""

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import brentq

from cranktrack.models.heat import CurrentSteps
from cranktrack.models.sma_bed import TABLE_2_3, SMABed, simulate_bed
from cranktrack.pipeline import track_run
from cranktrack.synthetic.scenarios import FreeScenario, SMAScenario
from cranktrack.synthetic.scene import RenderSettings, render_scene


def test_free_response_truth_is_consistent():
    sc = FreeScenario()
    t = np.linspace(0.1, 3.9, 200)
    m = sc.motion(t)
    h = 1e-5
    fd = (sc.motion(t + h).theta - sc.motion(t - h).theta) / (2 * h)
    np.testing.assert_allclose(m.omega, fd, rtol=1e-5, atol=1e-6)
    # B stays on the crank circle and the wire length is |BC|.
    np.testing.assert_allclose(np.hypot(*m.points_mm["B"].T), 72.4)
    np.testing.assert_allclose(m.L3_mm, np.hypot(*(m.points_mm["B"] - m.points_mm["C"]).T))
    # Damped: the energy only falls.
    e = sc.dynamics.energy(m.theta, m.omega)
    assert np.all(np.diff(e) < 0)
    # Asking frame by frame gives the same as asking all at once.
    one = np.array([sc.motion(np.array([x])).theta[0] for x in t[:5]])
    np.testing.assert_allclose(one, m.theta[:5], rtol=0, atol=1e-9)


def test_free_response_renders_and_tracks(tmp_path):
    files = render_scene(FreeScenario(), tmp_path / "scene",
                         RenderSettings(size=(640, 360), seconds=2.0, noise_dn=2.5, seed=3))
    truth = pd.read_csv(files.truth)
    assert truth["theta_deg"].iloc[0] == pytest.approx(70.0)
    assert truth["theta_deg"].max() > 90.0  # it swings past the bias spring's rest angle
    run = track_run(files.video, tmp_path / "run", ("A", "C", 160.8))
    err = run.kinematics["theta_deg"] - truth["theta_deg"]
    # 640×360: the crank is 230 px long; 0.1 px on each end is 0.05°.
    assert np.sqrt(np.mean(err**2)) < 0.1


def test_sma_bed_reproduces_table_2_3():
    bed = SMABed()
    t = np.arange(0, 6, 1 / 30)
    m = simulate_bed(bed, CurrentSteps((0.5, 3.0), (1.3, 0.0)), t)
    theta = np.degrees(m.theta)
    assert theta[0] == pytest.approx(TABLE_2_3["theta0_deg"], abs=1e-9)
    assert np.all(np.abs(theta[t < 0.5] - 125.0) < 1e-6)  # held by the preload until heated
    # Table 2.3: from 125° to 98° (Δθ 27° measured, 25° in the thesis's theory).
    assert theta.min() == pytest.approx(TABLE_2_3["thetaf_deg"], abs=2.0)
    assert m.xi[np.argmin(theta)] == pytest.approx(0.0, abs=1e-6)  # 1.3 A passes A_f
    # The final angle is where the bias spring's torque meets the austenite wire's.
    def torque(th):
        arm = bed.moment_arm_m(np.array(th))
        return bed.bias_k_Nm_rad * (bed.bias_rest_rad - th) - float(
            bed.wire_force_N(np.array(th), np.array(0.0)) * arm)
    static = np.degrees(brentq(torque, np.radians(60), np.radians(124)))
    assert theta.min() == pytest.approx(static, abs=0.01)
    # Cooled below M_f, the wire is martensite again and the spring brings the crank back.
    assert theta[-1] == pytest.approx(125.0, abs=0.01)
    assert np.all(np.diff(m.T_C[(t > 0.5) & (t < 3.0)]) >= -1e-9)


def test_sma_scenario_renders_and_tracks(tmp_path):
    sc = SMAScenario()
    files = render_scene(sc, tmp_path / "scene",
                         RenderSettings(size=(640, 360), seconds=4.0, noise_dn=2.5, seed=1))
    truth = pd.read_csv(files.truth)
    # Asking frame by frame (as the renderer does) gives the dense solution's values.
    assert truth["theta_deg"].min() == pytest.approx(97.52, abs=0.05)
    run = track_run(files.video, tmp_path / "run", ("A", "C", 305.0))
    err = run.kinematics["theta_deg"] - truth["theta_deg"]
    # 640×360: the crank is only 39 px long (L2 = 24.1 mm); 0.05 px at B is 0.07°.
    assert np.sqrt(np.mean(err**2)) < 0.15
    assert run.kinematics["theta_deg"].min() == pytest.approx(truth["theta_deg"].min(), abs=0.3)


def test_the_fits_quasi_static_sma_bed_follows_the_equation_of_motion():
    from cranktrack.loop.simulate import sma_theta

    bed = SMABed()
    t = np.arange(0, 5, 1 / 30)
    full = simulate_bed(bed, CurrentSteps((0.5, 3.0), (1.3, 0.0)), t)
    w = bed.thermal
    fast = sma_theta({"current_A": 1.3, "current_on_s": 0.5, "current_off_s": 3.0,
                      "ambient_C": w.T_amb_C, "L1_mm": bed.L1, "L2_mm": bed.L2,
                      "theta0_deg": bed.theta0_deg, "recovery_strain": bed.recovery_strain,
                      "h_W_m2K": w.h_W_m2K, "As_C": w.As_C, "Af_C": w.Af_C, "Ms_C": w.Ms_C,
                      "Mf_C": w.Mf_C}, t)
    # Inertia left out, the damper to first order: well under the tracker's 0.07° here.
    assert np.degrees(np.max(np.abs(fast - full.theta))) < 0.05


def test_thermal_lag_delays_the_crank_but_not_where_it_ends():
    t = np.arange(0, 5, 1 / 100)
    plain = SMAScenario().motion(t)
    lag = SMAScenario(bed=SMABed(thermal_lag_s=0.2)).motion(t)
    def halfway(m):
        th = np.degrees(m.theta)
        return t[np.argmax(th < 0.5 * (th[0] + th.min()))]
    assert 0.1 < halfway(lag) - halfway(plain) < 0.3  # about one time constant later
    assert np.degrees(lag.theta[t < 3].min()) == pytest.approx(
        np.degrees(plain.theta[t < 3].min()), abs=0.05)


def test_extra_pivot_damping_delays_the_crank_but_not_where_it_settles(tmp_path):
    t = np.arange(0, 6, 1 / 100)
    plain = SMAScenario().motion(t)
    bed = SMABed()
    damped = SMAScenario(bed=SMABed(damping_Nms_rad=bed.damping_Nms_rad + 0.05)).motion(t)
    # Heating pulls θ down, cooling lets it back up: the damped crank is behind both ways.
    heating, cooling = (t > 0.5) & (t < 2.5), (t > 3.0)
    lag = np.degrees(damped.theta - plain.theta)
    assert np.all(lag[heating] >= -1e-6) and np.all(lag[cooling] <= 1e-6)
    assert np.max(np.abs(lag)) > 0.5
    hot = (t > 2.5) & (t < 3.0)
    np.testing.assert_allclose(np.degrees(damped.theta[hot]), np.degrees(plain.theta[hot]),
                               atol=0.01)
    assert np.degrees(damped.theta[-1]) == pytest.approx(125.0, abs=0.01)
    from cranktrack.errors import CranktrackError
    with pytest.raises(CranktrackError, match="sma scenario"):
        render_scene(FreeScenario(), tmp_path / "x", RenderSettings(size=(64, 36), seconds=0.1),
                     effects={"damping_Nms_rad": 0.05})
