"""Known-length calibration, the plane frame and the calibration file."""

import json

import numpy as np
import pandas as pd
import pytest

from cranktrack.calibration.file import load_calibration, save_calibration
from cranktrack.calibration.known_length import calibrate_known_length, parse_known_length
from cranktrack.calibration.plane import add_plane_coordinates
from cranktrack.errors import CranktrackError
from cranktrack.synthetic.camera import Camera


def _tracks_from_camera(cam: Camera, n: int = 20, jitter: float = 0.0) -> pd.DataFrame:
    rng = np.random.default_rng(0)
    theta = np.linspace(0.5, 0.3, n)
    pts = {"A": np.zeros((n, 2)), "B": 72.4 * np.stack([np.cos(theta), np.sin(theta)], 1),
           "C": np.tile([160.8, 0.0], (n, 1))}
    cols = {"frame": np.arange(n), "t_s": np.arange(n) / 30}
    for m, xy in pts.items():
        uv = cam.project(xy) + rng.normal(0, jitter, (n, 2))
        cols |= {f"{m}_x_px": uv[:, 0], f"{m}_y_px": uv[:, 1], f"{m}_sigma_px": np.full(n, 0.1),
                 f"{m}_ok": np.ones(n, bool)}
    return pd.DataFrame(cols), pts


def test_known_length_recovers_scale_and_plane_frame_of_a_rotated_camera():
    cam = Camera(640, 480, 2.5, (200.0, 300.0), rotation_deg=17.0)
    tracks, pts = _tracks_from_camera(cam)
    cal = calibrate_known_length(tracks, "A", "C", 160.8, (640, 480))
    assert cal.quality["mm_per_px"] == pytest.approx(1 / 2.5)
    assert cal.quality["x_axis_deg"] == pytest.approx(17.0)
    out = add_plane_coordinates(tracks, cal, ("A", "B", "C"))
    np.testing.assert_allclose(out[["B_x_mm", "B_y_mm"]].to_numpy(), pts["B"], atol=1e-9)
    np.testing.assert_allclose(out["B_sigma_mm"], 0.1 / 2.5)
    assert not cal.warnings


def test_a_length_that_varies_is_reported():
    cam = Camera(640, 480, 2.5, (200.0, 300.0))
    tracks, _ = _tracks_from_camera(cam)
    tracks.loc[10:, "C_x_px"] += 12.0  # the "rigid" frame grows by ~4.8 mm (3%)
    cal = calibrate_known_length(tracks, "A", "C", 160.8, (640, 480))
    scale = cal.quality["mm_per_px"]
    assert cal.quality["length_range_mm"] == pytest.approx(12.0 * scale, rel=1e-6)
    # half the frames at each length: a 1σ spread of half the jump, 1.5%
    assert cal.quality["length_relative_spread"] == pytest.approx(6.0 * scale / 160.8)
    assert cal.warnings and "tilted" in cal.warnings[0]


def test_file_round_trip_and_refusals(tmp_path):
    cam = Camera(640, 480, 2.5, (200.0, 300.0), rotation_deg=-5.0)
    tracks, _ = _tracks_from_camera(cam)
    cal = calibrate_known_length(tracks, "A", "C", 160.8, (640, 480))
    path = save_calibration(tmp_path / "cal.json", cal)
    again = load_calibration(path, image_size=(640, 480))
    assert again.quality["mm_per_px"] == pytest.approx(cal.quality["mm_per_px"])
    assert again.quality["x_axis_deg"] == pytest.approx(cal.quality["x_axis_deg"])
    with pytest.raises(CranktrackError, match="made for 640x480"):
        load_calibration(path, image_size=(1280, 720))
    data = json.loads(path.read_text())
    data["schema"] = 99
    (tmp_path / "future.json").write_text(json.dumps(data))
    with pytest.raises(CranktrackError, match="schema 99"):
        load_calibration(tmp_path / "future.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(CranktrackError, match="not valid JSON"):
        load_calibration(tmp_path / "bad.json")


@pytest.mark.parametrize("text", ["A-C", "A=3", "A-A=3", "A-C=-1", "A-C=x"])
def test_bad_known_length_is_one_clear_error(text):
    with pytest.raises(CranktrackError, match="known-length"):
        parse_known_length(text)


def test_markers_never_seen_together_cannot_calibrate():
    cam = Camera(640, 480, 2.5, (200.0, 300.0))
    tracks, _ = _tracks_from_camera(cam)
    tracks["C_ok"] = False
    with pytest.raises(CranktrackError, match="never found in the same frame"):
        calibrate_known_length(tracks, "A", "C", 160.8, (640, 480))


def test_plane_scale_sigma_matches_the_scatter_of_refits():
    # A second method for the reported scale σ: refit the same 4×6 board points
    # with fresh pixel noise many times and measure the spread of the local scale.
    from cranktrack.calibration.plane import points_plane

    rng = np.random.default_rng(5)
    mm = np.array([[x, y] for x in range(0, 100, 20) for y in range(0, 80, 20)], float)
    px = 3.0 * mm + [100.0, 50.0]
    scales, reported = [], []
    for _ in range(300):
        cal = points_plane(px + rng.normal(0, 0.3, px.shape), mm, (640, 480), None)
        scales.append(float(cal.mm_per_px(np.array([250.0]), np.array([140.0]))[0]))
        reported.append(cal.scale_sigma)
    measured = np.std(scales) / np.mean(scales)
    # 300 refits pin the spread to ±4 %; the first-order σ is that of a similarity,
    # which a homography's extra freedom widens a little.
    print(f"scale σ reported {np.median(reported):.3g}, refits {measured:.3g}")
    assert np.median(reported) == pytest.approx(measured, rel=0.25)


def test_known_length_scale_sigma_is_the_two_markers_sigma_over_the_length(tmp_path):
    cam = Camera(640, 480, 2.5, (200.0, 300.0))
    tracks, _ = _tracks_from_camera(cam)  # σ 0.1 px per marker, A–C 402 px apart
    cal = calibrate_known_length(tracks, "A", "C", 160.8, (640, 480))
    assert cal.scale_sigma == pytest.approx(np.hypot(0.1, 0.1) / (160.8 * 2.5), rel=1e-6)
    again = load_calibration(save_calibration(tmp_path / "c.json", cal))
    assert again.scale_sigma == cal.scale_sigma


def _drawn_flight(readout_s: float, rng: np.random.Generator, noise_px: float = 0.05,
                  height: int = 480) -> tuple[np.ndarray, np.ndarray]:
    """A ball thrown up and across (4000 px/s² down, 30 fps) as a camera reading its rows
    over ``readout_s`` sees it: each fix at the time its row was read."""
    t = np.arange(20) / 30.0

    def at(time):
        return np.c_[120.0 + 700.0 * time, 300.0 - 900.0 * time + 2000.0 * time**2]

    seen = t.copy()
    for _ in range(6):
        seen = t + readout_s * at(seen)[:, 1] / height
    return t, at(seen) + rng.normal(0.0, noise_px, (len(t), 2))


def _over_draws(fit, draws: int = 40) -> tuple[list, np.ndarray, float]:
    """``fit()`` over ``draws`` noise draws: the fits, the readouts found (s), and the
    median jackknife σ over the readouts' scatter (≈ 1 for an honest σ)."""
    fits = [fit() for _ in range(draws)]
    found = np.array([f.readout_s for f in fits])
    return fits, found, float(np.median([f.readout_sigma_s for f in fits]) / found.std())


def test_a_rolling_shutters_readout_is_found_from_a_free_flight():
    """Drawn flights (the truth: a parabola, read row by row over 7 ms, or all at once).
    The jackknife σ is checked against the scatter of the readout over 40 noise draws
    (a second method)."""
    from cranktrack.calibration.readout import readout_from_flight

    rng = np.random.default_rng(11)
    fits, found, ratio = _over_draws(lambda: readout_from_flight(*_drawn_flight(0.007, rng),
                                                                 480))
    assert abs(found.mean() - 0.007) < 0.0003, found.mean()
    assert 0.6 < ratio < 1.7, ratio
    assert all(f.residual_px < f.residual_global_px for f in fits)
    assert np.median([f.acceleration_px_s2 for f in fits]) == pytest.approx(4000.0, rel=0.005)
    still = readout_from_flight(*_drawn_flight(0.0, rng), 480)
    assert abs(still.readout_s) < 3 * still.readout_sigma_s


def test_a_flight_plane_turned_to_the_camera_passes_for_a_readout_and_is_said_to():
    """The limit of one toss. Drawn here: a ball thrown 1 m/s across and 3 m/s up in a
    vertical plane 5 m away, turned by 10° about the vertical towards the camera, seen
    through a pinhole (f 500 px) with all rows read at once. The readout fit bends the
    time to the flight's perspective and finds many ms; the tilted plane fits it to its
    noise, and the fit says that it does."""
    from cranktrack.calibration.readout import readout_from_flight

    t = np.arange(20) / 30.0
    x, y = 0.5 + 1.0 * t, 1.0 + 3.0 * t - 4.9 * t**2  # m, in the flight's plane
    turn = np.radians(10.0)
    depth = 5.0 + x * np.sin(turn)
    xy = np.c_[320 + 500 * x * np.cos(turn) / depth, 400 - 500 * y / depth]
    fit = readout_from_flight(t, xy + np.random.default_rng(4).normal(0, 0.05, xy.shape), 480)
    assert abs(fit.readout_s) > 0.01 and abs(fit.readout_s) > 4 * fit.readout_sigma_s
    assert fit.residual_tilted_px < 0.07 and fit.tilt_explains_it


def _drawn_bar(readout_s: float, rng: np.random.Generator, breathe: float = 0.0,
               noise_px: float = 0.05, height: int = 480) -> tuple:
    """A ruler held upright with markers 280 rows apart, shaken sideways at 1.2 Hz (150 px
    each way), 60 frames at 30 fps, each marker seen when its row is read. ``breathe``
    moves the ruler towards the camera and back in step with its sideways position
    (its image grows by that fraction at one end of the shake): perspective alone."""
    t = np.arange(60) / 30.0

    def at(time: np.ndarray, row: float) -> np.ndarray:
        phase = np.sin(2 * np.pi * 1.2 * time)
        scale = 1.0 + breathe * phase
        return np.c_[320.0 + 150.0 * phase, 240.0 + (row - 240.0) * scale]

    seen = [at(t + readout_s * row / height, row) for row in (100.0, 380.0)]
    return t, *(s + rng.normal(0.0, noise_px, s.shape) for s in seen)


def test_a_readout_from_a_ruler_shaken_sideways_is_not_perspective():
    """Drawn here: a rigid ruler shaken sideways, read row by row over 7 ms, or all at
    once while it also moves in depth (perspective alone). The jackknife σ is checked
    against the scatter over 40 noise draws (a second method)."""
    from cranktrack.calibration.readout import readout_from_pair

    rng = np.random.default_rng(5)
    fits, found, ratio = _over_draws(lambda: readout_from_pair(*_drawn_bar(0.007, rng), 480))
    # Within 50 µs: a three-point velocity, 1 % slow at this shake, put it 80 µs high.
    assert abs(found.mean() - 0.007) < 0.00005, found.mean()
    assert 0.5 < ratio < 2.0, ratio
    assert all(f.residual_px < 0.2 * f.residual_global_px for f in fits)
    # A ruler coming 5 % nearer and going back in step with the shake, read at once:
    # its image size changes, but not with its speed, so no readout is found.
    deep = readout_from_pair(*_drawn_bar(0.0, rng, breathe=0.05), 480)
    assert abs(deep.readout_s) < max(3 * deep.readout_sigma_s, 0.0005), deep


def test_a_ruler_pair_refuses_markers_on_one_row_and_a_ruler_that_did_not_move():
    from cranktrack.calibration.readout import readout_from_pair

    t, a, _ = _drawn_bar(0.007, np.random.default_rng(6))
    with pytest.raises(CranktrackError, match="rows apart"):
        readout_from_pair(t, a, a + np.array([0.0, 20.0]), 480)
    still = np.tile(a[:1], (len(t), 1))
    with pytest.raises(CranktrackError, match="hardly moved"):
        readout_from_pair(t, still, still + np.array([0.0, 280.0]), 480)


def ruler_pictures(folder, readout_s: float, shake_px: float, shake_hz: float,
                   noise_dn: float = 1.0, frames: int = 45, fps: float = 30.0) -> None:
    """A ruler with a red disc (row 50) and a blue one (row 190), radius 6 px, shaken
    sideways by ``shake_px`` at ``shake_hz``, drawn into ``folder`` as 320×240 PNGs the
    way a rolling shutter reads it: each row at its own time, over ``readout_s``."""
    import cv2

    height, width = 240, 320
    rows = np.arange(height)
    sub = (np.arange(8) + 0.5) / 8 - 0.5  # 8 × 8 samples per pixel
    yy = rows[:, None, None, None] + sub[None, :, None, None]
    xx = np.arange(width)[None, None, :, None] + sub[None, None, None, :]
    rng = np.random.default_rng(8)
    for k in range(frames):
        seen = k / fps + readout_s * rows / height  # each row read at its own time
        x = 160.0 + shake_px * np.sin(2 * np.pi * shake_hz * seen)  # the ruler, per row
        picture = np.full((height, width, 3), 200.0)
        for row0, colour in ((50.0, (40, 40, 220)), (190.0, (220, 60, 40))):  # BGR
            inside = (xx - x[:, None, None, None]) ** 2 + (yy - row0) ** 2 < 36.0
            cover = inside.mean(axis=(1, 3))[..., None]
            picture = picture * (1 - cover) + np.array(colour, float) * cover
        picture += rng.normal(0.0, noise_dn, picture.shape)
        cv2.imwrite(str(folder / f"{k:03d}.png"), np.clip(picture, 0, 255).astype(np.uint8))


def test_a_ruler_drawn_row_by_row_is_tracked_and_gives_its_readout(tmp_path):
    """End to end on pixels: the ruler of :func:`ruler_pictures` (its rows drawn at their
    own times here, apart from the fit), tracked from a folder of pictures, then
    `calibrate readout`'s fit."""
    from cranktrack.pipeline import readout_from_run, track_run
    from cranktrack.tracker.markers import parse_markers

    (tmp_path / "frames").mkdir()
    ruler_pictures(tmp_path / "frames", 0.020, 40.0, 1.0)
    specs = parse_markers(["top=red@160,50", "bottom=blue@160,190"])
    track_run(tmp_path / "frames", tmp_path / "run", specs=specs, fps=30.0)
    fit = readout_from_run(tmp_path / "run", "top", second="bottom")
    assert fit.fixes >= 35
    assert fit.readout_s == pytest.approx(0.020, abs=max(3 * fit.readout_sigma_s, 0.0005))
