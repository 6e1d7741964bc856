"""The examples in the docstrings run and say what they show."""

import doctest
import importlib
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"

MODULES = [
    "cranktrack.models.crank_slider",
    "cranktrack.kinematics.differentiate",
    "cranktrack.tracker.track",
    "cranktrack.tracker.coverage",
    "cranktrack.tracker.scatter",
    "cranktrack.tracker.template",
    "cranktrack.tracker.lighting",
    "cranktrack.tracker.video",
    "cranktrack.tracker.pictures",
    "cranktrack.tracker.planes",
    "cranktrack.api",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_the_readme_python_example_runs(tmp_path, monkeypatch):
    """The README's notebook example, as printed (it writes into the folder it runs in)."""
    monkeypatch.chdir(tmp_path)
    result = doctest.testfile(str(README), module_relative=False,
                              optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted >= 8 and result.failed == 0
    assert (tmp_path / "clip" / "residuals.png").stat().st_size > 10_000
