"""Scenarios driven by the models: the free response of chapter 3."""

import numpy as np
import pandas as pd
import pytest

from cranktrack.pipeline import track_run
from cranktrack.synthetic.scenarios import FreeScenario
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
