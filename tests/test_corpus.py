"""The bad-input corpus: every fault and wrong input in one list, judged by one rule.

Each case builds its input in a fresh folder and runs the command line in-process
(stdout and stderr caught at the file descriptors, so an FFmpeg or OpenCV message
written straight to fd 2 is caught too). The rule, the same for all:

- no traceback, and every line on stderr is ours: ``warning: …``, one
  ``cranktrack: error: …`` (or ``cranktrack: interrupted …``), or argparse's usage
  and its one error line; nothing a library printed;
- a case marked ``fails`` exits non-zero with exactly one error sentence; one
  marked ``works`` exits 0 and leaves the files it promises; ``either`` may do
  both (a clip that can be read in part), but each outcome still obeys the rule
  for it;
- a run folder holds no file of another run.

Other test files check what each message *says*; this one checks that none of
these inputs gets past the one error path.
"""

from __future__ import annotations

import errno
import json
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest

import cranktrack.files as files
from cranktrack.cli import main
from cranktrack.synthetic.scenarios import SpoolScenario
from cranktrack.synthetic.scene import RenderSettings, render_scene

#: A run's promised files after `track`.
RUN_FILES = ("tracks.csv", "run.json", "report.md")

OURS = re.compile(r"^(warning: |cranktrack: error: |cranktrack: interrupted|usage: |"
                  r"cranktrack [a-z-]+: error: | )")


@pytest.fixture(scope="module")
def clip(tmp_path_factory) -> Path:
    """A small spool render (160×120, 1 s) and its frames as arrays."""
    settings = RenderSettings(size=(160, 120), fps=30.0, seconds=1.0, noise_dn=2.5, seed=2)
    return render_scene(SpoolScenario(), tmp_path_factory.mktemp("corpus"), settings).video


def _frames(video: Path, n: int | None = None) -> list[np.ndarray]:
    with av.open(str(video)) as c:
        out = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
    return out[:n]


def _encode(path: Path, frames: list[np.ndarray], codec: str = "libx264",
            pix_fmt: str = "yuv420p", pts_ms: list[int] | None = None) -> Path:
    """Frames into a video with PyAV: any codec, pixel format, and timestamps (ms)."""
    with av.open(str(path), "w") as c:
        s = c.add_stream(codec, rate=30)
        h, w = frames[0].shape[:2] if frames else (120, 160)
        s.width, s.height, s.pix_fmt = w, h, pix_fmt
        if pts_ms is not None:
            s.codec_context.time_base = Fraction(1, 1000)
        for i, rgb in enumerate(frames):
            f = av.VideoFrame.from_ndarray(rgb, format="rgb24")
            if pts_ms is not None:
                f.pts, f.time_base = pts_ms[i], Fraction(1, 1000)
            for p in s.encode(f):
                c.mux(p)
        for p in s.encode():
            c.mux(p)
    return path


def _damaged(clip: Path, where: str) -> Callable[[Path], Path]:
    def make(d: Path) -> Path:
        data = bytearray(clip.read_bytes())
        if where.startswith("cut"):
            data = data[: len(data) * int(where[3:]) // 100]
        elif where == "header":
            for i in range(8, 400, 3):
                data[i] ^= 0x5A
        elif where == "middle":
            start = len(data) // 2
            data[start:start + 1500] = bytes((i * 7919) % 256 for i in range(1500))
        out = d / f"{where}.mp4"
        out.write_bytes(bytes(data))
        return out
    return make


@dataclass(frozen=True)
class Case:
    name: str
    #: Builds the input in a fresh folder; returns the command line (after `cranktrack`).
    argv: Callable[[Path, Path], list[str]]
    #: "fails", "works" or "either".
    outcome: str
    #: Files that must exist (relative to the folder) when the command exits 0.
    promised: tuple[str, ...] = ()
    #: Set up before the run (monkeypatch, the folder, the clip), e.g. a full disk.
    setup: Callable | None = None


def _track(video_of: Callable[[Path, Path], Path], *extra: str) -> Callable:
    def argv(d: Path, clip: Path) -> list[str]:
        return ["track", str(video_of(d, clip)), "--out", str(d / "run"), *extra]
    return argv


def _the_clip(d: Path, clip: Path) -> Path:
    return clip


def _file(name: str, content: bytes | str) -> Callable[[Path, Path], Path]:
    def make(d: Path, clip: Path) -> Path:
        p = d / name
        p.write_bytes(content if isinstance(content, bytes) else content.encode())
        return p
    return make


def _images(gap: bool = False, size: tuple[int, int] | None = None) -> Callable:
    def make(d: Path, clip: Path) -> Path:
        import cv2

        folder = d / "images"
        folder.mkdir()
        for i, rgb in enumerate(_frames(clip, 12)):
            if gap and i == 5:
                continue
            img = rgb if size is None else np.zeros((*size[::-1], 3), np.uint8)
            cv2.imwrite(str(folder / f"frame_{i:03d}.png"), img[:, :, ::-1])
        return folder
    return make


def _reencoded(codec: str, pix_fmt: str, suffix: str = ".mp4", n: int | None = None,
               size: tuple[int, int] | None = None, pts_ms: list[int] | None = None
               ) -> Callable:
    def make(d: Path, clip: Path) -> Path:
        frames = _frames(clip, n)
        if size is not None:
            frames = [np.full((*size[::-1], 3), 128, np.uint8) for _ in frames]
        return _encode(d / f"v{suffix}", frames, codec, pix_fmt, pts_ms)
    return make


def _disk_full(monkeypatch, d: Path, clip: Path) -> None:
    real, calls = files.os.replace, {"n": 0}

    def replace(src, dst):
        calls["n"] += 1
        if calls["n"] > 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)


def _read_only(monkeypatch, d: Path, clip: Path) -> None:
    def refuse(self, *args, **kwargs):
        raise OSError(30, "Read-only file system", str(self))

    monkeypatch.setattr(files.Path, "mkdir", refuse)


def _another_runs_folder(monkeypatch, d: Path, clip: Path) -> Path:
    """The folder holds the run of another video (a copy of the clip elsewhere)."""
    other = d / "other.mp4"
    other.write_bytes(clip.read_bytes())
    assert main(["track", str(other), "--out", str(d / "run"), "--quiet"]) == 0
    return other


#: Processes a case started (a writer that holds a run folder's lock), stopped after it.
_SLEEPERS: list[subprocess.Popen] = []


def _locked(monkeypatch, d: Path, clip: Path) -> None:
    from cranktrack.run_folder import LOCK

    (d / "run").mkdir()
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    _SLEEPERS.append(sleeper)
    (d / "run" / LOCK).write_text(str(sleeper.pid))


CORPUS: list[Case] = [
    # The video itself.
    Case("no such file", _track(lambda d, c: d / "missing.mp4"), "fails"),
    Case("random bytes", _track(_file("noise.mp4", bytes(np.random.default_rng(0).integers(
        0, 256, 20000, dtype=np.uint8)))), "fails"),
    Case("empty file", _track(_file("empty.mp4", b"")), "fails"),
    Case("a text file", _track(_file("notes.mp4", "this is not a video\n")), "fails"),
    Case("an mp4 cut before its index", _track(_file("cut.mp4", b"\x00\x00\x00\x20ftypisom"
                                                     + bytes(5000))), "fails"),
    Case("truncated at 10 %", _track(lambda d, c: _damaged(c, "cut10")(d)), "either",
         RUN_FILES),
    Case("truncated at 50 %", _track(lambda d, c: _damaged(c, "cut50")(d)), "either",
         RUN_FILES),
    Case("truncated at 90 %", _track(lambda d, c: _damaged(c, "cut90")(d)), "either",
         RUN_FILES),
    Case("corrupt header", _track(lambda d, c: _damaged(c, "header")(d)), "either", RUN_FILES),
    Case("corrupt middle", _track(lambda d, c: _damaged(c, "middle")(d)), "either", RUN_FILES),
    Case("zero frames", _track(_reencoded("ffv1", "yuv420p", ".mkv", n=0)), "fails"),
    Case("a single frame", _track(_reencoded("libx264", "yuv420p", n=1)), "either", RUN_FILES),
    Case("a 1×1 video", _track(_reencoded("png", "rgb24", ".mov", n=4, size=(1, 1))), "fails"),
    Case("10-bit", _track(_reencoded("libx264", "yuv420p10le")), "works", RUN_FILES),
    Case("4:4:4", _track(_reencoded("libx264", "yuv444p")), "works", RUN_FILES),
    Case("variable frame rate", _track(_reencoded(
        "libx264", "yuv420p", pts_ms=[int(33.3 * i + (20 if i % 3 == 0 else 0))
                                      for i in range(30)])), "works", RUN_FILES),
    Case("image folder with a gap in its numbering", _track(_images(gap=True), "--fps", "30"),
         "works", RUN_FILES),
    Case("image folder with no images", _track(lambda d, c: (d / "none").mkdir() or d / "none",
                                                "--fps", "30"), "fails"),
    Case("image folder without --fps", _track(_images()), "either", RUN_FILES),
    # The options of track.
    Case("--known-length naming an untracked marker", _track(_the_clip, "--known-length",
                                                              "A-Q=5"), "fails"),
    Case("--known-length inf", _track(_the_clip, "--known-length", "A-C=inf"), "fails"),
    Case("--known-length negative", _track(_the_clip, "--known-length", "A-C=-3"), "fails"),
    Case("--known-length with no length", _track(_the_clip, "--known-length", "A-C"), "fails"),
    Case("--marker hue out of range", _track(_the_clip, "--marker", "B=400"), "fails"),
    Case("--marker unknown colour", _track(_the_clip, "--marker", "B=octarine"), "fails"),
    Case("--marker bad #RRGGBB", _track(_the_clip, "--marker", "X=#GGHHII"), "fails"),
    Case("--marker place outside the frame", _track(_the_clip, "--marker", "X=red@5000,10"),
         "fails"),
    Case("--fill-gaps negative", _track(_the_clip, "--fill-gaps", "-3"), "fails"),
    Case("--window-s zero", _track(_the_clip, "--window-s", "0"), "fails"),
    Case("--window-s longer than the clip", _track(_the_clip, "--window-s", "100"), "fails"),
    Case("--roi with three numbers", _track(_the_clip, "--roi", "1,2,3"), "fails"),
    Case("--roi outside the frame", _track(_the_clip, "--roi", "500,500,10,10"), "fails"),
    Case("--start after --end", _track(_the_clip, "--start", "0.8", "--end", "0.2"), "fails"),
    Case("--start after the clip", _track(_the_clip, "--start", "50"), "fails"),
    Case("--fps zero", _track(_images(), "--fps", "0"), "fails"),
    Case("--calibration missing", _track(_the_clip, "--calibration", "nope.json"), "fails"),
    Case("--calibration not JSON", _track(_the_clip, "--calibration", "/etc/hostname"),
         "fails"),
    Case("--calibration for another image size", lambda d, c: [
        "track", str(c), "--out", str(d / "run"), "--calibration",
        str(_file("cal.json", json.dumps({"schema": 1, "kind": "plane",
                                          "image_size": [1920, 1080]}))(d, c))], "fails"),
    Case("--resume with nothing to resume", _track(_the_clip, "--resume"), "fails"),
    # Where the output goes.
    Case("--out is a file", lambda d, c: ["track", str(c), "--out",
                                          str(_file("taken", "x")(d, c))], "fails"),
    Case("--out under a file", lambda d, c: ["track", str(c), "--out",
                                             str(_file("taken", "x")(d, c) / "sub")], "fails"),
    Case("--out on a read-only filesystem", _track(_the_clip), "fails", setup=_read_only),
    Case("disk full while writing", _track(_the_clip, "--known-length", "A-C=160.8"), "fails",
         setup=_disk_full),
    Case("a folder holding another video's run", _track(_the_clip), "fails",
         setup=_another_runs_folder),
    Case("a folder another process is writing", _track(_the_clip), "fails", setup=_locked),
    # The other commands.
    Case("synth board --board 9by6", lambda d, c: ["synth", "board", "--board", "9by6",
                                                    "--out", str(d / "b")], "fails"),
    Case("synth --seconds inf", lambda d, c: ["synth", "spool", "--seconds", "inf", "--out",
                                              str(d / "s")], "fails"),
    Case("compare on a folder that is not a run", lambda d, c: ["compare", str(d)], "fails"),
    Case("fit with an unknown model", lambda d, c: ["fit", str(d), "--model", "rubber"],
         "fails"),
    Case("fit --known not a number", lambda d, c: ["fit", str(d), "--known", "L1_mm=abc"],
         "fails"),
    Case("view a missing run", lambda d, c: ["view", str(d / "nothing")], "fails"),
    Case("thermal-id on a missing log", lambda d, c: ["thermal-id", str(d / "log.csv")],
         "fails"),
    Case("thermal-id on a log without its columns", lambda d, c: [
        "thermal-id", str(_file("log.csv", "t_s,current_A\n0,1\n")(d, c))], "fails"),
    Case("calibrate camera on files that are not photos", lambda d, c: [
        "calibrate", "camera", str(_file("a.png", "x")(d, c)), str(_file("b.png", "y")(d, c)),
        "--board", "9x6", "--square-mm", "25", "--out", str(d / "cam.json")], "fails"),
    Case("batch on a pattern that matches nothing", lambda d, c: [
        "batch", str(d / "*.mp4"), "--out", str(d / "batch")], "fails"),
    Case("an unknown command", lambda d, c: ["trak", str(c)], "fails"),
]


def test_the_corpus_is_large_enough():
    assert len(CORPUS) >= 40


@pytest.mark.parametrize("case", CORPUS, ids=[c.name for c in CORPUS])
def test_bad_input_gets_one_sentence(case, clip, tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    try:
        if case.setup is not None:
            case.setup(monkeypatch, tmp_path, clip)
        argv = case.argv(tmp_path, clip)
        capfd.readouterr()
        try:
            rc = main(argv)
        except SystemExit as e:  # argparse's own exit, should main let it through
            rc = e.code
    finally:
        while _SLEEPERS:
            sleeper = _SLEEPERS.pop()
            sleeper.kill()
            sleeper.wait()
    out, err = capfd.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Traceback" not in err, err
    strays = [ln for ln in lines if not OURS.match(ln)]
    assert not strays, f"not ours on stderr: {strays}"
    errors = [ln for ln in lines if "error:" in ln or ln.startswith("cranktrack: interrupted")]
    if rc == 0:
        assert case.outcome != "fails", f"exit 0 on bad input: {out}{err}"
        assert not errors, err
        for name in case.promised:
            assert (tmp_path / "run" / name).exists(), f"{name} missing after exit 0"
    else:
        assert case.outcome != "works", err
        assert rc in (1, 2), rc
        assert len(errors) == 1, err
    if case.setup is _another_runs_folder:  # the other video's run is still whole
        manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
        assert manifest["video"]["path"].endswith("other.mp4")
