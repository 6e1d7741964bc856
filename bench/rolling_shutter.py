"""Kinematics from a rolling-shutter camera, with and without ``--rolling-shutter-ms``.

The spool render of ``bench/kinematics.py`` (1280×720, 30 fps, σ 2.5 DN, H.264 crf
20, 4 s, seed 3), rendered again as a rolling shutter reads it: the renderer
(``synthetic/scene.py``) draws each row at its own time. The correction
(``kinematics/rolling_shutter.py``) shares no code with it. Each render is tracked
with no readout given, with half the true one, and with the true one; it prints
the RMS error of θ, ω and |v_B| against the render's truth, and the spread of
the crank's length |AB| (a rigid link: what a user can see without a truth).

    .venv/bin/python bench/rolling_shutter.py [--readouts-ms 5 15]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import scene

from cranktrack.pipeline import track_run
from cranktrack.synthetic.scene import RenderSettings


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--readouts-ms", type=float, nargs="+", default=[5.0, 15.0],
                    help="readout times to render, ms (top row to bottom row)")
    args = ap.parse_args()
    for readout_ms in [0.0, *args.readouts_ms]:
        name = "H.264_crf_20_noisy" if readout_ms == 0 else f"H.264_crf_20_noisy_rs{readout_ms:g}"
        files = scene(name, RenderSettings(size=(1280, 720), fps=30.0, seconds=4.0, seed=3,
                                           noise_dn=2.5, readout_s=readout_ms / 1e3))
        truth = pd.read_csv(files.truth)
        print(f"\nrendered with a readout of {readout_ms:g} ms")
        for given in sorted({0.0, readout_ms / 2, readout_ms}):
            with tempfile.TemporaryDirectory() as tmp:
                run = track_run(files.video, tmp, ("A", "C", 160.8), readout_s=given / 1e3)
            k = run.kinematics
            rms = {c: float(np.sqrt(np.nanmean((k[c] - truth[c]).to_numpy() ** 2)))
                   for c in ("theta_deg", "omega_rad_s", "vB_mm_s")}
            print(f"  --rolling-shutter-ms {given:<5g} θ {rms['theta_deg']:.4f}°, "
                  f"ω {rms['omega_rad_s']:.4f} rad/s, |v_B| {rms['vB_mm_s']:.3f} mm/s RMS; "
                  f"|AB| spread {np.nanstd(k['L2_mm']):.4f} mm")


if __name__ == "__main__":
    main()
