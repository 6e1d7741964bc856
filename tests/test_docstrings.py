"""The examples in the docstrings run and say what they show."""

import doctest
import importlib

import pytest

MODULES = [
    "cranktrack.models.crank_slider",
    "cranktrack.kinematics.differentiate",
    "cranktrack.tracker.track",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
