"""The command line: the demo, and one clear sentence for bad input."""

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from cranktrack.cli import _path_hint, main
from cranktrack.errors import CranktrackError
from cranktrack.files import replace_folder


def _run(*args: str, cwd=None) -> subprocess.CompletedProcess:
    # A real process, so we see exactly what a user sees (and any traceback).
    return subprocess.run([sys.executable, "-m", "cranktrack.cli", *args],
                          capture_output=True, text=True, timeout=300, cwd=cwd)


def test_demo_prints_the_table_and_replaces_its_own_folder(tmp_path):
    old = tmp_path / "demo-output"
    old.mkdir()
    (old / ".cranktrack-demo").write_text("")
    (old / "from-last-time.txt").write_text("")
    p = _run("demo", "--size", "320x240", "--seconds", "2", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "theta_deg (all frames)" in p.stdout and "omega_rad_s" in p.stdout
    assert "outputs: demo-output" in p.stdout
    assert not (old / "from-last-time.txt").exists()
    for name in ("scene/video.mp4", "scene/truth.csv", "run/tracks.csv", "run/kinematics.csv"):
        assert (old / name).exists()


def test_a_folder_cranktrack_did_not_make_is_never_cleared(tmp_path):
    mine = tmp_path / "demo-output"
    mine.mkdir()
    (mine / "thesis.tex").write_text("precious")
    with pytest.raises(CranktrackError, match="not made by cranktrack"):
        replace_folder(mine, ".cranktrack-demo")
    assert (mine / "thesis.tex").read_text() == "precious"
    empty = tmp_path / "empty"
    empty.mkdir()
    assert (replace_folder(empty, ".stamp") / ".stamp").is_file()


def test_a_venv_command_off_path_says_how_to_type_it(tmp_path, monkeypatch):
    bin_ = tmp_path / ".venv" / "bin"
    bin_.mkdir(parents=True)
    (bin_ / "cranktrack").write_text("")
    (bin_ / "activate").write_text("")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [str(bin_ / "cranktrack")])
    monkeypatch.setenv("PATH", "/nonexistent")
    assert "source .venv/bin/activate" in _path_hint()
    monkeypatch.setenv("PATH", str(bin_))
    (bin_ / "cranktrack").chmod(0o755)
    assert _path_hint() == ""


def test_synth_then_track(tmp_path, capsys):
    assert main(["synth", "spool", "--out", str(tmp_path / "s"), "--size", "160x120",
                 "--seconds", "1", "--noise", "0"]) == 0
    assert main(["track", str(tmp_path / "s" / "video.mp4"), "--out", str(tmp_path / "r")]) == 0
    out = capsys.readouterr().out
    assert "no --known-length" in out
    tracks = pd.read_csv(tmp_path / "r" / "tracks.csv")
    assert len(tracks) == 30 and "A_x_mm" not in tracks
    assert not (tmp_path / "r" / "kinematics.csv").exists()
    # Without kinematics the report shows the tracks.
    assert "tracks.png" in out and "![tracks](tracks.png)" in (tmp_path / "r" / "report.md"
                                                               ).read_text()


def test_parquet_tables_hold_what_the_csv_files_hold_and_leave_with_the_run(
        small_h264, tmp_path, capsys):
    run = tmp_path / "r"
    args = ["track", str(small_h264.video), "--out", str(run), "--known-length", "A-C=160.8"]
    assert main([*args, "--format", "parquet"]) == 0
    assert "tracks.parquet, kinematics.parquet" in capsys.readouterr().out
    for name in ("tracks", "kinematics"):
        csv, parquet = pd.read_csv(run / f"{name}.csv"), pd.read_parquet(run / f"{name}.parquet")
        assert list(parquet.columns) == list(csv.columns) and len(parquet) == len(csv)
        for col in csv.columns:
            if not pd.api.types.is_float_dtype(csv[col]):
                assert (parquet[col].astype(str) == csv[col].astype(str)).all(), col
            else:  # the CSV keeps 10 significant digits, Parquet all of them
                pd.testing.assert_series_equal(parquet[col].astype(float),
                                               csv[col].astype(float), rtol=1e-9)
    # Measured again, the Parquet copies are rewritten with the CSV files.
    assert main(["measure", str(run), "--rolling-shutter-ms", "3"]) == 0
    pd.testing.assert_series_equal(pd.read_parquet(run / "kinematics.parquet")["theta_deg"],
                                   pd.read_csv(run / "kinematics.csv")["theta_deg"], rtol=1e-9)
    assert main(args) == 0  # a CSV-only rerun must not leave the old Parquet beside it
    assert not list(run.glob("*.parquet"))


def _one_sentence_error(p: subprocess.CompletedProcess, *words: str) -> None:
    assert p.returncode != 0
    assert "Traceback" not in p.stderr
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, p.stderr
    for w in words:
        assert w in lines[0]


def test_missing_video(tmp_path):
    _one_sentence_error(_run("track", str(tmp_path / "nope.mp4"), "--out", str(tmp_path / "r")),
                        "nope.mp4", "does not exist")


def test_text_file_named_mp4(tmp_path):
    fake = tmp_path / "notes.mp4"
    fake.write_text("this is not a video\n" * 20)
    _one_sentence_error(_run("track", str(fake), "--out", str(tmp_path / "r")),
                        "notes.mp4", "not a video")


def test_empty_file(tmp_path):
    empty = tmp_path / "empty.mp4"
    empty.touch()
    _one_sentence_error(_run("track", str(empty), "--out", str(tmp_path / "r")), "empty")


def _green_disc_pictures(folder, stem: str, places: list[tuple[int, int]],
                         size: tuple[int, int]):
    """A folder of numbered PNGs (``stem`` 00, 01, …), each a green disc of 8 px at its
    place (whole px) on a dark ground of ``size`` (height, width)."""
    import cv2

    folder.mkdir()
    for k, place in enumerate(places):
        image = np.full((*size, 3), 30, np.uint8)
        cv2.circle(image, place, 8, (40, 200, 60), -1)  # BGR: green
        cv2.imwrite(str(folder / f"{stem}{k:02d}.png"), image)
    return folder


def test_one_picture_of_a_sequence_is_inspected_and_its_folder_tracked(tmp_path, capsys,
                                                                       monkeypatch):
    # A user who opens Tracker's "…00.jpg" is shown that frame, and told the command
    # that tracks the folder; the PNG is written beside the folder, not among its frames.
    frames = _green_disc_pictures(tmp_path / "car", "car", [(40 + 5 * k, 45) for k in range(3)],
                                  (90, 120))
    one = frames / "car00.png"
    _one_sentence_error(_run("track", str(one), "--out", str(tmp_path / "r")),
                        "car00.png", "one of 3 numbered pictures", "--fps")
    assert main(["inspect", str(one)]) == 0
    out = capsys.readouterr().out
    assert f"cranktrack track {frames} --fps FPS --marker" in out
    assert sorted(q.name for q in frames.iterdir()) == ["car00.png", "car01.png", "car02.png"]
    assert (tmp_path / "car_car00_inspect.png").exists()
    command = next(line for line in out.splitlines() if "cranktrack track" in line)
    monkeypatch.chdir(tmp_path)
    assert main(command.replace("FPS", "25").split()[1:]) == 0
    assert len(pd.read_csv(tmp_path / "run" / "tracks.csv")) == 3


def test_inspect_at_a_later_time_suggests_tracking_from_that_frame(tmp_path, capsys,
                                                                    monkeypatch):
    # The places inspect lists are those of the frame it shows, and @X,Y is where a
    # marker is when tracking starts: a ball falling 12 px a frame, placed where it is a
    # second in, was never there in the frames before. The command starts where the
    # places hold, and the picture goes where --out says, its folder made.
    frames = _green_disc_pictures(tmp_path / "drop", "d", [(60, 20 + 12 * k) for k in range(20)],
                                  (300, 120))
    picture = tmp_path / "new" / "folder" / "at1s.png"
    assert main(["inspect", str(frames), "--fps", "10", "--at", "1", "--out",
                 str(picture)]) == 0
    out = capsys.readouterr().out
    assert picture.exists()
    command = next(line for line in out.splitlines() if "cranktrack track" in line)
    assert " --start 10f " in command and "@60,140" in command, command
    monkeypatch.chdir(tmp_path)
    assert main(command.split()[1:]) == 0
    tracks = pd.read_csv(tmp_path / "run" / "tracks.csv")
    assert tracks["frame"].tolist() == list(range(10, 20))
    ok = [c for c in tracks.columns if c.endswith("_ok")]
    assert len(ok) >= 1 and tracks[ok[0]].all(), tracks


def test_inspect_says_what_the_file_says_of_its_pictures(tmp_path, capsys):
    # A phone's upright clip is shown turned: the places inspect lists are in the
    # turned picture, and the user is told so before the first `track`.
    import fractions

    import av

    path = tmp_path / "phone.mp4"
    with av.open(str(path), "w") as out:
        s = out.add_stream("libx264", rate=10)
        s.width, s.height, s.pix_fmt = 64, 48, "yuv420p"
        s.set_display_rotation(90)
        frame = av.VideoFrame.from_ndarray(np.full((48, 64, 3), 90, np.uint8), format="rgb24")
        frame.pts, frame.time_base = 0, fractions.Fraction(1, 10)
        out.mux(s.encode(frame))
        out.mux(s.encode())
    assert main(["inspect", str(path), "--out", str(tmp_path / "i.png")]) == 0
    assert "a quarter turn counter-clockwise" in capsys.readouterr().out


def test_bad_known_length(small_h264, tmp_path):
    _one_sentence_error(_run("track", str(small_h264.video), "--out", str(tmp_path / "r"),
                             "--known-length", "A-C"), "NAME-NAME=MILLIMETRES")


@pytest.mark.parametrize("options, says", [
    (["--known-length", "A-C=inf"], "positive, finite"),
    (["--known-length", "A-Q=5"], "Q, not among the tracked markers A, B, C"),
    (["--marker", "B=400"], "outside 0–360°"),
    (["--known-length", "A-C=160.8", "--window-s", "100"], "more than half the video"),
    (["--known-length", "A-C=160.8", "--rolling-shutter-ms", "40"], "does not fit in one frame"),
])
def test_bad_values_are_refused_before_tracking(small_h264, tmp_path, capsys, options, says):
    assert main(["track", str(small_h264.video), "--out", str(tmp_path / "r"), *options]) == 1
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()  # refused before a frame was tracked


def test_a_negative_gap_length_is_refused(small_h264, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["track", str(small_h264.video), "--out", str(tmp_path / "r"), "--fill-gaps", "-3"])
    assert e.value.code == 2 and "must be 0 or more" in capsys.readouterr().err


def test_marker_colour_absent_keeps_tracks_and_explains(small_h264, tmp_path):
    # B is asked to be yellow; there is no yellow in the scene.
    p = _run("track", str(small_h264.video), "--out", str(tmp_path / "r"),
             "--known-length", "A-C=160.8", "--marker", "B=yellow")
    _one_sentence_error(p, "marker B", "not found in any frame", "tracks.csv")
    assert (tmp_path / "r" / "tracks.csv").exists()  # work done so far is kept


def test_impossible_stroke_is_refused(tmp_path):
    _one_sentence_error(_run("synth", "spool", "--out", str(tmp_path), "--stroke-mm", "18"),
                        "stroke of 18.0 mm")


@pytest.mark.parametrize("bad", [["--size", "big"], ["--fps", "-3"]])
def test_bad_option_values_exit_2(bad, tmp_path):
    p = _run("synth", "spool", "--out", str(tmp_path), *bad)
    assert p.returncode == 2 and "Traceback" not in p.stderr


def _on_a_terminal(*args: str) -> str:
    """What a command writes to a terminal (a pseudo-terminal here), CI variable unset."""
    import fcntl
    import os
    import pty
    import struct
    import termios

    master, slave = pty.openpty()
    # A new pseudo-terminal is 0 columns wide, and tqdm draws a bar of the terminal's width.
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    p = subprocess.Popen([sys.executable, "-m", "cranktrack.cli", *args], stdin=slave,
                         stdout=slave, stderr=slave, env=env, close_fds=True)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # the other end closed: the process is done
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    assert p.wait(timeout=120) == 0
    return b"".join(chunks).decode(errors="replace")


def test_track_shows_progress_on_a_terminal_and_none_with_quiet(tmp_path):
    assert main(["synth", "spool", "--out", str(tmp_path / "s"), "--size", "320x240",
                 "--seconds", "1", "--noise", "0", "--quiet"]) == 0
    video = str(tmp_path / "s" / "video.mp4")
    shown = _on_a_terminal("track", video, "--out", str(tmp_path / "r1"), "--known-length",
                           "A-C=160.8")
    # The frames, then the steps after them on the same bar.
    assert "/30 [" in shown and "track: kinematics" in shown and "track: report" in shown
    quiet = _on_a_terminal("track", video, "--out", str(tmp_path / "r2"), "--quiet")
    assert "/30 [" not in quiet and "track:" not in quiet and "wrote" in quiet
    # compare (a fit, figures and a report: seconds) names its step on the same terms.
    shown = _on_a_terminal("compare", str(tmp_path / "r1"))
    assert "compare: fit" in shown and "compare: report" in shown and "wrote" in shown
    quiet = _on_a_terminal("compare", str(tmp_path / "r1"), "--quiet")
    assert "compare:" not in quiet and "wrote" in quiet


def test_calibrate_readout_reads_a_runs_flight_and_says_what_to_type(tmp_path, capsys):
    import json

    import numpy as np
    from test_calibration import _drawn_flight

    t, xy = _drawn_flight(0.007, np.random.default_rng(2))
    run = tmp_path / "toss"
    run.mkdir()
    pd.DataFrame({"frame": np.arange(len(t)), "t_s": t, "ball_x_px": xy[:, 0],
                  "ball_y_px": xy[:, 1], "ball_sigma_px": 0.05, "ball_ok": True,
                  "ball_status": "ok"}).to_csv(run / "tracks.csv", index=False)
    (run / "run.json").write_text(json.dumps({"source": {"height": 480}}))
    assert main(["calibrate", "readout", str(run), "--marker", "ball"]) == 0
    out = capsys.readouterr().out
    assert "--rolling-shutter-ms 7.0" in out or "--rolling-shutter-ms 6.9" in out, out
    assert main(["calibrate", "readout", str(run), "--marker", "bob"]) == 1
    err = capsys.readouterr().err
    assert "has no marker bob; it has ball" in err and err.count("\n") == 1


def test_measure_adds_kinematics_to_a_pixel_run_and_refuses_in_one_sentence(
        small_h264, tmp_path, capsys):
    run = tmp_path / "r"
    assert main(["track", str(small_h264.video), "--out", str(run)]) == 0
    assert "cranktrack measure" in capsys.readouterr().out  # the pixel run says how
    assert (run / "tracks.png").exists()
    for options, says in [([], "has no calibration yet"),
                          (["--known-length", "A-Q=5"], "Q, not among the run's markers"),
                          (["--known-length", "A-C=160.8", "--rolling-shutter-ms", "40"],
                           "does not fit in one frame"),
                          (["--known-length", "A-C=160.8", "--window-s", "5"],
                           "more than half the run")]:
        assert main(["measure", str(run), *options]) == 1
        err = capsys.readouterr().err
        assert says in err and err.count("\n") == 1, err
        assert not (run / "kinematics.csv").exists()
    assert main(["measure", str(tmp_path / "nowhere")]) == 1
    assert "is not a folder" in capsys.readouterr().err
    from cranktrack.run_folder import TRACKER_STATE

    (run / TRACKER_STATE).write_bytes(b"")  # as an interrupted track leaves it
    assert main(["measure", str(run), "--known-length", "A-C=160.8"]) == 1
    assert "was interrupted" in capsys.readouterr().err
    (run / TRACKER_STATE).unlink()
    assert main(["measure", str(run), "--known-length", "A-C=160.8",
                 "--rolling-shutter-ms", "3"]) == 0
    out = capsys.readouterr().out
    assert "rolling shutter 3 ms" in out and "kinematics.csv" in out
    assert len(pd.read_csv(run / "kinematics.csv")) == len(pd.read_csv(run / "tracks.csv"))
    # The report now shows the kinematics, and the pixel run's figure is gone.
    assert (run / "kinematics.png").exists() and not (run / "tracks.png").exists()
    # A compare made before a second measure stands on the kinematics it replaced.
    assert main(["compare", str(run), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["measure", str(run), "--rolling-shutter-ms", "0"]) == 0
    err = capsys.readouterr().err
    assert "made from an earlier kinematics.csv; run `cranktrack compare` again" in err


def test_a_pixel_run_is_told_a_command_that_works_for_the_markers_it_tracked(
        small_h264, tmp_path, capsys):
    # A run of other markers was told to add `--known-length A-C=MM`, which `measure`
    # then refused: "marker A is not tracked". Each hint is now run as printed.
    import re
    import shlex

    run = tmp_path / "abc"
    assert main(["track", str(small_h264.video), "--out", str(run)]) == 0
    hint = re.search(r"`(cranktrack measure [^`]*)`", capsys.readouterr().out).group(1)
    assert main(shlex.split(hint.replace("=MM", "=160.8"))[1:]) == 0
    assert (run / "kinematics.csv").exists()
    capsys.readouterr()
    other = tmp_path / "ball"
    assert main(["track", str(small_h264.video), "--marker", "ball=green",
                 "--out", str(other)]) == 0
    out = capsys.readouterr().out
    assert "--known-length A-C" not in out, out
    # Other markers are told of a ruler, and that hint too runs as printed.
    hint = re.search(r"`(cranktrack measure [^`]*)`", out).group(1)
    assert main(shlex.split(hint.replace("X1,Y1,X2,Y2=MM", "0,0,50,0=100"))[1:]) == 0
    assert (other / "motion.csv").exists() and not (other / "kinematics.csv").exists()


def test_calibrate_readout_from_two_markers_on_a_bar_shaken_sideways(tmp_path, capsys):
    import json

    import numpy as np
    from test_calibration import _drawn_bar

    t, top, bottom = _drawn_bar(0.007, np.random.default_rng(7))
    run = tmp_path / "ruler"
    run.mkdir()
    table = {"frame": np.arange(len(t)), "t_s": t}
    for name, xy in (("top", top), ("bottom", bottom)):
        table |= {f"{name}_x_px": xy[:, 0], f"{name}_y_px": xy[:, 1], f"{name}_sigma_px": 0.05,
                  f"{name}_ok": True, f"{name}_status": "ok"}
    pd.DataFrame(table).to_csv(run / "tracks.csv", index=False)
    (run / "run.json").write_text(json.dumps({"source": {"height": 480}}))
    assert main(["calibrate", "readout", str(run), "--marker", "top", "--marker", "bottom"]) == 0
    out = capsys.readouterr().out
    import re

    typed = float(re.search(r"track this camera with: --rolling-shutter-ms ([\d.]+)", out)[1])
    assert "top and bottom on one bar" in out and abs(typed - 7.0) < 0.1, out
    assert main(["calibrate", "readout", str(run), "--marker", "top", "--marker", "bottom",
                 "--marker", "top"]) == 1
    assert "not 3 times" in capsys.readouterr().err



def test_a_crank_tracked_without_c_has_its_angle_from_the_x_axis(small_h264, tmp_path, capsys):
    """`--marker C=none`: A and B alone, scaled by |AB| (72.4 mm on the render). θ is
    A→B's angle from the image's x direction (y turned up), against the render's own
    A and B; `compare` and `fit` refuse the run in one sentence."""
    run = tmp_path / "arm"
    assert main(["track", str(small_h264.video), "--out", str(run), "--marker", "C=none",
                 "--known-length", "A-B=72.4"]) == 0
    assert "no marker C" in capsys.readouterr().err
    k = pd.read_csv(run / "kinematics.csv")
    truth = pd.read_csv(small_h264.truth)
    drawn = np.degrees(np.arctan2(-(truth["B_y_px"] - truth["A_y_px"]),
                                  truth["B_x_px"] - truth["A_x_px"]))
    err = (k["theta_deg"] - drawn).to_numpy()
    assert np.isfinite(err).sum() > 50 and np.sqrt(np.nanmean(err**2)) < 0.1
    assert "C_x_px" not in pd.read_csv(run / "tracks.csv")
    _one_sentence_error(_run("compare", str(run)), "without marker C", "compare")
    _one_sentence_error(_run("fit", str(run), "--known", "L1_mm=160.8"), "without marker C")
