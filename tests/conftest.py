"""Shared fixtures: small renders made once per test session."""

from pathlib import Path

import pytest

from cranktrack.synthetic.scenarios import SpoolScenario
from cranktrack.synthetic.scene import RenderSettings, SceneFiles, render_scene

#: 320×240, 60 frames at 30 fps: the drive runs from 0.5 s to 1.57 s.
SMALL = RenderSettings(size=(320, 240), fps=30.0, seconds=2.0, noise_dn=2.5, seed=1)


@pytest.fixture(scope="session")
def small_h264(tmp_path_factory) -> SceneFiles:
    """A small noisy H.264 spool render with its truth."""
    return render_scene(SpoolScenario(), tmp_path_factory.mktemp("small_h264"), SMALL)


@pytest.fixture(scope="session")
def small_lossless(tmp_path_factory) -> SceneFiles:
    """The same scene, noise-free and bit-exact."""
    settings = RenderSettings(size=(320, 240), fps=30.0, seconds=2.0, lossless=True)
    return render_scene(SpoolScenario(), tmp_path_factory.mktemp("small_lossless"), settings)


def pytest_report_header(config) -> str:
    return f"cranktrack tests; renders go to pytest's tmp dirs ({Path.cwd()})"
