"""Damaged and wrong input, built by the tests: one clear sentence, no traceback,
work done kept."""

import errno
import json
import subprocess
import sys

import pandas as pd
import pytest

import cranktrack.files as files
from cranktrack.cli import main


def _run(*args):
    return subprocess.run([sys.executable, "-m", "cranktrack.cli", *args], capture_output=True,
                          text=True, timeout=300)


def test_truncated_video_keeps_the_tracks_up_to_the_damage(small_h264, tmp_path):
    data = small_h264.video.read_bytes()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(data[: len(data) // 2])
    p = _run("track", str(cut), "--out", str(tmp_path / "run"), "--known-length", "A-C=160.8")
    assert p.returncode == 0 and "Traceback" not in p.stderr
    assert "truncated or damaged" in p.stderr
    tracks = pd.read_csv(tmp_path / "run" / "tracks.csv")
    assert 10 < len(tracks) < 60  # what could be decoded, not invented


def test_a_run_that_fails_still_tells_what_went_wrong_with_the_video(small_h264, tmp_path,
                                                                     capsys):
    # Cut short and asked for a colour that is not there: the error is about the marker,
    # but the damage found on the way is printed first, since it may be the real cause.
    data = small_h264.video.read_bytes()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(data[: len(data) // 2])
    assert main(["track", str(cut), "--out", str(tmp_path / "run"), "--known-length",
                 "A-C=160.8", "--marker", "B=yellow"]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err[-1].startswith("cranktrack: error: marker B")
    assert any(line.startswith("warning:") and "truncated or damaged" in line
               for line in err[:-1]), err


def test_corrupt_packets_in_the_middle_are_skipped_and_listed(small_h264, tmp_path):
    data = bytearray(small_h264.video.read_bytes())
    start = len(data) // 3
    for i in range(start, start + 2000):
        data[i] = (i * 7919) % 256
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(bytes(data))
    p = _run("track", str(bad), "--out", str(tmp_path / "run"), "--known-length", "A-C=160.8")
    assert "Traceback" not in p.stderr
    tracks = pd.read_csv(tmp_path / "run" / "tracks.csv")
    assert 30 < len(tracks) < 60  # the damaged frames are missing, the rest is tracked
    assert "corrupt packet(s) were skipped" in p.stderr


def test_index_missing_is_explained(tmp_path):
    # An MP4 cut before its index: nothing can read it; say why it may be so.
    f = tmp_path / "cut.mp4"
    f.write_bytes(b"\x00\x00\x00\x20ftypisom" + bytes(5000))
    p = _run("track", str(f), "--out", str(tmp_path / "run"))
    assert p.returncode == 1 and "Traceback" not in p.stderr
    assert "index may be missing" in p.stderr


def test_output_path_that_is_a_file(small_h264, tmp_path):
    blocker = tmp_path / "taken"
    blocker.write_text("a file, not a folder")
    p = _run("track", str(small_h264.video), "--out", str(blocker))
    assert p.returncode == 1 and "exists and is not a folder" in p.stderr
    assert "Traceback" not in p.stderr


@pytest.mark.parametrize("where, says", [("taken/sub", "a part of its path is a file"),
                                         ("/proc/cranktrack-test/run", "choose another")])
def test_output_folder_that_cannot_be_made_is_one_sentence(small_h264, tmp_path, capsys,
                                                            where, says):
    (tmp_path / "taken").write_text("a file, not a folder")
    out = where if where.startswith("/") else str(tmp_path / where)
    assert main(["track", str(small_h264.video), "--out", out]) == 1
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1


def test_read_only_filesystem_is_one_sentence(tmp_path, monkeypatch, capsys):
    def read_only(self, *args, **kwargs):
        raise OSError(30, "Read-only file system", str(self))

    monkeypatch.setattr(files.Path, "mkdir", read_only)
    assert main(["synth", "spool", "--out", str(tmp_path / "new"), "--size", "160x120"]) == 1
    err = capsys.readouterr().err
    assert "Read-only file system" in err and err.count("\n") == 1


def test_a_board_size_that_is_not_cols_x_rows_is_one_sentence(tmp_path, capsys):
    for bad in ("9by6", "9x6x2", "1x6"):
        assert main(["synth", "board", "--board", bad, "--out", str(tmp_path / "b")]) == 1
        assert "--board" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


def test_disk_full_is_one_sentence_and_earlier_files_stay(small_h264, tmp_path, monkeypatch,
                                                          capsys):
    real = files.os.replace
    calls = {"n": 0}

    def replace(src, dst):
        calls["n"] += 1
        if calls["n"] > 2:  # tracks.csv and run.json get written, then the disk is full
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    assert main(["track", str(small_h264.video), "--out", str(tmp_path / "run"),
                 "--known-length", "A-C=160.8"]) == 1
    err = capsys.readouterr().err
    assert "disk may be full" in err and err.count("\n") == 1
    assert (tmp_path / "run" / "tracks.csv").exists()
    assert not list((tmp_path / "run").glob(".*partial"))


@pytest.mark.parametrize("content", ["", "{", '{"schema": 2, "kind": "plane"}', "[1, 2]",
                                     '{"schema": 1, "image_size": [Infinity, 480]}'])
def test_bad_calibration_files(small_h264, tmp_path, content):
    cal = tmp_path / "cal.json"
    cal.write_text(content)
    p = _run("track", str(small_h264.video), "--out", str(tmp_path / "run"), "--calibration",
             str(cal))
    assert p.returncode == 1 and "Traceback" not in p.stderr
    assert "cal.json" in p.stderr


def test_compare_on_nan_only_kinematics(tmp_path):
    cols = ["frame", "t_s", "theta_deg", "theta_deg_sigma", "L3_mm"]
    pd.DataFrame({c: [float("nan")] * 5 for c in cols}).to_csv(tmp_path / "kinematics.csv",
                                                                index=False)
    p = _run("compare", str(tmp_path))
    assert p.returncode == 1 and "Traceback" not in p.stderr
    assert "fewer than 12 frames" in p.stderr


def test_ctrl_c_keeps_valid_tracks_and_resume_equals_an_uninterrupted_run(small_h264,
                                                                         tmp_path):
    from cranktrack.pipeline import track_run

    full = track_run(small_h264.video, tmp_path / "full", ("A", "C", 160.8))

    def interrupt(index):
        if index == 20:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        track_run(small_h264.video, tmp_path / "cut", ("A", "C", 160.8), on_frame=interrupt)
    partial = pd.read_csv(tmp_path / "cut" / "tracks.csv")
    assert list(partial["frame"]) == list(range(21))  # up to the last finished frame
    assert partial[["A_ok", "B_ok", "C_ok"]].all().all()
    resumed = track_run(small_h264.video, tmp_path / "cut", ("A", "C", 160.8), resume=True)
    pd.testing.assert_frame_equal(resumed.tracks, full.tracks)
    pd.testing.assert_frame_equal(resumed.kinematics, full.kinematics)
    assert not (tmp_path / "cut" / ".tracker_state.pkl").exists()


RESUMED_FILES = ("tracks.csv", "kinematics.csv", "calibration.json")


def _same_bytes(a, b) -> None:
    for name in RESUMED_FILES:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.parametrize("at_frame", [7, 33])
def test_a_real_sigint_mid_frame_resumes_byte_for_byte(small_h264, tmp_path, at_frame,
                                                       monkeypatch):
    # SIGINT as Ctrl-C sends it, raised while a frame is half tracked (marker B found,
    # C not yet): the tracker finishes that frame first, so the saved state and the
    # rows agree.
    import os
    import signal

    import cranktrack.tracker.track as tracker
    from cranktrack.errors import RunInterrupted
    from cranktrack.pipeline import track_run

    track_run(small_h264.video, tmp_path / "full", ("A", "C", 160.8))
    real = tracker._locate

    def locate_then_sigint(frame, marker, *args, **kwargs):
        found = real(frame, marker, *args, **kwargs)
        if frame.index == at_frame and marker.spec.name == "B":
            os.kill(os.getpid(), signal.SIGINT)
        return found

    monkeypatch.setattr(tracker, "_locate", locate_then_sigint)
    with pytest.raises(RunInterrupted) as stop:
        track_run(small_h264.video, tmp_path / "cut", ("A", "C", 160.8))
    monkeypatch.setattr(tracker, "_locate", real)
    assert stop.value.resumable
    assert len(pd.read_csv(tmp_path / "cut" / "tracks.csv")) == at_frame + 1
    track_run(small_h264.video, tmp_path / "cut", ("A", "C", 160.8), resume=True)
    _same_bytes(tmp_path / "full", tmp_path / "cut")


@pytest.mark.parametrize("module, step, not_yet", [
    ("cranktrack.pipeline", "measure_kinematics", "kinematics.csv"),
    ("cranktrack.report.summary", "write_report", "report.md")])
def test_ctrl_c_after_the_frames_resumes(small_h264, tmp_path, monkeypatch, module, step,
                                         not_yet):
    import importlib

    import cranktrack.pipeline as pipeline
    from cranktrack.errors import RunInterrupted

    pipeline.track_run(small_h264.video, tmp_path / "full", ("A", "C", 160.8))
    owner = importlib.import_module(module)
    real = getattr(owner, step)

    def stopped(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(owner, step, stopped)
    with pytest.raises(RunInterrupted) as stop:
        pipeline.track_run(small_h264.video, tmp_path / "cut", ("A", "C", 160.8))
    assert stop.value.resumable and not (tmp_path / "cut" / not_yet).exists()
    monkeypatch.setattr(owner, step, real)
    pipeline.track_run(small_h264.video, tmp_path / "cut", ("A", "C", 160.8), resume=True)
    _same_bytes(tmp_path / "full", tmp_path / "cut")
    assert not (tmp_path / "cut" / ".tracker_state.pkl").exists()


def test_ctrl_c_before_the_first_frame_is_not_called_resumable(small_h264, tmp_path):
    from cranktrack.errors import RunInterrupted
    from cranktrack.pipeline import track_run

    def stopped(total):
        raise KeyboardInterrupt

    with pytest.raises(RunInterrupted) as stop:
        track_run(small_h264.video, tmp_path / "cut", ("A", "C", 160.8), on_start=stopped)
    assert not stop.value.resumable


def test_resume_without_an_interrupted_run(small_h264, tmp_path):
    p = _run("track", str(small_h264.video), "--out", str(tmp_path), "--resume")
    assert p.returncode == 1 and "no interrupted run to resume" in p.stderr


def test_two_blobs_of_one_colour_are_reported(tmp_path):
    import numpy as np

    from cranktrack.pipeline import track_run
    from cranktrack.synthetic.render import Style, render_frame, to_uint8
    from cranktrack.synthetic.scenarios import SpoolScenario
    from cranktrack.synthetic.scene import scenario_camera
    from cranktrack.synthetic.video import VideoWriter

    scenario = SpoolScenario()
    cam = scenario_camera(scenario, (320, 240))
    style = Style(markers={**Style().markers, "D": Style().markers["B"]})  # a second red disc
    motion = scenario.motion(np.arange(20) / 30)
    with VideoWriter(tmp_path / "two.mp4", 320, 240, 30) as w:
        for i in range(20):
            pts = {k: cam.project(v[i]) for k, v in motion.points_mm.items()}
            pts["D"] = np.array([40.0, 40.0])
            w.write(to_uint8(render_frame(pts, (320, 240), cam.px_per_mm, style)), i / 30)
    run = track_run(tmp_path / "two.mp4", tmp_path / "run")
    notes = [p for p in run.warnings if "blobs of its colour and size" in p]
    assert len(notes) == 1 and notes[0].startswith("marker B: 2 blobs")
    p = _run("track", str(tmp_path / "two.mp4"), "--out", str(tmp_path / "run2"))
    assert "2 blobs of its colour and size" in p.stderr and "Traceback" not in p.stderr


def test_a_damaged_stream_header_is_one_sentence(small_h264, tmp_path, capsys):
    # The sample entry's codec tag renamed: FFmpeg opens the file but has no decoder
    # for the stream, so it knows no frame size (was an AttributeError).
    video = tmp_path / "header.mp4"
    video.write_bytes(small_h264.video.read_bytes().replace(b"avc1", b"zzzz"))
    assert main(["track", str(video), "--out", str(tmp_path / "run")]) == 1
    err = capsys.readouterr().err
    assert "damaged video stream header" in err and err.count("\n") == 1


def test_a_metadata_tag_that_is_not_utf8_does_not_stop_the_run(tmp_path, capsys):
    import av
    import numpy as np

    video = tmp_path / "tagged.mp4"
    with av.open(str(video), "w") as out:
        out.metadata["title"] = "cranktrack-title"
        s = out.add_stream("mpeg4", rate=30)
        s.width, s.height, s.pix_fmt = 64, 48, "yuv420p"
        for _ in range(5):
            frame = av.VideoFrame.from_ndarray(np.full((48, 64, 3), 128, np.uint8), "rgb24")
            out.mux(s.encode(frame))
        out.mux(s.encode())
    data = video.read_bytes()
    assert b"cranktrack-title" in data
    video.write_bytes(data.replace(b"cranktrack-title", b"cranktrack-\xce\xff\xfe\xce"))
    # Was a UnicodeDecodeError before any frame; now the five frames are read.
    assert main(["track", str(video), "--out", str(tmp_path / "run")]) in (0, 1)
    assert len(pd.read_csv(tmp_path / "run" / "tracks.csv")) == 5



def test_a_folder_another_run_is_writing_is_refused_and_a_stale_lock_is_taken_over(
        small_h264, tmp_path, capsys):

    from cranktrack.run_folder import LOCK

    run = tmp_path / "run"
    run.mkdir()
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        (run / LOCK).write_text(str(sleeper.pid))  # a live writer holds it
        assert main(["track", str(small_h264.video), "--out", str(run)]) == 1
        assert f"process {sleeper.pid}) is writing" in capsys.readouterr().err
        assert not (run / "tracks.csv").exists()
    finally:
        sleeper.kill()
        sleeper.wait()
    # Its writer is gone: the lock is stale, the run goes ahead and leaves no lock.
    assert main(["track", str(small_h264.video), "--out", str(run)]) == 0
    assert (run / "tracks.csv").exists() and not (run / LOCK).exists()


def test_a_reused_run_folder_does_not_mix_runs(small_h264, tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["track", str(small_h264.video), "--out", str(run),
                 "--known-length", "A-C=160.8"]) == 0
    (run / "fit").mkdir()
    (run / "fit" / "report.json").write_text("{}")
    # The same video again without a scale: the earlier run's kinematics, calibration and
    # fit would sit beside pixel-only tracks; they are removed.
    assert main(["track", str(small_h264.video), "--out", str(run)]) == 0
    assert not (run / "kinematics.csv").exists() and not (run / "calibration.json").exists()
    assert not (run / "fit").exists() and (run / "tracks.csv").exists()
    # Another video into the same folder: refused, the first run kept.
    other = tmp_path / "other.mp4"
    other.write_bytes(small_h264.video.read_bytes())
    capsys.readouterr()
    assert main(["track", str(other), "--out", str(run)]) == 1
    assert "already holds the run of" in capsys.readouterr().err
    assert (run / "tracks.csv").exists()
    # With --overwrite it replaces that run: nothing of the first one is left.
    (run / "fit").mkdir()
    (run / "fit" / "report.json").write_text("{}")
    assert main(["track", str(other), "--out", str(run), "--overwrite"]) == 0
    assert json.loads((run / "run.json").read_text())["source"]["path"] == str(other.resolve())
    assert not (run / "fit").exists()


def test_ctrl_c_during_a_render_leaves_no_half_video_and_no_empty_folder(tmp_path):
    from cranktrack.synthetic.scenarios import SpoolScenario
    from cranktrack.synthetic.scene import RenderSettings, render_scene

    def stopped(i, n):
        if i == 3:
            raise KeyboardInterrupt

    settings = RenderSettings(size=(160, 120), fps=30.0, seconds=1.0)
    with pytest.raises(KeyboardInterrupt):
        render_scene(SpoolScenario(), tmp_path / "new", settings, on_frame=stopped)
    assert not (tmp_path / "new").exists()
    (tmp_path / "kept").mkdir()
    (tmp_path / "kept" / "notes.txt").write_text("mine")
    with pytest.raises(KeyboardInterrupt):
        render_scene(SpoolScenario(), tmp_path / "kept", settings, on_frame=stopped)
    assert [p.name for p in (tmp_path / "kept").iterdir()] == ["notes.txt"]


@pytest.mark.parametrize("photo", ["missing.png", "garbage.png"])
def test_a_plane_photo_that_is_not_there_or_not_an_image_is_our_sentence_only(tmp_path, photo):
    (tmp_path / "garbage.png").write_text("not a picture")
    p = _run("calibrate", "plane", str(tmp_path / photo), "--out", str(tmp_path / "p.json"))
    assert p.returncode == 1 and p.stderr.count("\n") == 1  # no OpenCV WARN line before it
    assert photo in p.stderr and "Traceback" not in p.stderr


def test_results_made_from_an_earlier_table_are_called_out_of_date(small_h264, tmp_path,
                                                                      capsys):
    import json
    import os

    run = tmp_path / "run"
    video = tmp_path / "clip.mp4"
    video.write_bytes(small_h264.video.read_bytes())
    assert main(["track", str(video), "--out", str(run), "--known-length", "A-C=160.8"]) == 0
    assert main(["compare", str(run)]) == 0
    manifest = json.loads((run / "manifest.json").read_text())
    assert set(manifest["steps"]) == {"track", "compare"}
    assert manifest["steps"]["compare"]["read"]["kinematics.csv"] == \
        manifest["steps"]["track"]["made"]["kinematics.csv"]
    capsys.readouterr()
    assert main(["view", str(run)]) == 0
    assert "warning" not in capsys.readouterr().err  # nothing out of date yet
    # The kinematics edited by hand (a row dropped) after compare read them.
    kin = pd.read_csv(run / "kinematics.csv")
    kin.iloc[1:].to_csv(run / "kinematics.csv", index=False)
    assert main(["view", str(run)]) == 0
    err = capsys.readouterr().err
    assert "kinematics.csv has changed since `cranktrack track` wrote it" in err
    assert "compare.csv was made from an earlier kinematics.csv; run `cranktrack compare` " \
           "again" in err
    # compare warns of the edited table (its own results it is about to replace, not).
    assert main(["compare", str(run)]) == 0
    err = capsys.readouterr().err
    assert "kinematics.csv has changed since" in err and "compare.csv was made" not in err
    # The video changed after it was tracked.
    os.utime(video, ns=(0, 0))
    assert main(["view", str(run)]) == 0
    assert f"the video {video.resolve()} has changed or gone" in capsys.readouterr().err


def test_ctrl_c_while_the_command_line_loads_is_one_sentence(monkeypatch, capsys):
    """A Ctrl-C while numpy and the rest load (the first ~0.3 s), as the console script
    runs it: bench/resume.py met a traceback there before."""
    import builtins

    import cranktrack.__main__ as entry

    real = builtins.__import__

    def interrupted(name, *args, **kwargs):
        if name == "cli":
            raise KeyboardInterrupt
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", interrupted)
    assert entry.console() == 130
    err = capsys.readouterr().err.strip()
    assert err == "cranktrack: interrupted while starting; nothing was written"


@pytest.mark.parametrize("older", ["marker", "tracker"])
def test_a_state_saved_by_an_older_cranktrack_is_refused_in_one_sentence(small_h264, tmp_path,
                                                                         older):
    # The tracker keeps more than it once did (for each marker its motion, shape and
    # usual gain; for the run each frame's light): a state saved before that would fail
    # mid-run on --resume.
    import pickle

    from cranktrack.pipeline import track_run

    def interrupt(index):
        if index == 5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        track_run(small_h264.video, tmp_path, ("A", "C", 160.8), on_frame=interrupt)
    path = tmp_path / ".tracker_state.pkl"
    saved = pickle.loads(path.read_bytes())
    if older == "marker":
        for st in saved["state"].markers:
            del st.surprise_px  # as an older version had no such field
    else:
        del saved["state"].lights
    path.write_bytes(pickle.dumps(saved))
    p = _run("track", str(small_h264.video), "--out", str(tmp_path), "--known-length",
             "A-C=160.8", "--resume")
    assert p.returncode == 1 and "saved by an older cranktrack" in p.stderr
    assert "Traceback" not in p.stderr and len(p.stderr.strip().splitlines()) == 1
