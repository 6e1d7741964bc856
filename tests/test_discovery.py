"""The proposed missing term: sparse regression of what no effect in the library explains.

Truth is the spool bed built from its parts (:mod:`cranktrack.synthetic.mechanism`,
which imports nothing the fitter uses) with an effect the library lacks: play
between the wire and the crank (taken out of the library for the test), or a mount
that rocks. The proposal must name the
shape the physics has, at its size, and nothing on noise.
"""

import numpy as np
import pytest

from cranktrack.loop.candidates import CANDIDATES
from cranktrack.loop.discovery import discover
from cranktrack.loop.search import close_loop
from cranktrack.report.fit import plain_summary, report_markdown
from cranktrack.synthetic.mechanism import SpoolBed, measured_table

T = np.arange(75) / 30.0
KNOWN = {"start_s": 0.5, "stroke_mm": 15.0, "L1_mm": 160.8, "L2_mm": 72.4, "speed_mm_s": 14.0}


def loop(bed: SpoolBed, seed: int = 0, candidates: dict | None = None) -> dict:
    table = measured_table(bed.theta(T), T, 0.02, seed=seed, correlation=0.5)
    return close_loop(table, KNOWN, candidates=candidates).to_dict()


def test_play_between_wire_and_crank_is_proposed_as_a_step_of_the_band_when_driving():
    # With play taken out of the library, what the library would lack is proposed.
    without_play = {k: c for k, c in CANDIDATES.items() if k != "play_deg"}
    report = loop(SpoolBed(dead_band_deg=0.5), candidates=without_play)
    assert report["effects"] == [] and report["unexplained"]
    found = report["leftover"]["discovery"]
    # The wire must take up the band before the crank follows, then the crank trails the
    # play-free linkage by the whole band: a step of +0.5° from the drive's start.
    assert list(found["terms"]) == ["after start"]
    assert found["terms"]["after start"] == pytest.approx(0.5, abs=0.075)
    assert found["rmse_after_deg"] < 0.5 * found["rmse_before_deg"]
    # The user reads it in the report's first paragraph and in its own section.
    assert found["equation"] in plain_summary(report)
    assert "**Proposed missing term**" in report_markdown(report)


@pytest.mark.parametrize("seed", [0, 3])
def test_a_rocking_bench_is_proposed_as_a_ripple_at_its_frequency_also_while_still(seed):
    # The crank's mount rocks at 7.3 Hz by ±0.1°, drive or no drive: nothing the effect
    # library has (its ripple is the drive's, once per spool turn, only while winding).
    rock = np.radians(0.1) * np.sin(2 * np.pi * 7.3 * T + 0.4)
    table = measured_table(SpoolBed().theta(T) + rock, T, 0.02, seed=seed, correlation=0.5)
    report = close_loop(table, KNOWN).to_dict()
    assert report["effects"] == [] and report["unexplained"]
    found = report["leftover"]["discovery"]
    assert set(found["terms"]) <= {"ripple sin", "ripple cos"}
    assert found["ripple_hz"] == pytest.approx(7.3, rel=0.02)
    assert "while moving" not in found["equation"]
    amp = np.hypot(found["terms"].get("ripple sin", 0.0), found["terms"].get("ripple cos", 0.0))
    assert amp == pytest.approx(0.1, rel=0.15)
    assert found["rmse_after_deg"] < 0.5 * found["rmse_before_deg"]


@pytest.mark.parametrize("seed", range(20))
def test_nothing_is_proposed_for_tracker_noise(seed):
    bed = SpoolBed()
    model = np.degrees(bed.theta(T))
    noise = measured_table(bed.theta(T), T, 0.02, seed=seed, correlation=0.5)["theta_deg"]
    assert discover(T, noise.to_numpy() - model, model, 0.02, ripple_hz=2.0) is None
