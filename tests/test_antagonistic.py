"""The antagonistic two-wire mechanism of thesis chapter 5 and its scenario."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from cranktrack.errors import CranktrackError
from cranktrack.models.antagonistic import (
    THESIS_TABLE_MM,
    AntagonisticBed,
    equilibrium_psi,
    rocking_vs_table,
    simulate_antagonistic,
)
from cranktrack.pipeline import track_run
from cranktrack.synthetic.scenarios import AntagonisticScenario
from cranktrack.synthetic.scene import RenderSettings, render_scene


def test_small_turns_lengthen_one_wire_and_shorten_the_other_by_arm_times_psi():
    bed = AntagonisticBed()
    psi = 1e-4
    plus, minus = bed.strains_pct(psi)
    sym, _ = bed.strains_pct(0.0)
    step = 100 * bed.arm_mm * psi / bed.wire_length_mm
    assert plus - sym == pytest.approx(step, rel=1e-3)
    assert sym - minus == pytest.approx(step, rel=1e-3)
    # Table 5 mm out from taut-with-0.2-mm-slack on a 200 mm wire: 2.4 % at rest.
    assert sym == pytest.approx(100 * (5.0 - 0.2) / 200.0)


def test_cold_pair_balances_at_the_symmetric_position():
    bed = AntagonisticBed()
    assert equilibrium_psi(bed, 1.0, 1.0) == pytest.approx(0.0, abs=1e-12)
    # Whichever wire is austenite wins, by the same angle (the mechanism is symmetric).
    a = float(equilibrium_psi(bed, 0.0, 1.0))
    b = float(equilibrium_psi(bed, 1.0, 0.0))
    assert a < -0.1 and b == pytest.approx(-a, rel=1e-9)
    assert float(bed.torque_Nm(a, 0.0, 1.0)) == pytest.approx(0.0, abs=1e-9)


def test_heating_each_wire_in_turn_swings_the_rocker_both_ways():
    bed = AntagonisticBed()
    t = np.arange(0.0, 5.0, 0.01)
    m = simulate_antagonistic(bed, t)
    theta = np.degrees(m.theta)
    assert theta[0] == pytest.approx(bed.rest_deg, abs=1e-9)
    first = (t > bed.on_s[0]) & (t < bed.off_s[0])
    second = (t > bed.on_s[1]) & (t < bed.off_s[1])
    assert theta[first].min() < bed.rest_deg - 10 and theta[second].max() > bed.rest_deg + 10
    # At the end of a heating the hot wire is austenite and the rocker sits at the
    # quasi-static balance of the two wires.
    i = np.searchsorted(t, bed.off_s[0]) - 1
    assert m.xi_plus[i] == pytest.approx(0.0, abs=1e-6)
    static = float(equilibrium_psi(bed, m.xi_plus[i], m.xi_minus[i]))
    assert np.degrees(m.psi[i] - static) == pytest.approx(0.0, abs=0.05)


def test_rocking_angle_against_pre_stress_rises_then_falls():
    # Thesis Fig. 5.7: slack at low pre-stress costs angle, high pre-stress blocks it.
    swing = rocking_vs_table(AntagonisticBed(), THESIS_TABLE_MM)
    peak = int(np.argmax(swing))
    assert 0 < peak < len(swing) - 1
    assert swing[0] < 0.5 * swing[peak] and swing[-1] < 0.5 * swing[peak]
    assert np.all(np.diff(swing[:peak + 1]) > 0) and np.all(np.diff(swing[peak:]) < 0)


def test_a_wire_too_slack_to_pull_leaves_the_rocker_still():
    # The austenite wire shortens by only 0.15 % (0.3 mm of 200 mm): with 1 mm of
    # slack neither wire ever pulls.
    bed = AntagonisticBed(slack_mm=1.0, table_mm=0.0)
    m = simulate_antagonistic(bed, np.arange(0.0, 5.0, 0.01))
    assert np.max(np.abs(m.psi)) < 1e-9


def test_bad_schedule_is_a_clear_error():
    with pytest.raises(CranktrackError, match="one after the other"):
        AntagonisticBed(on_s=(0.5, 1.0), off_s=(2.0, 3.0))


def test_scenario_truth_and_drawing_agree_with_the_model():
    sc = AntagonisticScenario()
    t = np.linspace(0.2, 4.8, 120)
    m = sc.motion(t)
    h = 1e-4
    fd = (sc.motion(t + h).theta - sc.motion(t - h).theta) / (2 * h)
    np.testing.assert_allclose(m.omega, fd, atol=2e-3)
    # The drawn wires are as long as the model's strains say.
    psi = m.theta - np.radians(sc.bed.rest_deg)
    plus, minus = sc.bed.strains_pct(psi)
    for (p, q), strain in zip(m.wires_mm, (plus, minus), strict=True):
        np.testing.assert_allclose(np.hypot(*(q - p).T),
                                   sc.bed.wire_length_mm * (1 + strain / 100), rtol=1e-12)


def test_antagonistic_scenario_renders_and_tracks(tmp_path):
    sc = AntagonisticScenario(replace(AntagonisticBed(), on_s=(0.2, 1.6), off_s=(1.4, 2.8)))
    files = render_scene(sc, tmp_path / "scene",
                         RenderSettings(size=(640, 360), seconds=3.0, noise_dn=2.5, seed=2))
    truth = pd.read_csv(files.truth)
    assert np.ptp(truth["theta_deg"]) > 30
    run = track_run(files.video, tmp_path / "run", ("A", "C", sc.bed.anchor_mm))
    err = run.kinematics["theta_deg"] - truth["theta_deg"]
    # 640×360: the 40 mm rocker arm is about 100 px long; 0.05 px at B is 0.03°.
    assert np.sqrt(np.mean(err**2)) < 0.1
