"""Compiling the numba kernels once, at install, so a user's first command does not.

numba compiles a kernel on its first call and keeps the machine code on disk
(``cache=True``, in ``__pycache__`` beside the source, or numba's user cache
where that is read-only). A fresh install has none, so its first ``cranktrack
track`` of a 1 s clip took 9.1 s instead of 1.45 s. ``make`` runs
:func:`compile_kernels` after installing; it calls the real entry points on
tiny inputs, so every kernel is compiled for the argument types the commands
pass it (a hand-typed signature that differed would compile a second time on
first use anyway).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np


def compile_kernels() -> list[str]:
    """Call each compiled entry point once on a tiny input; returns what was run.

    Takes about as long as the compilation (several seconds) the first time,
    well under a second once numba's cache holds everything.
    """
    from .loop.simulate import sma_theta
    from .models.dynamics import CrankDynamics, free_response
    from .models.heat import CurrentSteps
    from .models.sma_bed import SMABed, simulate_bed
    from .models.spool import crank_friction
    from .synthetic.scenarios import SpoolScenario
    from .synthetic.scene import RenderSettings, render_scene
    from .tracker.outline import fit_outline, rim_coverage
    from .tracker.refine import LARGE_RADIUS_PX, refine
    from .tracker.track import track
    from .tracker.video import Frame, open_frames

    done = []
    with tempfile.TemporaryDirectory(prefix="cranktrack-warmup-") as tmp:
        # H.264 (4:2:0, converted region by region) and lossless RGB (full chroma,
        # where the marker's edge is read in luminance too) take different kernels.
        for lossless in (False, True):
            folder = Path(tmp) / f"lossless_{lossless}"
            files = render_scene(SpoolScenario(), folder,
                                 RenderSettings(size=(320, 240), seconds=0.3, lossless=lossless))
            track(open_frames(files.video))
            done.append(f"track ({'lossless RGB' if lossless else 'H.264 4:2:0'})")
    # A shaded ball is centred by its rim, whose kernels the flat markers above skip.
    yy, xx = np.mgrid[0:40, 0:40]
    ball = (np.hypot(xx - 20.0, yy - 20.0) < 8.0)[..., None] * np.array([200.0, 40.0, 40.0])
    alpha, _ = rim_coverage(ball + 20.0, 0.0, 0.0, (20.0, 20.0), 8.0)
    fit_outline(alpha, 0.0, 0.0, (20.0, 20.0), 8.0)
    done.append("rim of a ball")
    # A marker filmed close is fitted block by block (tracker/binned.py): the blocks'
    # conversion and the σ with neighbours' errors shared are kernels of their own.
    import av

    yy, xx = np.mgrid[0:120, 0:160]
    big = LARGE_RADIUS_PX + 2.0
    disc = (np.hypot(xx - 80.3, yy - 60.6) < big)[..., None] * np.array([110, -50, -50]) + 90
    planes = av.VideoFrame.from_ndarray(disc.astype(np.uint8), format="rgb24").reformat(
        format="yuv420p").to_ndarray()
    refine(Frame(0, 0.0, planes, "i420", full_chroma=False), (80.0, 60.0), big, wire=True)
    done.append("a marker filmed close")
    t = np.linspace(0.0, 1.0, 11)
    free_response(CrankDynamics(coulomb=0.1), t, 0.3)
    done.append("free response")
    crank_friction(np.linspace(0.0, -0.1, 50), 2e-3, 3.0, 0.1, 0.5)
    done.append("spool crank with dry friction")
    simulate_bed(SMABed(), CurrentSteps((0.1, 0.5), (1.3, 0.0)), t)
    done.append("SMA bed")
    bed, wire = SMABed(), SMABed().thermal
    sma_theta({"current_on_s": 0.1, "current_off_s": 0.5, "current_A": 1.3,
               "h_W_m2K": wire.h_W_m2K, "ambient_C": wire.T_amb_C, "As_C": wire.As_C,
               "Af_C": wire.Af_C, "Ms_C": wire.Ms_C, "Mf_C": wire.Mf_C, "L1_mm": bed.L1,
               "L2_mm": bed.L2, "theta0_deg": bed.theta0_deg,
               "recovery_strain": bed.recovery_strain, "coulomb_Nm": 0.01}, t)
    done.append("SMA fit model (with dry friction)")
    from .loop.flight import _dragged

    _dragged(np.linspace(-0.1, 0.1, 5), np.array([0.0, 0.0, 1.0, 1.0, 0.0, -9810.0]), 0.1,
             1e-4)
    done.append("a flight through air")
    return done
