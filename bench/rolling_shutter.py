"""Kinematics from a rolling-shutter camera, with and without ``--rolling-shutter-ms``.

The spool render of ``bench/kinematics.py`` (1280×720, 30 fps, σ 2.5 DN, H.264 crf
20, 4 s, seed 3), rendered again as a rolling shutter reads it: the renderer
(``synthetic/scene.py``) draws each row at its own time. The correction
(``kinematics/rolling_shutter.py``) shares no code with it. Each render is tracked
with no readout given, with half the true one, and with the true one; it prints
the RMS error of θ, ω and |v_B| against the render's truth, and the spread of
the crank's length |AB| (a rigid link: what a user can see without a truth).

Then, as a user without a known readout would: the run tracked with none is fitted
by the closed loop (`cranktrack fit`, the spool model with the bed's known values),
and where the loop names a rolling shutter, its readout is given to `cranktrack
measure`; the same errors are printed after that.

    .venv/bin/python bench/rolling_shutter.py [--readouts-ms 5 15] [--no-loop]
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

from cranktrack.environment import versions_line
from cranktrack.pipeline import fit_run, measure_run, track_run
from cranktrack.synthetic.scene import RenderSettings


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--readouts-ms", type=float, nargs="+", default=[5.0, 15.0],
                    help="readout times to render, ms (top row to bottom row)")
    ap.add_argument("--no-loop", action="store_true",
                    help="leave out the closed loop's readout and `measure` with it")
    args = ap.parse_args()
    print(f"libraries: {versions_line()}")
    for readout_ms in [0.0, *args.readouts_ms]:
        name = "H.264_crf_20_noisy" if readout_ms == 0 else f"H.264_crf_20_noisy_rs{readout_ms:g}"
        files = scene(name, RenderSettings(size=(1280, 720), fps=30.0, seconds=4.0, seed=3,
                                           noise_dn=2.5, readout_s=readout_ms / 1e3))
        truth = pd.read_csv(files.truth)
        print(f"\nrendered with a readout of {readout_ms:g} ms")
        for given in sorted({0.0, readout_ms / 2, readout_ms}):
            with tempfile.TemporaryDirectory() as tmp:
                run = track_run(files.video, tmp, ("A", "C", 160.8), readout_s=given / 1e3)
                print(f"  --rolling-shutter-ms {given:<5g} {errors(run.kinematics, truth)}")
                if given == 0 and not args.no_loop:
                    loop_then_measure(Path(tmp), truth)


def errors(k: pd.DataFrame, truth: pd.DataFrame) -> str:
    """θ, ω and |v_B| RMS against the render's truth, and the spread of |AB|."""
    rms = {c: float(np.sqrt(np.nanmean((k[c] - truth[c]).to_numpy() ** 2)))
           for c in ("theta_deg", "omega_rad_s", "vB_mm_s")}
    return (f"θ {rms['theta_deg']:.4f}°, ω {rms['omega_rad_s']:.4f} rad/s, |v_B| "
            f"{rms['vB_mm_s']:.3f} mm/s RMS; |AB| spread {np.nanstd(k['L2_mm']):.4f} mm")


#: The bed's values a user knows (thesis Table 2.2), as `bench/discrepancy.py` gives them.
KNOWN = {"L1_mm": 160.8, "L2_mm": 72.4, "speed_mm_s": 14.0, "start_s": 0.5, "stroke_mm": 15.0}


def loop_then_measure(run: Path, truth: pd.DataFrame) -> None:
    """The closed loop on a run tracked with no readout; its readout, if it names one,
    given to `measure`."""
    result, _ = fit_run(run, "spool", KNOWN)
    params = result.to_dict()["parameters"]
    found = params.get("readout_s")
    named = "readout_s" in result.effects
    print(f"    the loop names {result.effects or 'nothing'}"
          + (f"; readout {found['value'] * 1e3:.2f} ± {found.get('sigma', np.nan) * 1e3:.2f} ms"
             if found and named else ""))
    if named and found["value"] > 0:
        again = measure_run(run, readout_s=found["value"])
        print(f"    `measure --rolling-shutter-ms {found['value'] * 1e3:.2f}`: "
              f"{errors(again.kinematics, truth)}")


if __name__ == "__main__":
    main()
