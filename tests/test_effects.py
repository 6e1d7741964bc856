"""Each effect shows in the truth or the video the way its documentation says."""

import json
import re

import numpy as np
import pandas as pd
import pytest

from cranktrack.cli import parse_effects
from cranktrack.errors import CranktrackError
from cranktrack.models.crank_slider import CrankSlider
from cranktrack.synthetic.effects import EFFECTS, EffectedSpool
from cranktrack.synthetic.scenarios import SpoolScenario
from cranktrack.synthetic.scene import RenderSettings, render_scene, scenario_camera
from cranktrack.tracker.track import track
from cranktrack.tracker.video import open_frames

BED = CrankSlider(160.8, 72.4)
T = np.linspace(0, 3, 3001)


def test_every_effect_is_documented_in_one_sentence():
    for name, info in EFFECTS.items():
        assert info.kind in ("physical", "recording", "camera"), name
        # One sentence: no sentence break (a stop, then a capital) inside it.
        assert not re.search(r"[.;:!?]\s+[A-Z]", info.shows_as), name
        assert len(info.shows_as) > 30, name


def test_slack_delays_the_start_and_shrinks_the_rocking_angle():
    m = EffectedSpool(SpoolScenario(), {"slack_mm": 2.8}).motion(T)
    moved = T[np.abs(m.theta - m.theta[0]) > 1e-9]
    assert moved[0] == pytest.approx(0.5 + 2.8 / 14.0, abs=0.002)  # start + slack/speed
    rocking = np.degrees(m.theta[0] - m.theta[-1])
    expected = np.degrees(BED.theta(105.4) - BED.theta(105.4 - (15.0 - 2.8)))
    assert rocking == pytest.approx(expected, abs=1e-6)


def test_a_servo_stall_holds_the_crank_halfway_then_finishes_the_stroke_that_much_later():
    base = SpoolScenario().motion(T)
    m = EffectedSpool(SpoolScenario(), {"servo_stall_s": 0.2}).motion(T)
    mid = 0.5 + 0.5 * 15.0 / 14.0  # halfway through the 15 mm stroke at 14 mm/s
    held = (T > mid + 0.002) & (T < mid + 0.198)
    assert np.ptp(m.theta[held]) < 1e-12
    assert m.theta[held][0] == pytest.approx(float(np.interp(mid, T, base.theta)), abs=1e-6)
    late = (T > mid + 0.25) & (T < 1.5)  # after the stall: the plain stroke 0.2 s later
    np.testing.assert_allclose(m.theta[late], np.interp(T[late] - 0.2, T, base.theta),
                               atol=1e-5)
    assert m.theta[-1] == pytest.approx(base.theta[-1], abs=1e-9)  # the whole stroke


def test_spool_growth_ends_the_stroke_sooner_with_a_faster_crank():
    g = 0.3
    base = SpoolScenario().motion(T)
    m = EffectedSpool(SpoolScenario(), {"spool_growth_per_s": g}).motion(T)
    # 15 mm wound at 14·(1 + g·τ) mm/s: 14·(τ + gτ²/2) = 15.
    tau = (-1 + np.sqrt(1 + 2 * g * 15 / 14)) / g
    still = T[(T > 0.5) & (m.omega == 0)]
    assert still[0] == pytest.approx(0.5 + tau, abs=0.002)
    mid = np.searchsorted(T, 1.0)
    assert abs(m.omega[mid]) > abs(base.omega[mid])
    assert m.theta[-1] == pytest.approx(base.theta[-1], abs=1e-9)  # same stroke in the end


def test_return_spring_rings_at_its_frequency_about_the_final_angle():
    f, zeta = 3.0, 0.05
    m = EffectedSpool(SpoolScenario(), {"return_spring_hz": f, "return_spring_zeta": zeta}
                      ).motion(T)
    base = SpoolScenario().motion(T)
    after = T > 0.5 + 15 / 14 + 1e-6
    x = m.theta[after] - base.theta[-1]
    crossings = T[after][1:][np.sign(x[1:]) != np.sign(x[:-1])]
    fd = f * np.sqrt(1 - zeta**2)
    assert 2 * np.mean(np.diff(crossings)) == pytest.approx(1 / fd, rel=0.01)
    # ω is continuous at the stop: the crank does not stop dead.
    i = np.argmax(after)
    assert m.omega[i] == pytest.approx(m.omega[i - 1], rel=0.05)
    # and ω really is the derivative of θ there.
    np.testing.assert_allclose(np.gradient(m.theta, T)[after][5:-5], m.omega[after][5:-5],
                               rtol=0.02, atol=2e-3)


@pytest.mark.parametrize("k1, k2", [(-0.2, 0.0), (0.0, 0.3)])
def test_lens_k1_k2_move_an_off_centre_marker_by_the_radial_formula(k1, k2):
    sc = SpoolScenario()
    plain = scenario_camera(sc, (640, 360), pinhole=True)
    bent = scenario_camera(sc, (640, 360), k1=k1, k2=k2)
    p = np.array([[0.0, 0.0], [160.8, 0.0]])  # A and C, far from the centre
    u, d = plain.ideal_project(p), bent.project(p)
    K = bent.camera_matrix
    xn = (u - K[:2, 2]) / K[0, 0]
    r2 = (xn**2).sum(axis=1, keepdims=True)
    expected = K[:2, 2] + K[0, 0] * xn * (1 + k1 * r2 + k2 * r2**2)
    np.testing.assert_allclose(d, expected, atol=1e-6)
    assert np.all(np.hypot(*(d - u).T) > 1)  # pixels at the image's edge


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    def make(effects, declare=False):
        folder = tmp_path_factory.mktemp("fx")
        return render_scene(SpoolScenario(), folder, RenderSettings(size=(320, 240), seconds=2.0,
                                                                    noise_dn=2.5, seed=5),
                            effects=effects, declare_effects=declare)
    return make


def test_dropped_frames_are_gaps_in_the_timestamps(small):
    files = small({"dropped_frames": 0.2})
    truth = pd.read_csv(files.truth)
    assert 35 < len(truth) < 58
    result = track(open_frames(files.video))
    assert len(result.tracks) == len(truth)
    dropped = 60 - len(truth)  # drops at the very end leave no gap to see
    assert result.timing["gaps"] > 0
    assert 1 <= result.timing["dropped_frames_estimate"] <= dropped
    np.testing.assert_allclose(result.tracks["t_s"], truth["t_s"], atol=1e-4)


def test_a_wrong_frame_rate_label_scales_the_measured_times(small):
    files = small({"fps_label": 25.0})
    truth = pd.read_csv(files.truth)
    result = track(open_frames(files.video))
    np.testing.assert_allclose(result.tracks["t_s"], truth["t_s"] * 30.0 / 25.0, atol=1e-4)


def test_effects_are_in_scene_json_only_when_declared(small):
    hidden = json.loads(small({"slack_mm": 1.0}).scene.read_text())
    shown = json.loads(small({"slack_mm": 1.0}, declare=True).scene.read_text())
    assert hidden["effects"] == "not declared"
    assert shown["effects"] == {"slack_mm": 1.0}


def test_bad_effect_options():
    with pytest.raises(CranktrackError, match="known effect"):
        parse_effects(["wobble=3"])
    with pytest.raises(CranktrackError, match="not a number"):
        parse_effects(["slack_mm=lots"])
    with pytest.raises(CranktrackError, match="needs return_spring_hz"):
        parse_effects(["return_spring_zeta=0.1"])


def test_rolling_shutter_catches_each_marker_when_the_readout_reaches_its_row(tmp_path):
    sc, size, readout = SpoolScenario(), (320, 240), 1 / 30
    settings = RenderSettings(size=size, seconds=1.6, lossless=True, readout_s=readout)
    files = render_scene(sc, tmp_path, settings, effects={"readout_s": readout})
    truth = pd.read_csv(files.truth)  # where the markers are at the frame times
    tracked = track(open_frames(files.video)).tracks
    camera = scenario_camera(sc, size)
    t = truth["t_s"].to_numpy()
    B = sc.motion(t).points_mm["B"]
    late = t + readout * camera.project(B)[:, 1] / size[1]
    expected = camera.project(sc.motion(late).points_mm["B"])
    moving = (t > 0.6) & (t < 1.5)
    got = tracked[["B_x_px", "B_y_px"]].to_numpy()
    at_row = np.hypot(*(got - expected)[moving].T)
    at_frame = np.hypot(*(got - truth[["B_x_px", "B_y_px"]].to_numpy())[moving].T)
    assert np.sqrt(np.mean(at_row**2)) < 0.03
    assert np.sqrt(np.mean(at_frame**2)) > 5 * np.sqrt(np.mean(at_row**2))


def test_pivot_motion_moves_the_frame_but_not_the_crank_angle(tmp_path):
    amp = 1.5
    files = render_scene(SpoolScenario(), tmp_path, RenderSettings(size=(320, 240), seconds=2.0,
                                                                   noise_dn=2.5, seed=2),
                         effects={"pivot_amp_mm": amp, "pivot_hz": 2.0})
    truth = pd.read_csv(files.truth)
    plain = SpoolScenario().motion(truth["t_s"].to_numpy())
    np.testing.assert_allclose(np.radians(truth["theta_deg"]), plain.theta, atol=1e-12)
    # A shakes with the set amplitude (std of a sine: amp/√2) …
    assert truth["A_y_mm"].std() == pytest.approx(amp / np.sqrt(2), rel=0.1)
    # … and the tracker sees the crank angle unchanged, computed from the three points.
    from cranktrack.pipeline import track_run

    run = track_run(files.video, tmp_path / "run", ("A", "C", 160.8))
    err = run.kinematics["theta_deg"] - truth["theta_deg"]
    assert np.sqrt(np.mean(err**2)) < 0.1
    assert run.tracks["A_y_mm"].std() == pytest.approx(amp / np.sqrt(2), rel=0.15)


def test_coulomb_friction_shrinks_each_swing_by_the_same_angle(tmp_path):
    from cranktrack.models.dynamics import CrankDynamics

    # A linear spring (no wire) and dry friction only: every half swing loses 2·f_c/k_l.
    k_l, fc = 4.0, 0.2
    d = CrankDynamics(I=1.0, k_l=k_l, k_s=0.0, k_d=0.0, theta0=np.pi / 2, coulomb=fc)
    t = np.linspace(0, 6, 60001)
    theta, omega = d.simulate(t, np.pi / 2 - 0.5)
    turning = np.flatnonzero(np.sign(omega[1:]) != np.sign(omega[:-1]))
    amplitude = np.abs(theta[turning] - np.pi / 2)
    np.testing.assert_allclose(-np.diff(amplitude)[:3], 2 * fc / k_l, rtol=0.02)
    # The free and spool scenarios take it as an effect; the spool only with inertia.
    assert parse_effects(["coulomb_rad_s2=0.5"]) == {"coulomb_rad_s2": 0.5}
    with pytest.raises(CranktrackError, match="needs return_spring_hz"):
        render_scene(SpoolScenario(), tmp_path / "never", RenderSettings(),
                     effects={"coulomb_rad_s2": 0.5})
    assert not (tmp_path / "never").exists()  # a refused request leaves nothing behind


def test_wire_stretch_makes_the_crank_lag_where_the_moment_arm_is_small():
    from scipy.optimize import brentq

    from cranktrack.models.crank_slider import l3_from_theta

    s0 = 0.5
    m = EffectedSpool(SpoolScenario(), {"wire_stretch_mm": s0}).motion(T)
    plain = SpoolScenario().motion(T)
    assert m.theta[0] == pytest.approx(plain.theta[0], abs=1e-12)  # the stretch is in L3_0
    # At rest after the stop: the wire is the kinematic length minus the initial stretch
    # plus the stretch under the spring there (tension ∝ (θ0 + 2π − θ)/arm(θ)).
    d = SpoolScenario().drive
    th0 = float(BED.theta(d.L3_0))

    def arm(th):
        return d.L1 * d.L2 * np.sin(th) / l3_from_theta(th, d.L1, d.L2)

    def stretch(th):
        return s0 * (th0 + 2 * np.pi - th) / arm(th) / ((2 * np.pi) / arm(th0))

    L3_kin = d.L3_0 - d.stroke_mm
    final = brentq(lambda th: l3_from_theta(th, d.L1, d.L2) - (L3_kin - s0 + stretch(th)),
                   1e-3, th0)
    assert m.theta[-1] == pytest.approx(final, abs=1e-9)
    lag = np.degrees(m.theta - plain.theta)
    assert 0 < lag[1500] < lag[-1]  # the lag grows as the crank closes and the arm shrinks
    moving = (T > 0.6) & (T < 1.5)
    np.testing.assert_allclose(np.gradient(m.theta, T)[moving], m.omega[moving], rtol=1e-3,
                               atol=1e-5)


def test_a_dead_band_renders_on_the_free_swing_and_is_refused_on_the_sma_bed(tmp_path):
    from cranktrack.synthetic.scenarios import FreeScenario, SMAScenario
    from cranktrack.synthetic.scene import RenderSettings, render_effects

    settings = RenderSettings(size=(160, 120), seconds=0.2)
    free = render_effects(FreeScenario(), tmp_path / "free", settings, {"dead_band_deg": 2.0})
    assert free.video.exists()
    with pytest.raises(CranktrackError, match="spool and free scenarios"):
        render_effects(SMAScenario(), tmp_path / "sma", settings, {"dead_band_deg": 2.0})
    assert not (tmp_path / "sma").exists()  # refused before anything is written
