"""The install's warm-up compiles every numba kernel the commands use, for the types
they pass, so a user's first command loads machine code instead of compiling."""

import os
import subprocess
import sys

PROBE = """
import sys, importlib, pkgutil
from numba.core.registry import CPUDispatcher
import cranktrack
from cranktrack.cli import main
from cranktrack.models.dynamics import CrankDynamics, free_response
from cranktrack.models.heat import CurrentSteps
from cranktrack.models.sma_bed import SMABed, simulate_bed
from cranktrack.models.spool import crank_friction
import numpy as np

for video, out in zip(sys.argv[1::2], sys.argv[2::2]):
    assert main(["track", video, "--out", out, "--known-length", "A-C=160.8", "--quiet"]) == 0
t = np.linspace(0.0, 2.0, 41)
free_response(CrankDynamics(coulomb=0.3, k_d=0.1), t, 0.5)
simulate_bed(SMABed(), CurrentSteps((0.2, 1.0), (1.2, 0.0)), t)
crank_friction(np.linspace(0.0, -0.3, 200), 1e-3, 4.0, 0.2, 1.0)
missed, loaded = [], 0
for info in pkgutil.walk_packages(cranktrack.__path__, "cranktrack."):
    if ".tests" in info.name or ".bench" in info.name:
        continue
    module = sys.modules.get(info.name)
    for name, obj in (vars(module) if module else {}).items():
        if isinstance(obj, CPUDispatcher) and obj.signatures:
            loaded += 1
            missed += [f"{info.name}.{name}" for _ in obj.stats.cache_misses]
print(loaded, " ".join(missed) or "-")
"""


def test_after_the_warm_up_a_fresh_process_compiles_nothing(small_h264, small_lossless,
                                                            tmp_path):
    # An empty cache of its own, as after a fresh install (the checkout's __pycache__
    # is warm from every other test).
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    warm = subprocess.run([sys.executable, "-c", "from cranktrack.warmup import compile_kernels;"
                           "print(len(compile_kernels()))"], capture_output=True, text=True,
                          timeout=600, env=env)
    assert warm.returncode == 0, warm.stderr
    p = subprocess.run([sys.executable, "-c", PROBE, str(small_h264.video), str(tmp_path / "a"),
                        str(small_lossless.video), str(tmp_path / "b")],
                       capture_output=True, text=True, timeout=600, env=env)
    assert p.returncode == 0, p.stderr
    loaded, missed = p.stdout.splitlines()[-1].split(maxsplit=1)
    assert int(loaded) >= 6  # the tracker's kernels and the models' ones were all called
    assert missed == "-", f"compiled on first use after the warm-up: {missed}"
