"""Batch speed-up: 2 Dask workers vs 1 on the same small renders, in one run.

Renders (cached) 6 spool scenes at 640×360, 3 s each, then runs
`cranktrack batch` on a LocalCluster with 1 worker and with 2 workers and
prints the wall times and their ratio. On a 2-core machine the ideal is 2.0.

    .venv/bin/python bench/batch.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import CACHE, scene

from cranktrack.batch import run_batch
from cranktrack.synthetic.scene import RenderSettings


def main() -> None:
    import distributed

    videos = CACHE / "batch_videos"
    videos.mkdir(parents=True, exist_ok=True)
    for seed in range(6):
        files = scene(f"batch_{seed}", RenderSettings(size=(640, 360), seconds=3.0,
                                                      noise_dn=2.5, seed=seed))
        link = videos / f"take{seed}.mp4"
        if not link.exists():
            link.symlink_to(files.video)
    times = {}
    for workers in (1, 2):
        with distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                      dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client, tempfile.TemporaryDirectory() as out:
            t = time.perf_counter()
            summary = run_batch(str(videos / "*.mp4"), out, ("A", "C", 160.8), scheduler=client)
            times[workers] = time.perf_counter() - t
            assert (summary["status"] == "ok").all()
        print(f"{workers} worker(s): {times[workers]:.1f} s for {len(summary)} videos")
    print(f"speed-up 2 workers / 1 worker = {times[1] / times[2]:.2f}  (ideal 2.0 on 2 cores)")


if __name__ == "__main__":
    main()
