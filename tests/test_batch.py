"""Batches of videos, locally and on a Dask LocalCluster started by the test."""

import pandas as pd
import pytest

from cranktrack.batch import run_batch
from cranktrack.synthetic.scenarios import SpoolScenario
from cranktrack.synthetic.scene import RenderSettings, render_scene


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    folder = tmp_path_factory.mktemp("recordings")
    for seed in (1, 2, 3):
        files = render_scene(SpoolScenario(), folder / f"s{seed}",
                             RenderSettings(size=(320, 240), seconds=1.0, noise_dn=2.5,
                                            seed=seed))
        files.video.rename(folder / f"take{seed}.mp4")
    (folder / "broken.mp4").write_text("not a video")
    return folder


def _check(summary, out):
    assert len(summary) == 4
    ok = summary[summary["status"] == "ok"]
    assert len(ok) == 3 and (ok["frames"] == 30).all()
    # One frame of take 1 is a gap: its fit gave B a σ of 13 px (radius 3.6 px) and
    # a centre 0.13 px off the truth, which an honest tracker does not call found.
    assert (ok["B_found_pct"] >= 96).all() and (ok["A_found_pct"] == 100).all()
    bad = summary[summary["video"].str.endswith("broken.mp4")].iloc[0]
    assert bad["status"] == "failed" and "not a video" in bad["message"]
    assert (out / "summary.csv").exists()
    for stem in ("take1", "take2", "take3"):
        assert (out / stem / "kinematics.csv").exists()


def test_local_batch_reports_the_failure_and_does_the_rest(recordings, tmp_path):
    summary = run_batch(str(recordings / "*.mp4"), tmp_path, ("A", "C", 160.8), jobs=2)
    _check(summary, tmp_path)


def test_a_local_batch_starts_its_workers_afresh_not_forked(recordings, tmp_path,
                                                            monkeypatch):
    import concurrent.futures

    import cranktrack.batch as batch

    # A forked worker copies a process that holds OpenCV's, numba's and the decoder's
    # threads; a lock held by one of them at the fork is never let go in the copy.
    # A batch forked from a pytest worker that had tracked before hung so in CI.
    made = []

    def pool(*args, **kwargs):
        made.append(kwargs.get("mp_context"))
        return concurrent.futures.ProcessPoolExecutor(*args, **kwargs)

    monkeypatch.setattr(batch, "ProcessPoolExecutor", pool)
    summary = run_batch(str(recordings / "take1.mp4"), tmp_path, ("A", "C", 160.8), jobs=2)
    assert list(summary["status"]) == ["ok"]
    assert len(made) == 1 and made[0] is not None
    assert made[0].get_start_method() == "spawn"


def test_a_worker_that_dies_ends_the_batch_in_one_sentence_and_keeps_what_finished(
        recordings, tmp_path, monkeypatch):
    from concurrent.futures.process import BrokenProcessPool

    import cranktrack.batch as batch
    from cranktrack.errors import CranktrackError

    # A worker killed (out of memory), or a script that calls run_batch outside
    # `if __name__ == "__main__":` (started afresh, its workers import it again and
    # die): the pool breaks. One video finished first; it stays in the summary.
    def one_then_broken(tasks, rows, jobs, scheduler, on_done):
        rows.append({"video": tasks[0][0], "run": tasks[0][1], "status": "ok"})
        raise BrokenProcessPool("a child process terminated abruptly")

    monkeypatch.setattr(batch, "_run_tasks", one_then_broken)
    with pytest.raises(CranktrackError, match=r"stopped abruptly.*__main__.*summary\.csv"):
        run_batch(str(recordings / "*.mp4"), tmp_path, ("A", "C", 160.8), jobs=2)
    summary = pd.read_csv(tmp_path / "summary.csv")
    assert len(summary) == 4
    assert sorted(summary["status"]) == ["not run", "not run", "not run", "ok"]


def test_batch_on_a_local_dask_cluster(recordings, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        summary = run_batch(str(recordings / "*.mp4"), tmp_path, ("A", "C", 160.8),
                            scheduler=client)
    _check(summary, tmp_path)
    # The summary is what a user opens: one row per video.
    assert list(pd.read_csv(tmp_path / "summary.csv")["status"]).count("ok") == 3


def test_no_match_is_one_clear_error(tmp_path):
    from cranktrack.errors import CranktrackError

    with pytest.raises(CranktrackError, match="no files match"):
        run_batch(str(tmp_path / "*.mp4"), tmp_path / "out")


def test_an_interrupted_batch_keeps_a_summary_and_resumes(recordings, tmp_path):
    from cranktrack.errors import RunInterrupted

    def stop_after_first(row):
        raise KeyboardInterrupt

    with pytest.raises(RunInterrupted):
        run_batch(str(recordings / "*.mp4"), tmp_path, ("A", "C", 160.8), jobs=1,
                  on_done=stop_after_first)
    first = pd.read_csv(tmp_path / "summary.csv")
    assert len(first) == 4 and (first["status"] != "interrupted").sum() == 1
    again: list[str] = []
    summary = run_batch(str(recordings / "*.mp4"), tmp_path, ("A", "C", 160.8), jobs=1,
                        on_done=lambda row: again.append(row["video"]), resume=True)
    _check(summary, tmp_path)
    finished_first = first.loc[first["status"] == "ok", "video"].tolist()
    assert not set(finished_first) & set(again)  # a finished video is not run twice
    assert len(again) == 4 - len(finished_first)


def test_one_cameras_readout_reaches_every_run_and_one_too_long_fails_each_alone(
        recordings, tmp_path):
    import json

    summary = run_batch(str(recordings / "take*.mp4"), tmp_path / "rs", ("A", "C", 160.8),
                        jobs=2, readout_s=0.004)
    assert (summary["status"] == "ok").all() and len(summary) == 3
    for stem in ("take1", "take2", "take3"):
        info = json.loads((tmp_path / "rs" / stem / "run.json").read_text())
        assert info["tracking"]["rolling_shutter_readout_s"] == 0.004
    # 40 ms is longer than a 30 fps frame: refused per video, before tracking.
    summary = run_batch(str(recordings / "take*.mp4"), tmp_path / "long", ("A", "C", 160.8),
                        jobs=2, readout_s=0.04)
    assert (summary["status"] == "failed").all()
    assert summary["message"].str.contains("does not fit in one frame").all()
