"""The loop on physics it was not built from: beds built from their parts in ``synthetic/``.

Truth here is the rig built from its parts (circle crossings, a spool of finite
radius, a torque balance for an elastic wire, Newton's law for a crank with
inertia and dry friction), which imports nothing the fitter uses. Effects the
library has must be named and measured in both physical forms where there are
two; effects it lacks must come out "unexplained" with the right signature, and
never under another effect's name.
"""

import numpy as np
import pandas as pd
import pytest

from cranktrack.loop.camera_view import CameraView, camera_link_mm
from cranktrack.loop.search import close_loop
from cranktrack.loop.simulate import spool_theta
from cranktrack.synthetic.mechanism import SpoolBed, crank_angle, measured_table

T = np.arange(75) / 30.0
KNOWN = {"start_s": 0.5, "stroke_mm": 15.0, "L1_mm": 160.8, "L2_mm": 72.4, "speed_mm_s": 14.0}
SIGMA = 0.02


def loop(bed: SpoolBed, seed: int = 1, correlation: float = 0.0, **kw) -> dict:
    table = measured_table(bed.theta(T), T, SIGMA, seed=seed, correlation=correlation)
    return close_loop(table, KNOWN, **kw).to_dict()


def test_the_linkage_by_circle_crossings_is_the_law_of_cosines():
    # Two ways to the same angle: A–B–C with |AB| = L2, |AC| = L1, |BC| = L3.
    L3 = np.linspace(95.0, 120.0, 7)
    cos = (160.8**2 + 72.4**2 - L3**2) / (2 * 160.8 * 72.4)
    np.testing.assert_allclose(crank_angle(160.8, 72.4, L3), np.arccos(cos), atol=1e-12)


@pytest.mark.parametrize("bed, model_values", [
    (SpoolBed(slack_mm=1.0), {"slack_mm": 1.0}),
    (SpoolBed(wire_diameter_mm=0.4), {"spool_growth_per_s": SpoolBed(wire_diameter_mm=0.4)
                                      .growth_per_s}),
    (SpoolBed(stretch_mm=0.5), {"wire_stretch_mm": 0.5}),
    (SpoolBed(ring_hz=3.0, ring_zeta=0.1), {"return_spring_hz": 3.0}),
    (SpoolBed(dead_band_deg=1.5), {"play_deg": 1.5}),
    (SpoolBed(ring_hz=3.0, coulomb_rad_s2=1.0),
     {"return_spring_hz": 3.0, "return_spring_zeta": 0.1, "coulomb_rad_s2": 1.0}),
    (SpoolBed(ring_hz=8.0, coulomb_rad_s2=2.0),
     {"return_spring_hz": 8.0, "return_spring_zeta": 0.1, "coulomb_rad_s2": 2.0}),
])
def test_the_mechanism_and_the_fitters_model_agree_where_the_physics_is_the_same(
        bed, model_values):
    base = {"start_s": 0.5, "stroke_mm": 15.0, "L1_mm": 160.8, "L2_mm": 72.4,
            "L3_0_mm": 105.4, "speed_mm_s": 14.0}
    model = spool_theta({**base, **model_values}, T)
    # Written apart, they agree to far below any tracker's noise (the ringing crank's
    # two integrators to 0.001°); a wrong formula on either side would show here.
    assert np.degrees(np.max(np.abs(bed.theta(T) - model))) < 2e-3


@pytest.mark.parametrize("bed, named, parameter, truth", [
    (SpoolBed(slack_mm=1.0), "slack_mm", "slack_mm", 1.0),  # slack as lost stroke
    (SpoolBed(delay_s=0.05), "time_offset_s", "time_offset_s", 0.05),  # ... as a pure delay
    (SpoolBed(wire_diameter_mm=0.4), "spool_growth_per_s", "spool_growth_per_s",
     SpoolBed(wire_diameter_mm=0.4).growth_per_s),
    (SpoolBed(stretch_mm=0.5), "wire_stretch_mm", "wire_stretch_mm", 0.5),
    (SpoolBed(ring_hz=3.0), "return_spring_hz", "return_spring_hz", 3.0),
    (SpoolBed(ring_hz=8.0, ring_zeta=0.05), "return_spring_hz", "return_spring_hz", 8.0),
    (SpoolBed(dead_band_deg=0.5), "play_deg", "play_deg", 0.5),  # play, not slack
    (SpoolBed(dead_band_deg=2.0), "play_deg", "play_deg", 2.0),
    (SpoolBed(slack_mm=0.3), "slack_mm", "slack_mm", 0.3),  # slack, not play
    # Dry friction at the pivot, through the crank's inertia (a stick–slip ODE there,
    # a compiled integrator in the fitter): named alone, the ring with it.
    (SpoolBed(ring_hz=3.0, coulomb_rad_s2=0.5), "coulomb_rad_s2", "coulomb_rad_s2", 0.5),
    (SpoolBed(ring_hz=3.0, coulomb_rad_s2=2.0), "coulomb_rad_s2", "coulomb_rad_s2", 2.0),
])
def test_an_effect_in_the_library_is_named_alone_and_measured(bed, named, parameter, truth):
    report = loop(bed, correlation=0.5)
    assert report["effects"] == [named]
    p = report["parameters"][parameter]
    assert abs(p["value"] - truth) <= max(0.05 * truth, 3 * p["sigma"]), p
    assert report["rmse_after_deg"] < 1.5 * SIGMA


@pytest.mark.parametrize("radius, eccentricity", [(3.0, 0.15), (1.0, 0.15), (0.7, 0.05)])
def test_an_off_centre_spool_is_named_a_drive_ripple_of_its_offset_and_turn(radius, eccentricity):
    # The mechanism turns the spool about a point `eccentricity · radius` off its centre;
    # the ripple's amplitude is that offset and its period one turn's wire, 2π·radius
    # (under one turn in the stroke at 3 mm: a bump, still the same physics).
    report = loop(SpoolBed(eccentricity=eccentricity, spool_radius_mm=radius), correlation=0.5)
    assert report["effects"] == ["drive_ripple_mm"]
    amp, turn = (report["parameters"][k] for k in ("drive_ripple_mm", "ripple_turn_mm"))
    offset = eccentricity * radius
    assert abs(amp["value"] - offset) <= max(0.05 * offset, 3 * amp["sigma"]), amp
    assert turn["value"] == pytest.approx(2 * np.pi * radius, rel=0.05)
    assert report["rmse_after_deg"] < 1.5 * SIGMA


@pytest.mark.parametrize("bed", [
    SpoolBed(stall_at_s=0.9, stall_s=0.1),
    SpoolBed(stall_at_s=1.2, stall_s=0.05),
], ids=["servo-stall-0.1-s", "servo-stall-0.05-s"])
def test_an_effect_outside_the_library_is_unexplained_never_misnamed(bed):
    report = loop(bed)
    assert report["effects"] == []
    assert report["unexplained"].startswith("the residual stays structured")
    assert report["rmse_after_deg"] > 1.5 * SIGMA  # nothing soaked it up quietly


@pytest.mark.parametrize("stall_s", [0.05, 0.1])
def test_a_servo_that_stalls_mid_stroke_is_described_as_a_lag_from_then_on(stall_s):
    # The servo stops at 0.9 s for stall_s, then winds the rest of the stroke: the crank
    # keeps to the model until then and trails it by about stall_s afterwards.
    report = loop(SpoolBed(stall_at_s=0.9, stall_s=stall_s), correlation=0.5)
    top = report["leftover"]["shapes"][0]
    assert top["kind"] == "lag from a moment on"
    assert 0.9 <= top["from_s"] <= 0.9 + stall_s + 2 / 30.0
    assert top["lag_s"] == pytest.approx(stall_s, rel=0.15)
    assert report["leftover"]["sentence"].startswith("the crank follows the model until")


@pytest.mark.parametrize("seed", range(6))
def test_correlated_noise_alone_names_nothing(seed):
    assert loop(SpoolBed(), seed=seed, correlation=0.6)["effects"] == []


def _view() -> CameraView:
    H = np.array([[0.5, 0.0, -40.0], [0.0, -0.5, 60.0], [0.0, 0.0, 1.0]])  # px → mm
    Hi = np.linalg.inv(H)

    def apply(M, p):
        h = p @ M[:, :2].T + M[:, 2]
        return h[:, :2] / h[:, 2:]

    return CameraView(lambda p: apply(H, p), lambda p: apply(Hi, p), (480, 270),
                      np.array([80.0, 120.0]), np.array([401.6, 120.0]), 1.0)


def test_lens_and_tilt_are_vetoed_while_the_rigid_crank_does_not_bend():
    bed = SpoolBed(slack_mm=1.0)
    table = measured_table(bed.theta(T), T, SIGMA, seed=1)
    report = close_loop(table, KNOWN, view=_view()).to_dict()
    camera = [c for c in report["candidates"] if c["name"] in ("lens_edge_pct",
                                                                "tilt_vertical_deg")]
    # Each would explain much of the slack (ΔBIC in the thousands) at a value that
    # bends |AB| by ~0.1 mm, which the unbent crank does not show.
    assert camera and all(c["delta_bic"] > 1000 and "does not bend" in c["veto"]
                          for c in camera)
    assert report["effects"] == ["slack_mm"]
    # Bend the measured crank as that lens would, and the lens's veto lifts.
    lens = next(c for c in camera if c["name"] == "lens_edge_pct")
    values = {"L1_mm": 160.8, "L2_mm": 72.4,
              "lens_edge_pct": lens["parameters"]["lens_edge_pct"]["value"]}
    bend = camera_link_mm(np.radians(table["theta_deg"].to_numpy()), values, _view())
    bent = table.assign(L2_mm=table["L2_mm"] + bend - bend.mean())
    report = close_loop(bent, KNOWN, view=_view()).to_dict()
    lens = next(c for c in report["candidates"] if c["name"] == "lens_edge_pct")
    assert "does not bend" not in lens["veto"]


def test_a_readout_longer_than_a_frame_is_not_plausible():
    # A 20 ms dead time: a rolling shutter would need B read 69 ms after A to mimic it,
    # longer than the 33 ms between frames, which no camera does.
    table = measured_table(SpoolBed(delay_s=0.02).theta(T), T, SIGMA, seed=1)
    report = close_loop(table, KNOWN, view=_view()).to_dict()
    readout = next(c for c in report["candidates"] if c["name"] == "readout_s")
    assert abs(readout["parameters"]["readout_s"]["value"]) > 1 / 30
    assert not readout["plausible"] and not readout["accepted"]
    assert report["effects"] == ["time_offset_s"]


def test_a_shake_at_an_angle_is_reported_as_the_whole_vector():
    from cranktrack.loop.frame_motion import frame_shake

    # The frame shakes 0.4 mm along a line 30° off A–C, at 5 Hz: across the line
    # that is 0.2 mm, along it 0.35 mm.
    rng = np.random.default_rng(3)
    t = np.arange(150) / 30.0
    move = 0.4 * np.sin(2 * np.pi * 5.0 * t)
    dx, dy = move * np.cos(np.radians(30)), move * np.sin(np.radians(30))
    tracks = pd.DataFrame({"t_s": t, "A_x_mm": dx + rng.normal(0, 0.01, t.size),
                           "A_y_mm": dy + rng.normal(0, 0.01, t.size),
                           "C_x_mm": 160.8 + dx + rng.normal(0, 0.01, t.size),
                           "C_y_mm": dy + rng.normal(0, 0.01, t.size),
                           "A_sigma_mm": 0.01, "C_sigma_mm": 0.01})
    shake = frame_shake(tracks)
    assert shake.accepted
    assert shake.amp_mm == pytest.approx(0.2, rel=0.05)
    assert shake.amp_along_mm == pytest.approx(0.4 * np.cos(np.radians(30)), rel=0.05)
    assert shake.amp_vector_mm == pytest.approx(0.4, rel=0.05)


# The free response (the dynamic model) against the crank built from its parts in
# synthetic/free_swing.py: vector torques and a true stick–slip, not eq. 3.28's
# closed form with a tanh.

def _free_table(friction: float, seed: int, play_deg: float = 0.0) -> pd.DataFrame:
    from cranktrack.synthetic.scenarios import FreeScenario

    d = FreeScenario().dynamics
    crank = FreeScenario().crank.__class__(d.L1, d.L2, d.I, d.k_l, d.k_s, d.theta0, d.eps,
                                           d.k_d, friction, np.radians(play_deg))
    t = np.arange(180) / 30.0
    theta = crank.swing(t, np.radians(70.0))[0]
    return measured_table(theta, t, SIGMA, seed=seed, L1_mm=d.L1, L2_mm=d.L2)


def test_the_free_swing_and_the_fitters_equation_agree_without_dry_friction():
    from cranktrack.models.dynamics import CrankDynamics
    from cranktrack.synthetic.free_swing import SwingingCrank

    d = CrankDynamics(I=0.05, k_l=1.0, k_s=1e-3, k_d=0.5, L1=160.8, L2=72.4,
                      theta0=np.radians(90.0))
    crank = SwingingCrank(d.L1, d.L2, d.I, d.k_l, d.k_s, d.theta0, d.eps, d.k_d)
    t = np.arange(300) / 30.0
    theirs = d.simulate(t, np.radians(70.0))[0]
    assert np.degrees(np.max(np.abs(crank.swing(t, np.radians(70.0))[0] - theirs))) < 1e-6


@pytest.mark.parametrize("friction", [0.0, 0.3, 0.6, 1.2])
def test_the_dynamic_model_finds_stick_slip_friction_it_did_not_render(friction):
    # At 0.6 the crank sticks 1.2 s before the end. At 1.2 it sticks after three half
    # swings, and the least squares has a valley for each number of swings: started
    # from the data's decay it settled at 0.25 or 0.53 (0.34–0.46° RMS) until the fit
    # profiled μ first.
    result = close_loop(_free_table(friction, seed=2), {}, model="dynamic").to_dict()
    if friction:
        assert result["effects"] == ["coulomb_rad_s2"]
        fitted = result["parameters"]["coulomb_rad_s2"]["value"]
        assert abs(fitted - friction) < 0.05 * friction
        assert result["rmse_after_deg"] < 1.5 * SIGMA
    else:
        assert result["effects"] == []


def test_the_free_swings_lever_and_the_fitters_dead_band_agree():
    # The rig finds where the wire goes slack by bisection on |BC| and moves a lever
    # between stops; the fitter clips the angle the wire sees about the law of cosines'.
    from dataclasses import replace

    from cranktrack.models.dynamics import free_response
    from cranktrack.synthetic.scenarios import FreeScenario

    sc = FreeScenario()
    d = sc.dynamics
    t = np.arange(180) / 30.0
    play = np.radians(2.0)
    theirs = replace(sc.crank, play_rad=play).swing(t, np.radians(70.0))[0]
    ours = free_response(replace(d, I=1.0, k_l=d.k_l / d.I, k_s=d.k_s / d.I, play=play), t,
                         np.radians(70.0))[0]
    assert np.degrees(np.max(np.abs(ours - theirs))) < 1e-3
    # and the play is felt: the crank settles degrees away from where it would without
    assert abs(np.degrees(theirs[-1] - sc.crank.swing(t, np.radians(70.0))[0][-1])) > 1.0


@pytest.mark.parametrize("play_deg", [0.5, 4.0])
def test_the_dynamic_model_finds_play_it_did_not_render(play_deg):
    # At 4° the base fit drops the wire (k_s → 0), where play does nothing: the effect's
    # fit needs the data's start that shares the stiffness with the wire.
    result = close_loop(_free_table(0.0, seed=2, play_deg=play_deg), {},
                        model="dynamic").to_dict()
    assert result["effects"] == ["play_deg"]
    fitted = result["parameters"]["play_deg"]["value"]
    assert abs(fitted - play_deg) < 0.05 * play_deg
    assert result["rmse_after_deg"] < 1.5 * SIGMA


# The SMA bed (the sma model) against the rig built from its parts in
# synthetic/sma_rig.py: heat integrated as enthalpy, hysteresis as memory of the
# last turn, the crank with inertia under vector torques.

SMA_KNOWN = {"current_A": 1.3, "current_on_s": 0.5, "current_off_s": 3.0}


def _sma_theta(lag_s: float, t: np.ndarray) -> np.ndarray:
    from cranktrack.models.sma_bed import SMABed
    from cranktrack.synthetic.scenarios import SMAScenario
    from cranktrack.synthetic.sma_rig import current_step

    scenario = SMAScenario(bed=SMABed(thermal_lag_s=lag_s))
    return scenario.rig.response(t, current_step(1.3, 0.5, 3.0))[0]


def test_the_sma_rig_and_the_fitters_bed_agree_where_the_physics_is_the_same():
    from cranktrack.models.heat import CurrentSteps
    from cranktrack.models.sma_bed import SMABed, simulate_bed

    t = np.arange(150) / 30.0
    theirs = simulate_bed(SMABed(), CurrentSteps((0.5, 3.0), (1.3, 0.0)), t).theta
    # Two integrations of the same physics written apart: 0.012° apart at most, a
    # tenth of the 0.1° the crank moves per frame at full speed.
    assert np.degrees(np.max(np.abs(_sma_theta(0.0, t) - theirs))) < 0.03


@pytest.mark.parametrize("lag_s", [0.0, 0.2])
def test_the_sma_model_finds_a_thermal_lag_it_did_not_render(lag_s):
    t = np.arange(150) / 30.0
    table = measured_table(_sma_theta(lag_s, t), t, SIGMA, seed=3, L1_mm=305.0, L2_mm=24.1)
    result = close_loop(table, SMA_KNOWN, model="sma").to_dict()
    if lag_s:
        assert result["effects"] == ["thermal_lag_s"]
        fitted = result["parameters"]["thermal_lag_s"]["value"]
        assert abs(fitted - lag_s) < 0.15 * lag_s
    else:
        assert result["effects"] == []


def _sma_rubbing(coulomb_Nm: float, t: np.ndarray) -> np.ndarray:
    from dataclasses import replace

    from cranktrack.synthetic.scenarios import SMAScenario
    from cranktrack.synthetic.sma_rig import current_step

    rig = replace(SMAScenario().rig, coulomb_Nm=coulomb_Nm)
    return rig.response(t, current_step(1.3, 0.5, 3.0))[0]


def test_the_sma_rigs_stick_slip_and_the_fitters_friction_band_agree():
    # Two forms of one friction: the rig integrates stick and slip with inertia, the
    # fitter clamps the balance between the angles where the torque is ±friction.
    from cranktrack.loop.simulate import sma_theta
    from cranktrack.models.heat import SMAWire

    w = SMAWire()
    t = np.arange(150) / 30.0
    base = {**SMA_KNOWN, "ambient_C": w.T_amb_C, "L1_mm": 305.0, "L2_mm": 24.1,
            "theta0_deg": 125.0, "recovery_strain": 0.0325, "h_W_m2K": w.h_W_m2K,
            "As_C": w.As_C, "Af_C": w.Af_C, "Ms_C": w.Ms_C, "Mf_C": w.Mf_C}
    free, rubbing = _sma_rubbing(0.0, t), _sma_rubbing(0.02, t)
    # The friction is felt: the crank comes back 0.7° short by the end.
    assert np.degrees(free[-1] - rubbing[-1]) > 0.5
    ours = sma_theta({**base, "coulomb_Nm": 0.02}, t)
    assert np.degrees(np.max(np.abs(ours - rubbing))) < 0.02


@pytest.mark.parametrize("extra", [0.0, 0.1])
def test_the_fitters_sma_bed_follows_a_heavily_damped_rig(extra):
    # The rig integrates inertia and damper; the fitter has the crank relax towards
    # its balance. Taking that lag to first order (θ − c·θ'/k) was 2° off at 0.1.
    from cranktrack.loop.simulate import sma_theta
    from cranktrack.models.heat import SMAWire
    from cranktrack.models.sma_bed import SMABed
    from cranktrack.synthetic.scenarios import SMAScenario
    from cranktrack.synthetic.sma_rig import current_step

    w = SMAWire()
    t = np.arange(150) / 30.0
    bed = SMABed(damping_Nms_rad=SMABed.damping_Nms_rad + extra)
    theirs = SMAScenario(bed=bed).rig.response(t, current_step(1.3, 0.5, 3.0))[0]
    ours = sma_theta({**SMA_KNOWN, "ambient_C": w.T_amb_C, "L1_mm": 305.0, "L2_mm": 24.1,
                      "theta0_deg": 125.0, "recovery_strain": 0.0325, "h_W_m2K": w.h_W_m2K,
                      "As_C": w.As_C, "Af_C": w.Af_C, "Ms_C": w.Ms_C, "Mf_C": w.Mf_C,
                      "damping_Nms_rad": extra}, t)
    assert np.degrees(np.max(np.abs(ours - theirs))) < 0.1


@pytest.mark.parametrize("coulomb_Nm", [0.015, 0.03])
def test_the_sma_model_finds_dry_friction_it_did_not_render(coulomb_Nm):
    # The base model takes up most of it (0.015 N·m leaves a white residual 1.34× the
    # tracker's σ): the loop must look past a white residual that is still too large.
    t = np.arange(150) / 30.0
    table = measured_table(_sma_rubbing(coulomb_Nm, t), t, SIGMA, seed=3, L1_mm=305.0,
                           L2_mm=24.1)
    result = close_loop(table, SMA_KNOWN, model="sma").to_dict()
    assert result["effects"] == ["coulomb_Nm"]
    fitted = result["parameters"]["coulomb_Nm"]["value"]
    assert abs(fitted - coulomb_Nm) < 0.15 * coulomb_Nm
    assert result["rmse_after_deg"] < 1.1 * SIGMA


def test_the_sma_models_late_current_is_the_rigs_dead_time_in_the_strain():
    # The lag's other form: the wire's length follows ξ as it was 0.1 s before, which
    # is the current switched 0.1 s late for the fitter's time-invariant heat model.
    from dataclasses import replace

    from cranktrack.synthetic.scenarios import SMAScenario
    from cranktrack.synthetic.sma_rig import current_step

    t = np.arange(150) / 30.0
    rig = replace(SMAScenario().rig, strain_delay_s=0.1)
    theta = rig.response(t, current_step(1.3, 0.5, 3.0))[0]
    table = measured_table(theta, t, SIGMA, seed=3, L1_mm=305.0, L2_mm=24.1)
    result = close_loop(table, SMA_KNOWN, model="sma").to_dict()
    assert result["effects"] == ["time_offset_s"]
    assert abs(result["parameters"]["time_offset_s"]["value"] - 0.1) < 0.01


def test_the_loop_reports_each_fit_it_starts():
    # What `cranktrack fit` shows as progress: the base model first, then the effects.
    calls: list[tuple[str, ...]] = []
    close_loop(_free_table(0.3, seed=4), {}, model="dynamic", on_fit=calls.append)
    assert calls[0] == () and ("coulomb_rad_s2",) in calls
