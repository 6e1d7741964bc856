"""Measured kinematics against truth on the issue-5 reference render.

Spool scene of thesis Table 2.2, 1280×720, 30 fps, sensor noise σ 2.5 DN,
H.264 crf 20, 4 s (cached in bench/.cache). Tracks it, measures the
kinematics with the automatic window, and prints for θ, ω, |v_B| (and the
other rates) the RMS error, as % of the peak for rates, and the fraction of
true values inside the reported ±1σ band.

    .venv/bin/python bench/kinematics.py
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import scene

from cranktrack.pipeline import track_run
from cranktrack.synthetic.scene import RenderSettings

TARGETS = {"theta_deg": "RMS ≤ 0.02°", "omega_rad_s": "RMS ≤ 1 % of peak",
           "vB_mm_s": "RMS ≤ 1 % of peak"}


def main() -> None:
    files = scene("H.264_crf_20_noisy", RenderSettings(size=(1280, 720), fps=30.0, seconds=4.0,
                                                       seed=3, noise_dn=2.5))
    truth = pd.read_csv(files.truth)
    with tempfile.TemporaryDirectory() as tmp:
        run = track_run(files.video, tmp, ("A", "C", 160.8))
        import json

        info = json.loads((Path(tmp) / "run.json").read_text())["kinematics"]
    k = run.kinematics
    print(f"{files.video}: {len(k)} frames; window {info['window_samples']} samples "
          f"({info['window_s']:.3f} s), rate σ scale {info['sigma_scale']:.3f}")
    print(f"{'column':14s} {'RMS error':>12s} {'% of peak':>10s} {'max error':>11s} "
          f"{'in ±1σ':>7s}  target")
    for col in ("theta_deg", "omega_rad_s", "vB_mm_s", "vB_x_mm_s", "vB_y_mm_s",
                "alpha_rad_s2", "L3_mm", "L3_rate_mm_s"):
        e = (k[col] - truth[col]).to_numpy()
        ok = np.isfinite(e)
        rms = np.sqrt(np.mean(e[ok] ** 2))
        peak = np.nanmax(np.abs(truth[col]))
        inside = np.mean(np.abs(e[ok]) < k[f"{col}_sigma"].to_numpy()[ok])
        print(f"{col:14s} {rms:12.4g} {100 * rms / peak:9.2f}% {np.max(np.abs(e[ok])):11.4g} "
              f"{100 * inside:6.0f}%  {TARGETS.get(col, '')}")
    print("(coverage target: 60–75 % of true values inside ±1σ)")


if __name__ == "__main__":
    main()
