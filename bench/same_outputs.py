"""Every output file of a fixed set of commands, hashed: for refactors that must not change them.

Runs the ``cranktrack`` console script (the public surface, so the same script drives any
layout of the code) on a fixed list of jobs: the demo, a spool run with an undeclared effect
through track/compare/fit, a free-response and a short SMA run through fit, the sweeps, the
thermal log and thermal-id, and the synthetic calibration photos through both calibrations.
Each file's SHA-256 goes into ``OUT/digest.txt`` and its stdout into ``OUT/stdout.txt``.

Machine-specific text is made neutral before hashing: the output folder's path becomes
``<out>``, and JSON's ``created`` time and package version and ``report.md``'s line with
them are dropped, as is ``manifest.json``'s time stamp of the video. Numbers in the two
calibration files (``camera.json``, ``plane.json``) are rounded to 6 significant digits:
OpenCV's camera calibration differs from the 7th digit on (distortion; the focal length
from the 10th) between two runs of the same code on the same photos, which no refactor can
keep. Rerun recordings (``.rrd``) carry a random recording id and are listed by size only.

    python bench/same_outputs.py /tmp/before            # at the old commit
    python bench/same_outputs.py /tmp/after --against /tmp/before/digest.txt
    python bench/same_outputs.py /tmp/before --rehash    # hash again, without running
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

#: Written by `cranktrack calibrate`, whose numbers vary from the 7th digit run to run.
CALIBRATION_FILES = {"camera.json", "plane.json"}

SMALL = ["--size", "320x240", "--seconds", "3", "--seed", "3"]


def jobs(out: Path) -> list[list[str]]:
    """The commands, in order (later ones read what earlier ones wrote)."""
    o = str(out)
    return [
        ["demo", "--out", f"{o}/demo"],
        ["synth", "spool", "--out", f"{o}/eff", *SMALL, "--effect", "slack_mm=0.8"],
        ["track", f"{o}/eff/video.mp4", "--out", f"{o}/eff/run", "--known-length", "A-C=160.8"],
        ["compare", f"{o}/eff/run", "--known", "L1_mm=160.8"],
        ["fit", f"{o}/eff/run", "--known", "L1_mm=160.8", "--known", "L2_mm=72.4"],
        ["synth", "free", "--out", f"{o}/free", *SMALL],
        ["track", f"{o}/free/video.mp4", "--out", f"{o}/free/run", "--known-length",
         "A-C=160.8"],
        ["fit", f"{o}/free/run", "--model", "dynamic"],
        ["synth", "sma", "--out", f"{o}/sma", "--size", "320x240", "--seconds", "2.5",
         "--current-off-s", "2"],
        ["track", f"{o}/sma/video.mp4", "--out", f"{o}/sma/run", "--known-length", "A-C=305"],
        ["fit", f"{o}/sma/run", "--model", "sma", "--known", "current_A=1.3", "--known",
         "current_on_s=0.5"],
        ["sweep", "rocking-angle", "--n", "15", "--out", f"{o}/sweep"],
        ["sweep", "work", "--actuator", "sma", "--n", "15", "--out", f"{o}/sweep"],
        ["sweep", "actuator-curve", "--out", f"{o}/sweep"],
        ["sweep", "max-work", "--n", "10", "--out", f"{o}/sweep"],
        ["synth", "thermal", "--out", f"{o}/thermal"],
        ["thermal-id", f"{o}/thermal/thermal_log.csv", "--out", f"{o}/thermal/id.json"],
        ["synth", "board", "--out", f"{o}/board", "--views", "8"],
        ["calibrate", "camera", *[f"{o}/board/camera_view_{i:02d}.png" for i in range(8)],
         "--square-mm", "12", "--out", f"{o}/board/camera.json"],
        ["calibrate", "plane", f"{o}/board/plane_board_00.png", "--board", "11x5",
         "--square-mm", "14", "--camera", f"{o}/board/camera.json", "--out",
         f"{o}/board/plane.json"],
    ]


def neutral(path: Path, out: Path) -> bytes:
    """The file's bytes with this machine's traces removed (see the module docstring)."""
    data = path.read_bytes()
    if path.suffix in {".json", ".md", ".csv", ".txt"}:
        text = data.decode("utf-8").replace(str(out.resolve()), "<out>").replace(str(out),
                                                                                 "<out>")
        if path.suffix == ".json":
            text = re.sub(r'\s*"(created|cranktrack)": "[^"]*",?', "", text)
            # The manifest's stamp of the video: the render's own file time.
            text = re.sub(r'\s*"mtime_ns": \d+,?', "", text)
        if path.name in CALIBRATION_FILES:
            text = re.sub(r"-?\d+\.\d+(?:e[-+]?\d+)?", lambda m: f"{float(m.group(0)):.6g}",
                          text)
        if path.name == "report.md":
            text = re.sub(r"\n- cranktrack [^\n]*", "", text)
        data = text.encode("utf-8")
    return data


def digest(out: Path) -> dict[str, str]:
    rows = {}
    for p in sorted(out.rglob("*")):
        if not p.is_file() or p.name in {"digest.txt", "stdout.txt"}:
            continue
        rel = str(p.relative_to(out))
        if p.suffix == ".rrd":
            rows[rel] = f"rrd ({p.stat().st_size // 1000} kB, not compared)"
        else:
            rows[rel] = hashlib.sha256(neutral(p, out)).hexdigest()
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="folder for the outputs (emptied first)")
    ap.add_argument("--against", type=Path, help="an earlier digest.txt to compare with")
    ap.add_argument("--rehash", action="store_true",
                    help="hash the outputs already in OUT again instead of running the jobs")
    ap.add_argument("--cranktrack", default=str(Path(sys.executable).with_name("cranktrack")),
                    help="the console script to run (this Python's)")
    a = ap.parse_args()
    if not a.rehash:
        shutil.rmtree(a.out, ignore_errors=True)
        a.out.mkdir(parents=True)
        log = []
        for cmd in jobs(a.out):
            r = subprocess.run([a.cranktrack, *cmd], capture_output=True, text=True,
                               env={**os.environ, "CI": "1"})
            log.append(f"$ cranktrack {' '.join(cmd)}\n{r.stdout}{r.stderr}rc {r.returncode}\n")
            print(f"rc {r.returncode}  cranktrack {' '.join(cmd[:2])}", flush=True)
        (a.out / "stdout.txt").write_text("".join(log).replace(str(a.out), "<out>"))
    rows = digest(a.out)
    rows["stdout.txt"] = hashlib.sha256(neutral(a.out / "stdout.txt", a.out)).hexdigest()
    (a.out / "digest.txt").write_text("".join(f"{k} {v}\n" for k, v in rows.items()))
    print(f"{len(rows)} files hashed into {a.out / 'digest.txt'}")
    if a.against:
        before = dict(line.rstrip("\n").split(" ", 1) for line in a.against.read_text()
                      .splitlines())
        differ = sorted(k for k in set(before) | set(rows) if before.get(k) != rows.get(k))
        for k in differ:
            print(f"differs: {k}  ({before.get(k, 'absent')[:12]} → {rows.get(k, 'absent')[:12]})")
        print(f"{len(rows) - len([k for k in differ if k in rows])} of {len(rows)} files the same"
              f", {len(differ)} differ")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
