"""Render a small spool scene, track it, and compare with its truth."""

import numpy as np
import pandas as pd
import pytest

from cranktrack.loop.compare import error_summary, spool_model
from cranktrack.models.spool import SpoolDrive
from cranktrack.pipeline import track_run
from cranktrack.tables import kinematics_columns, track_mm_columns, track_px_columns

# At 320×240 the scene scale is 1.59 px/mm, so the crank A–B (72.4 mm) is 115 px
# long. A centre error of 0.25 px on each of A and B (1/15 of the 3.7 px marker
# radius) turns the crank by at most 0.5 / 115 rad = 0.25°: the bound for the
# per-frame angle and for the rocking angle (largest minus smallest θ).
THETA_BOUND_DEG = np.degrees(0.5 / 115)


@pytest.fixture(scope="module")
def run(small_h264, tmp_path_factory):
    return track_run(small_h264.video, tmp_path_factory.mktemp("run"), ("A", "C", 160.8))


def test_run_folder_has_the_contract_tables(run):
    tracks = pd.read_csv(run.folder / "tracks.csv")
    kin = pd.read_csv(run.folder / "kinematics.csv")
    assert set(track_px_columns()) | set(track_mm_columns()) <= set(tracks.columns)
    contract = kinematics_columns()
    assert list(kin.columns[: len(contract)]) == contract
    assert {"L1_mm", "L2_mm", "rigid_ok"} <= set(kin.columns)  # the rigid-link checks
    assert len(tracks) == len(kin) == 60
    assert (run.folder / "calibration.json").exists() and (run.folder / "run.json").exists()
    assert tracks[["A_ok", "B_ok", "C_ok"]].all().all()


def test_timestamps_come_from_the_container(run, small_h264):
    truth = pd.read_csv(small_h264.truth)
    np.testing.assert_allclose(run.tracks["t_s"], truth["t_s"], atol=1e-4)


def test_rocking_angle_within_the_pixel_scale_bound(run, small_h264):
    truth = pd.read_csv(small_h264.truth)
    err = run.kinematics["theta_deg"] - truth["theta_deg"]
    assert np.max(np.abs(err)) < THETA_BOUND_DEG
    rocking = np.ptp(run.kinematics["theta_deg"])
    assert rocking == pytest.approx(np.ptp(truth["theta_deg"]), abs=THETA_BOUND_DEG)
    # And the rocking angle is the thesis model's: 15 mm of the Table 2.2 bed.
    assert np.ptp(truth["theta_deg"]) == pytest.approx(20.80, abs=0.01)


def test_angular_velocity_matches_the_model_away_from_the_steps(run):
    drive = SpoolDrive()
    k = run.kinematics
    model = spool_model(drive, k["t_s"].to_numpy())
    t = k["t_s"].to_numpy()
    away = (np.abs(t - drive.start_s) > 0.2) & (np.abs(t - drive.stop_s) > 0.2)
    s = error_summary(k, model, mask=away).set_index("quantity")
    # θ noise ~0.05° over a 7-sample window gives ~0.01 rad/s; 5% of the 0.6 rad/s peak
    # leaves room for it.
    assert s.loc["omega_rad_s", "rms_pct_of_peak"] < 5.0
    assert s.loc["vB_mm_s", "rms_pct_of_peak"] < 5.0
    assert s.loc["omega_rad_s", "frames"] > 20


def test_calibrated_scale_matches_the_render(run, small_h264):
    import json

    scene = json.loads(small_h264.scene.read_text())
    assert run.calibration.quality["mm_per_px"] == pytest.approx(1 / scene["camera"]["px_per_mm"],
                                                      rel=2e-3)


def test_a_rolling_shutter_readout_reaches_the_kinematics_only(run, small_h264, tmp_path):
    # The render reads all its rows at once, so the truth here is only where the option
    # goes: the kinematics move (B is taken back by up to 3.5 ms of its motion), the
    # tracks stay as seen, and run.json records it.
    import json

    rolled = track_run(small_h264.video, tmp_path / "rolled", ("A", "C", 160.8),
                       readout_s=0.0035)
    pd.testing.assert_frame_equal(rolled.tracks, run.tracks)
    moved = np.abs(rolled.kinematics["theta_deg"] - run.kinematics["theta_deg"])
    assert 0 < np.nanmax(moved) < THETA_BOUND_DEG
    info = json.loads((tmp_path / "rolled" / "run.json").read_text())
    assert info["tracking"]["rolling_shutter_readout_s"] == 0.0035


def test_measuring_a_pixel_run_again_gives_what_tracking_with_the_options_gives(
        run, small_h264, tmp_path):
    # The second path to the same numbers is a whole `track` with the options: measuring
    # a run tracked in pixels alone, with a scale and a readout given afterwards, must
    # give its kinematics (to the 10 digits tracks.csv keeps), without the video.
    import json

    from cranktrack.pipeline import measure_run
    from cranktrack.run_folder import out_of_date

    tracked = track_run(small_h264.video, tmp_path / "tracked", ("A", "C", 160.8),
                        readout_s=0.0035)
    track_run(small_h264.video, tmp_path / "bare")
    assert not (tmp_path / "bare" / "kinematics.csv").exists()
    again = measure_run(tmp_path / "bare", ("A", "C", 160.8), readout_s=0.0035)
    pd.testing.assert_frame_equal(again.kinematics, tracked.kinematics, rtol=1e-3, atol=1e-5)
    assert np.nanmax(np.abs(again.kinematics["theta_deg"] - tracked.kinematics["theta_deg"])
                     ) < 1e-6
    on_disk = pd.read_csv(tmp_path / "bare" / "kinematics.csv")
    np.testing.assert_allclose(on_disk["theta_deg"], again.kinematics["theta_deg"], atol=1e-7)
    info = json.loads((tmp_path / "bare" / "run.json").read_text())
    assert info["tracking"]["rolling_shutter_readout_s"] == 0.0035
    assert info["calibration"]["known_length_mm"] == 160.8
    assert out_of_date(tmp_path / "bare") == []
    # Without a new scale the run's own calibration is used again; a readout of 0 takes
    # the correction off, which gives the run tracked without one.
    off = measure_run(tmp_path / "bare", readout_s=0.0)
    np.testing.assert_allclose(off.kinematics["theta_deg"], run.kinematics["theta_deg"],
                               atol=1e-6)
    # Both paths run one kinematics step (pipeline._measure_into), so the comparisons
    # above check what measure reads back and passes on. The physics is checked here
    # against the render's own truth, as for the tracked run.
    truth = pd.read_csv(small_h264.truth)
    assert np.max(np.abs(off.kinematics["theta_deg"] - truth["theta_deg"])) < THETA_BOUND_DEG
    info = json.loads((tmp_path / "bare" / "run.json").read_text())
    assert "rolling_shutter_readout_s" not in info["tracking"]


def _anamorphic_crank(path, aspect, frames=20):
    """A crank drawn in square pixels (A fixed, B on a 45 mm circle round it, C 160 mm
    along +x; 1 mm a pixel), stored squeezed to pixels ``aspect`` times as wide as high,
    with that sample aspect ratio, as DV and HDV camcorders store it. Returns B's drawn
    angle, deg, counter-clockwise from A→C."""
    import fractions

    import av
    import cv2

    h, w_square = 180, 320
    a, c = np.array([90.0, 100.0]), np.array([250.0, 100.0])
    phi = np.radians(30 + 50 * np.sin(2 * np.pi * np.arange(frames) / frames))
    up = 4  # drawn 4× larger and averaged down: edges to a sixteenth of a pixel
    with av.open(str(path), "w") as out:
        s = out.add_stream("libx264", rate=25, options={"crf": "4"})
        s.width, s.height, s.pix_fmt = round(w_square / aspect), h, "yuv420p"
        s.codec_context.sample_aspect_ratio = fractions.Fraction(aspect).limit_denominator(100)
        for k in range(frames):
            big = np.full((h * up, w_square * up, 3), (200, 200, 195), np.uint8)
            b = a + 45.0 * np.array([np.cos(phi[k]), -np.sin(phi[k])])
            for xy, rgb in ((a, (30, 160, 60)), (b, (200, 40, 40)), (c, (40, 60, 200))):
                centre = np.round(((xy + 0.5) * up - 0.5) * 64).astype(int)
                cv2.circle(big, tuple(int(v) for v in centre), 9 * up * 64, rgb, -1,
                           cv2.LINE_AA, 6)
            picture = cv2.resize(big, (s.width, h), interpolation=cv2.INTER_AREA)
            frame = av.VideoFrame.from_ndarray(picture, format="rgb24")
            frame.pts, frame.time_base = k, fractions.Fraction(1, 25)
            out.mux(s.encode(frame))
        out.mux(s.encode())
    return np.degrees(phi)


@pytest.mark.parametrize(("aspect", "rms_deg"), [(4 / 3, 0.25), (16 / 15, 0.08)])
def test_non_square_pixels_give_the_drawn_crank_angle(tmp_path, aspect, rms_deg):
    # HDV (1440×1080 shown 16:9) and DV camcorders store pixels wider than high. The
    # known length set one scale for x and y: θ came out up to 8.4° (4:3) and 1.8°
    # (16:15) off the drawn angle, with warnings blaming the camera's tilt.
    from cranktrack.pipeline import measure_run

    path = tmp_path / "anamorphic.mp4"
    truth = _anamorphic_crank(path, aspect)
    out = track_run(path, tmp_path / "run", known_length=("A", "C", 160.0))
    err = out.kinematics["theta_deg"].to_numpy() - truth
    assert np.sqrt(np.nanmean(err**2)) < rms_deg
    assert any("times as wide as high" in w for w in out.warnings)
    assert not any("rigid length" in w for w in out.warnings)
    again = measure_run(tmp_path / "run", known_length=("A", "C", 160.0))
    np.testing.assert_allclose(again.kinematics["theta_deg"], out.kinematics["theta_deg"])


def test_a_monochrome_cameras_rig_with_white_markers_gives_the_drawn_crank_angle(tmp_path):
    # Many lab and high-speed cameras record brightness alone. The crank-slider marked
    # with white dots and named A, B and C with their places is tracked as the printed
    # discs are, into θ; the markers found by hue are refused with one sentence.
    import fractions

    import av
    import cv2

    from cranktrack.errors import CranktrackError
    from cranktrack.tracker.markers import parse_markers

    path, up, frames = tmp_path / "mono.mkv", 4, 20
    a, c = np.array([90.0, 100.0]), np.array([250.0, 100.0])
    phi = np.radians(30 + 40 * np.sin(2 * np.pi * np.arange(frames) / frames))
    with av.open(str(path), "w") as out:
        s = out.add_stream("ffv1", rate=25)
        s.width, s.height, s.pix_fmt = 320, 180, "gray"
        for k in range(frames):
            big = np.full((180 * up, 320 * up), 60, np.uint8)
            b = a + 45.0 * np.array([np.cos(phi[k]), -np.sin(phi[k])])
            for xy in (a, b, c):
                centre = np.round(((xy + 0.5) * up - 0.5) * 64).astype(int)
                cv2.circle(big, tuple(int(v) for v in centre), 8 * up * 64, 230, -1,
                           cv2.LINE_AA, 6)
            frame = av.VideoFrame.from_ndarray(
                cv2.resize(big, (320, 180), interpolation=cv2.INTER_AREA), format="gray")
            frame.pts, frame.time_base = k, fractions.Fraction(1, 25)
            out.mux(s.encode(frame))
        out.mux(s.encode())
    with pytest.raises(CranktrackError, match="stored without colour"):
        track_run(path, tmp_path / "hued", known_length=("A", "C", 160.0))
    b0 = a + 45.0 * np.array([np.cos(phi[0]), -np.sin(phi[0])])
    specs = parse_markers(["A=white@90,100", f"B=white@{b0[0]:.0f},{b0[1]:.0f}",
                           "C=white@250,100"])
    run = track_run(path, tmp_path / "run", known_length=("A", "C", 160.0), specs=specs)
    err = run.kinematics["theta_deg"].to_numpy() - np.degrees(phi)
    assert np.sqrt(np.nanmean(err**2)) < 0.02  # 0.006° here
