"""Closing the loop: the effect that is in the data is found, named and measured; nothing
is found where there is nothing.

Two kinds of data: θ(t) series from :mod:`cranktrack.synthetic.mechanism` plus white
noise (fast, many seeds, parameters known exactly), and tracked renders with an
undeclared effect, whose ground truth (``truth.csv``) sets the noise floor the fit must
come down to. Neither is made with the fitter's simulation code: the mechanism is
written from the rig's parts (circle crossings, the spool's radius, a torque balance,
Newton's law for the ringing crank), so a wrong formula in the fitter would fail here.
"""

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from cranktrack.cli import main, parse_known
from cranktrack.errors import CranktrackError
from cranktrack.loop.search import close_loop
from cranktrack.synthetic.mechanism import SpoolBed

T = np.arange(75) / 30.0
TRUE = {"start_s": 0.5, "stroke_mm": 15.0, "L1_mm": 160.8, "L2_mm": 72.4, "L3_0_mm": 105.4,
        "speed_mm_s": 14.0}
KNOWN = {k: TRUE[k] for k in ("start_s", "stroke_mm", "L1_mm", "L2_mm", "speed_mm_s")}


def true_theta(effect: dict) -> np.ndarray:
    """θ (rad) of the mechanism with the effects named as the fitter names them."""
    e = dict(effect)
    # A clock that runs ``clock_scale`` fast about the start, then ``time_offset_s`` late.
    clock = 0.5 + e.pop("clock_scale", 1.0) * (T - 0.5) - e.pop("time_offset_s", 0.0)
    bed = SpoolBed(slack_mm=e.pop("slack_mm", 0.0), stretch_mm=e.pop("wire_stretch_mm", 0.0),
                   ring_hz=e.pop("return_spring_hz", 0.0),
                   ring_zeta=e.pop("return_spring_zeta", 0.1))
    # Speed growth is the wire layering on the spool: one diameter of radius per turn.
    growth = e.pop("spool_growth_per_s", 0.0)
    bed = replace(bed, wire_diameter_mm=growth * bed.spool_radius_mm / bed.turn_hz)
    assert not e, f"no mechanism for {e}"
    return bed.theta(np.maximum(clock, 0.0))


def series(effect: dict | None = None, seed: int = 0, sigma: float = 0.02,
           add: np.ndarray | None = None) -> pd.DataFrame:
    """A kinematics table whose θ is the mechanism's, with white noise of σ degrees."""
    rng = np.random.default_rng(seed)
    theta = np.degrees(true_theta(effect or {})) + rng.normal(0, sigma, T.size)
    if add is not None:
        theta = theta + add
    return pd.DataFrame({"frame": np.arange(T.size), "t_s": T, "theta_deg": theta,
                         "theta_deg_sigma": sigma, "L3_mm": np.nan,
                         "L1_mm": 160.8 + rng.normal(0, 0.02, T.size),
                         "L2_mm": 72.4 + rng.normal(0, 0.02, T.size)})


def recovered(report: dict, name: str, truth: float, off: float = 0.0, z: float = 3.0) -> None:
    """Within 20 % of the effect's size and within zσ (the fit's own interval)."""
    p = report["parameters"][name]
    assert abs(p["value"] - truth) <= 0.2 * abs(truth - off), (name, p, truth)
    assert abs(p["value"] - truth) <= z * p["sigma"], (name, p, truth)


@pytest.mark.parametrize("effect, first", [
    ({"slack_mm": 1.0}, "slack_mm"),
    ({"time_offset_s": 0.05}, "time_offset_s"),
    ({"spool_growth_per_s": 0.1}, "spool_growth_per_s"),
    ({"return_spring_hz": 3.0, "return_spring_zeta": 0.1}, "return_spring_hz"),
    ({"clock_scale": 1.03}, "clock_scale"),
    ({"wire_stretch_mm": 0.5}, "wire_stretch_mm"),
])
def test_each_effect_in_the_library_is_named_and_measured(effect, first):
    report = close_loop(series(effect), KNOWN).to_dict()
    assert report["effects"] == [first]
    off = 1.0 if first == "clock_scale" else 0.0
    for name, value in effect.items():
        recovered(report, name, value, off)
    assert report["rmse_after_deg"] < 1.5 * 0.02  # down to the noise
    assert report["rmse_before_deg"] > 3 * report["rmse_after_deg"]
    assert report["fit_percent_after"] > report["fit_percent_before"]


def test_white_noise_alone_is_explained_by_nothing():
    found = [close_loop(series(seed=s), KNOWN).effects for s in range(8)]
    assert found == [[]] * 8


def test_an_effect_that_needs_a_known_value_is_not_tried_without_it():
    known = {k: v for k, v in KNOWN.items() if k not in ("start_s", "stroke_mm")}
    report = close_loop(series({"slack_mm": 1.0}), known).to_dict()
    # Slack is a later start and a shorter stroke unless one of them is known: the base
    # model absorbs it, and the report says what would have separated it.
    assert report["effects"] == []
    needs = {n["name"]: n["needs"] for n in report["not_separable"]}
    assert needs["slack_mm"] == ["start_s", "stroke_mm"]
    assert needs["time_offset_s"] == ["start_s"]
    assert report["rmse_before_deg"] < 1.5 * 0.02
    # Knowing the stroke alone is enough: slack then also shrinks the rocking angle.
    known["stroke_mm"] = KNOWN["stroke_mm"]
    report = close_loop(series({"slack_mm": 1.0}), known).to_dict()
    assert report["effects"] == ["slack_mm"]
    recovered(report, "slack_mm", 1.0)


def test_look_alikes_are_reported_as_a_group_with_the_experiment_that_separates_them():
    known = {k: v for k, v in KNOWN.items() if k != "stroke_mm"}
    report = close_loop(series({"slack_mm": 1.0}), known).to_dict()
    # With the stroke free, slack ≡ a clock offset: same delay, stroke absorbs the rest.
    assert report["effects"][0] in ("slack_mm", "time_offset_s")
    group = report["look_alike_groups"][0]
    assert set(group["effects"]) == {"slack_mm", "time_offset_s"}
    assert "stroke" in group["separated_by"]


def test_structure_no_candidate_matches_is_reported_not_forced():
    wobble = 0.3 * np.sin(2 * np.pi * 1.6 * T)  # nothing in the library makes this
    report = close_loop(series(add=wobble), KNOWN).to_dict()
    assert report["effects"] == []
    assert report["unexplained"] and "ripple" in report["unexplained"]
    ripple = report["leftover"]["shapes"][0]
    assert ripple["hz"] == pytest.approx(1.6, abs=0.1)
    assert ripple["amplitude_deg"] == pytest.approx(0.3, rel=0.3)
    assert not ripple["while_moving_only"]  # it is there while the crank stands still
    assert not report["residual_white_after"]


def test_two_effects_at_once_are_both_found():
    report = close_loop(series({"slack_mm": 1.0, "return_spring_hz": 3.0}), KNOWN).to_dict()
    assert sorted(report["effects"]) == ["return_spring_hz", "slack_mm"]
    recovered(report, "slack_mm", 1.0)
    recovered(report, "return_spring_hz", 3.0)


def test_known_values_are_checked():
    assert parse_known(["L1_mm=160.8", "start_s=0.5"]) == {"L1_mm": 160.8, "start_s": 0.5}
    for bad in (["L1=160"], ["start_s"], ["start_s=soon"], ["start_s=nan"]):
        with pytest.raises(CranktrackError):
            parse_known(bad)
    with pytest.raises(CranktrackError, match="cannot be fitted yet"):
        parse_known([], "antagonistic")
    with pytest.raises(CranktrackError, match="fewer than 12"):
        close_loop(series().iloc[:8], KNOWN)


# Tracked renders with an effect that scene.json does not declare.

RENDER = ["--size", "480x270", "--seconds", "2.5", "--fps", "30"]


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    root = tmp_path_factory.mktemp("undeclared")
    made = {}

    def make(name: str, effects: tuple[str, ...] = (), seed: int = 0, scenario: str = "spool"):
        if name not in made:
            scene, run = root / name / "scene", root / name / "run"
            args = ["synth", scenario, "--out", str(scene), *RENDER, "--seed", str(seed)]
            for e in effects:
                args += ["--effect", e]
            assert main(args) == 0
            assert main(["track", str(scene / "video.mp4"), "--out", str(run),
                         "--known-length", "A-C=160.8"]) == 0
            declared = json.loads((scene / "scene.json").read_text())["effects"]
            assert declared == ("not declared" if effects else {})
            made[name] = (scene, run)
        return made[name]
    return make


def floor_deg(scene, run) -> float:
    """The render's noise floor: RMS of the tracked θ against the truth."""
    truth = pd.read_csv(scene / "truth.csv")
    measured = pd.read_csv(run / "kinematics.csv")
    return float(np.sqrt(np.mean((measured["theta_deg"] - truth["theta_deg"]) ** 2)))


def fit(run, known: dict) -> dict:
    args = ["fit", str(run)]
    for k, v in known.items():
        args += ["--known", f"{k}={v}"]
    assert main(args) == 0
    return json.loads((run / "fit" / "report.json").read_text())


@pytest.mark.parametrize("effects, named, truth", [
    (("slack_mm=1",), ["slack_mm"], {"slack_mm": 1.0}),
    (("spool_growth_per_s=0.1",), ["spool_growth_per_s"], {"spool_growth_per_s": 0.1}),
    (("return_spring_hz=3",), ["return_spring_hz"], {"return_spring_hz": 3.0}),
    # 36 s through the tracker; its physics written apart from the fitter is
    # test_open_world.py's SpoolBed(stretch_mm=0.5), in memory.
    pytest.param(("wire_stretch_mm=0.5",), ["wire_stretch_mm"], {"wire_stretch_mm": 0.5},
                 marks=pytest.mark.slow),
    # Two at once on a tracked render is slow (20 s); in memory it is
    # test_two_effects_at_once_are_both_found.
    pytest.param(("slack_mm=1", "return_spring_hz=3"), ["slack_mm", "return_spring_hz"],
                 {"slack_mm": 1.0, "return_spring_hz": 3.0}, marks=pytest.mark.slow),
])
def test_an_undeclared_effect_in_a_tracked_render_is_found(rendered, effects, named, truth):
    scene, run = rendered("-".join(effects), effects)
    report = fit(run, KNOWN)
    assert report["effects"][0] == named[0]
    assert sorted(report["effects"]) == sorted(named)
    for name, value in truth.items():
        # 4σ on a tracked render: its tracker bias is one draw that σ does not
        # hold. The 1 mm slack came out 1.024 ± 0.011 from the CLI and, twice in
        # about ten suite runs, 1.034 ± 0.010 (3.3σ) on the same render (see the note).
        recovered(report, name, value, z=4.0)
    assert report["rmse_after_deg"] <= 1.5 * floor_deg(scene, run)
    assert (run / "fit" / "residuals.png").stat().st_size > 10_000
    assert "Closing the loop" in (run / "report.md").read_text()


# 17 s; the clock error in memory is in test_each_effect_in_the_library_is_named_and_measured.
@pytest.mark.slow
def test_a_wrong_frame_rate_label_is_found_as_a_clock_error(rendered):
    scene, run = rendered("fps", ("fps_label=31",))
    # The user reads the drive's start off the video, so on its (wrong) clock.
    known = {**KNOWN, "start_s": 0.5 * 30 / 31}
    report = fit(run, known)
    assert report["effects"] == ["clock_scale"]
    recovered(report, "clock_scale", 31 / 30, off=1.0)
    assert report["rmse_after_deg"] <= 1.5 * floor_deg(scene, run)


# A second null seed is in `make test-slow`; bench/discrepancy.py runs 10 per noise level.
@pytest.mark.parametrize("seed", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_a_tracked_render_without_effects_gets_none(rendered, seed):
    scene, run = rendered(f"null{seed}", seed=seed)
    for known in (KNOWN, {k: KNOWN[k] for k in ("L1_mm", "L2_mm", "speed_mm_s", "start_s")},
                  {}):
        report = fit(run, known)
        assert report["effects"] == [], (known, report["candidates"])
        assert report["rmse_after_deg"] <= 1.5 * floor_deg(scene, run)


def test_a_shaking_frame_is_found_from_a_and_c_though_theta_cannot_show_it(rendered):
    scene, run = rendered("shake", ("pivot_amp_mm=0.3",))  # at the default 5 Hz
    report = fit(run, KNOWN)
    assert report["effects"] == ["pivot_amp_mm"]
    recovered(report, "pivot_amp_mm", 0.3)
    recovered(report, "pivot_hz", 5.0)
    assert report["rmse_after_deg"] <= 1.5 * floor_deg(scene, run)  # θ: nothing to explain
    # The floor of the across-line motion: tracked mean of A and C against the truth's.
    tracks, truth = pd.read_csv(run / "tracks.csv"), pd.read_csv(scene / "truth.csv")
    got = 0.5 * (tracks["A_y_mm"] + tracks["C_y_mm"]).to_numpy()
    true = 0.5 * (truth["A_y_mm"] + truth["C_y_mm"]).to_numpy()
    e = got - np.sign(np.corrcoef(got, true)[0, 1]) * true
    floor = float(np.std(e))
    fm = report["frame_motion"]
    assert fm["rmse_before_mm"] > 5 * floor
    assert fm["rmse_after_mm"] <= 1.5 * floor, (fm, floor)
    assert "The frame shakes" in (run / "fit" / "report.md").read_text()


def test_a_rolling_shutter_is_found_as_a_delay_that_follows_b_s_row(rendered):
    readout = 0.033
    _, run = rendered("rolling", (f"readout_s={readout}",))
    report = fit(run, KNOWN)
    # A clock offset explains most of it (B is caught ~readout × its mean row late), but
    # only the readout explains the part that follows B's row through the stroke.
    assert report["effects"] == ["readout_s"]
    recovered(report, "readout_s", readout)
    assert report["parameters"]["readout_s"]["unit"] == "s"
    assert "time_offset_s" in report["effect_docs"]["readout_s"]["also_looks_like"]
    assert not report["camera_effect_suspected"]
    # The floor is the same render's without the shutter: truth.csv holds where the
    # markers were at the frame time, which a rolling shutter does not show.
    null_scene, null_run = rendered("null0", seed=0)
    assert report["rmse_after_deg"] <= 1.5 * floor_deg(null_scene, null_run)


def image_floor_deg(scene, run) -> float:
    """A camera effect's floor: RMS of the tracked angle at A against the angle between
    the markers' true image positions (truth.csv's px, which the camera bent)."""
    truth, tracks = pd.read_csv(scene / "truth.csv"), pd.read_csv(run / "tracks.csv")

    def angle(df):
        a, b, c = (df[[f"{m}_x_px", f"{m}_y_px"]].to_numpy() for m in "ABC")
        u, v = b - a, c - a
        return np.degrees(np.arctan2(np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]),
                                     (u * v).sum(axis=1)))

    return float(np.sqrt(np.nanmean((angle(tracks) - angle(truth)) ** 2)))


def test_an_uncalibrated_lens_is_found_as_a_camera_effect(rendered):
    _, run = rendered("lens", ("k1=-0.2",))
    report = fit(run, KNOWN)
    assert report["effects"] == ["lens_edge_pct"]
    # The synthetic camera's 60° lens: k1 = −0.2 moves a point at the half-width by
    # k1·(tan 30°)² = −6.67 % of its radius.
    recovered(report, "lens_edge_pct", 100 * -0.2 * np.tan(np.radians(30)) ** 2)
    assert report["rmse_after_deg"] <= 1.5 * image_floor_deg(*rendered("lens"))
    assert report["camera_effect_suspected"]
    assert "tilt" in report["effect_docs"]["lens_edge_pct"]["also_looks_like"]


def test_a_tilted_camera_is_found_as_a_tilt(rendered):
    _, run = rendered("tilt", ("tilt_deg=8",))
    report = fit(run, KNOWN)
    assert report["effects"] == ["tilt_vertical_deg"]
    recovered(report, "tilt_vertical_deg", 8.0)  # the renderer's lens is the 60° assumed
    assert report["rmse_after_deg"] <= 1.5 * image_floor_deg(*rendered("tilt"))


def test_a_camera_tilt_the_free_model_absorbs_is_still_told_to_the_user(rendered):
    # An 8° tilt (synthetic/camera.py) on the free swing: the dynamic model's own
    # parameters take the bias in and θ's residual stays at the noise, but the rigid
    # crank's |AB| follows θ. A user must not read "nothing is missing" alone.
    _, run = rendered("free_tilt", ("tilt_deg=8",), scenario="free")
    assert main(["fit", str(run), "--model", "dynamic", "--quiet"]) == 0
    report = json.loads((run / "fit" / "report.json").read_text())
    assert report["camera_effect_suspected"]
    if not {"tilt_vertical_deg", "tilt_horizontal_deg", "lens_edge_pct"} & set(report["effects"]):
        text = (run / "fit" / "report.md").read_text()
        assert "the camera is probably tilted or its lens distorts" in text
        assert "calibrate the camera" in text


@pytest.mark.parametrize("coulomb", [0.0, 0.5])
def test_the_dynamic_model_finds_dry_friction_in_a_free_response(rendered, coulomb):
    effects = (f"coulomb_rad_s2={coulomb}",) if coulomb else ()
    scene, run = rendered(f"free{coulomb}", effects, scenario="free")
    assert main(["fit", str(run), "--model", "dynamic"]) == 0
    report = json.loads((run / "fit" / "report.json").read_text())
    assert report["model"] == "dynamic"
    assert report["rmse_after_deg"] <= 1.5 * floor_deg(scene, run)
    if coulomb:
        assert report["effects"] == ["coulomb_rad_s2"]
        recovered(report, "coulomb_rad_s2", coulomb)
    else:
        assert report["effects"] == []


SMA_KNOWN = ["--known", "current_A=1.3", "--known", "current_on_s=0.5",
             "--known", "current_off_s=3"]
#: The heat model's constants as rendered (Tables 4.2/4.4): without them extra pivot
#: damping hides in fitted transformation temperatures and h.
THERMAL_KNOWN = ["--known", "h_W_m2K=625", "--known", "As_C=55", "--known", "Af_C=70",
                 "--known", "Ms_C=50", "--known", "Mf_C=25"]


@pytest.mark.slow
@pytest.mark.parametrize("effect, value, known", [
    (None, 0.0, []),
    ("thermal_lag_s", 0.2, []),
    ("damping_Nms_rad", 0.05, THERMAL_KNOWN),
])
def test_the_sma_model_finds_a_thermal_lag_or_pivot_damping(tmp_path, effect, value, known):
    # Slow (≈ 1–2 min each: a 640×360 render and a loop whose every simulation runs the
    # heat model): `pytest -m slow`.
    scene, run = tmp_path / "scene", tmp_path / "run"
    args = ["synth", "sma", "--out", str(scene), "--size", "640x360", "--seconds", "5"]
    assert main([*args, *(["--effect", f"{effect}={value}"] if effect else [])]) == 0
    assert main(["track", str(scene / "video.mp4"), "--out", str(run),
                 "--known-length", "A-C=305"]) == 0
    assert main(["fit", str(run), "--model", "sma", *SMA_KNOWN, *known]) == 0
    report = json.loads((run / "fit" / "report.json").read_text())
    assert report["rmse_after_deg"] <= 1.5 * floor_deg(scene, run)
    if effect:
        assert report["effects"][0] == effect
        recovered(report, effect, value)
    else:
        assert report["effects"] == []


# The camera candidates' geometry, against the renderer's own camera.

def _similarity_residual(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance left after the best similarity from points a to points b, px."""
    za, zb = a[:, 0] + 1j * a[:, 1], b[:, 0] + 1j * b[:, 1]
    A = np.stack([za, np.ones_like(za)], axis=1)
    coef, *_ = np.linalg.lstsq(A, zb, rcond=None)
    return float(np.abs(A @ coef - zb).max())


def test_camera_candidates_bend_the_image_as_the_synthetic_camera_does():
    from cranktrack.loop.camera_view import _camera_maps
    from cranktrack.synthetic.camera import PinholeCamera

    lo, hi = np.array([-80.0, -80.0]), np.array([170.0, 80.0])
    grid = np.stack(np.meshgrid(np.linspace(-80, 170, 9), np.linspace(-80, 80, 7)), -1)
    pts = grid.reshape(-1, 2)
    flat = PinholeCamera.framing(480, 270, lo, hi)
    # Lens: OpenCV's k1 on a 60° lens is our displacement at the half-width, k1·tan²30°.
    lens = PinholeCamera.framing(480, 270, lo, hi, k1=-0.15)
    seen, ideal = _camera_maps({"lens_edge_pct": -15 * np.tan(np.pi / 6) ** 2}, (480, 270))
    np.testing.assert_allclose(seen(flat.ideal_project(pts)), lens.project(pts), atol=1e-6)
    np.testing.assert_allclose(ideal(lens.project(pts)), flat.ideal_project(pts), atol=1e-6)
    # Tilt: the renderer's tilt_deg = 8 is ours, up to the similarity a calibration absorbs.
    tilted = PinholeCamera.framing(480, 270, lo, hi, tilt_deg=8.0)
    seen, _ = _camera_maps({"tilt_vertical_deg": 8.0}, (480, 270))
    assert _similarity_residual(flat.ideal_project(pts), tilted.ideal_project(pts)) > 5.0
    assert _similarity_residual(seen(flat.ideal_project(pts)), tilted.ideal_project(pts)) < 0.1


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_camera_theta_without_an_effect_is_the_angle_itself(side):
    from cranktrack.loop.camera_view import CameraView, camera_theta

    H = np.array([[0.5, 0.0, -40.0], [0.0, -0.5, 60.0], [0.0, 0.0, 1.0]])  # px → mm, y flipped
    Hi = np.linalg.inv(H)

    def apply(M, p):
        h = p @ M[:, :2].T + M[:, 2]
        return h[:, :2] / h[:, 2:]

    view = CameraView(lambda p: apply(H, p), lambda p: apply(Hi, p), (480, 270),
                      np.array([80.0, 120.0]), np.array([401.6, 120.0]), side)
    theta = np.radians(np.linspace(20.0, 160.0, 15))
    values = {"L1_mm": 160.8, "L2_mm": 72.4, "lens_edge_pct": 0.0}
    np.testing.assert_allclose(camera_theta(theta, values, view), theta, atol=1e-12)
    bent = camera_theta(theta, {**values, "lens_edge_pct": -5.0}, view)
    assert np.max(np.abs(bent - theta)) > np.radians(0.1)
