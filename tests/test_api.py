"""The Python API's refusals: one CranktrackError sentence, before any work is done.

The happy path is the README's example (tests/test_docstrings.py)."""

import pytest

import cranktrack as ct
from cranktrack.errors import CranktrackError


@pytest.mark.parametrize("model, known, words", [
    ("pendulum", {}, "cannot be fitted yet"),
    ("spool", {"L9_mm": 1.0}, "is not a spool parameter"),
    ("spool", {"L1_mm": float("inf")}, "not a finite number"),
    ("spool", {"L1_mm": "long"}, "not a finite number"),
])
def test_fit_refuses_what_it_cannot_use_before_reading_the_run(tmp_path, model, known, words):
    with pytest.raises(CranktrackError, match=words):
        ct.fit(tmp_path / "absent", model=model, known=known)
    assert not (tmp_path / "absent").exists()


def test_track_refuses_a_missing_video_and_a_bad_length_without_making_a_folder(tmp_path):
    with pytest.raises(CranktrackError):
        ct.track(tmp_path / "none.mp4", out=tmp_path / "run")
    with pytest.raises(CranktrackError, match="not a positive length"):
        ct.track(tmp_path / "none.mp4", known_length=("A", "C", -3), out=tmp_path / "run")
    with pytest.raises(CranktrackError, match="not a number of mm"):
        ct.track(tmp_path / "none.mp4", known_length=("A", "C", "far"), out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError):
        ct.no_such_thing  # noqa: B018


def test_measure_refuses_a_folder_that_is_no_run_and_a_bad_length(tmp_path):
    with pytest.raises(CranktrackError, match="is not a folder"):
        ct.measure(tmp_path / "absent")
    with pytest.raises(CranktrackError, match="not a positive length"):
        ct.measure(tmp_path, known_length=("A", "C", 0))
    with pytest.raises(CranktrackError, match="was not written by `cranktrack track`"):
        ct.measure(tmp_path, known_length=("A", "C", 160.8))
    assert list(tmp_path.iterdir()) == []
