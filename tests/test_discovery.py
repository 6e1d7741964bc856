"""The proposed missing term: sparse regression of what no effect in the library explains.

Truth is the spool bed built from its parts (:mod:`cranktrack.synthetic.mechanism`,
which imports nothing the fitter uses) with an effect the library lacks: play
between the wire and the crank, or a spool turning off-centre. The proposal must
name the shape the mechanism has, at its size, and nothing on noise.
"""

import numpy as np
import pytest

from cranktrack.loop.discovery import discover
from cranktrack.loop.search import close_loop
from cranktrack.report.fit import plain_summary, report_markdown
from cranktrack.synthetic.mechanism import SpoolBed, measured_table

T = np.arange(75) / 30.0
KNOWN = {"start_s": 0.5, "stroke_mm": 15.0, "L1_mm": 160.8, "L2_mm": 72.4, "speed_mm_s": 14.0}


def loop(bed: SpoolBed, seed: int = 0) -> dict:
    table = measured_table(bed.theta(T), T, 0.02, seed=seed, correlation=0.5)
    return close_loop(table, KNOWN).to_dict()


def test_play_between_wire_and_crank_is_proposed_as_a_step_of_the_band_when_driving():
    report = loop(SpoolBed(dead_band_deg=0.5))
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


def test_an_off_centre_spool_is_proposed_as_a_ripple_at_its_turn_rate_while_driving():
    bed = SpoolBed(eccentricity=0.2, spool_radius_mm=1.0)
    found = loop(bed, seed=2)["leftover"]["discovery"]
    assert {"ripple sin", "ripple cos"} & set(found["terms"])
    # 2.4 turns in the stroke fix the frequency to a few per cent only.
    assert found["ripple_hz"] == pytest.approx(bed.turn_hz, rel=0.05)
    # The ripple's size in θ: the off-centre bed minus the round one, fitted with a sine
    # at the turn rate over the stroke (0.25°). The regression shares it with the lag
    # term the base fit leaves, so a fifth either way.
    stroke = (T > 0.5) & (T < 0.5 + 15.0 / 14.0)
    wave = 2 * np.pi * bed.turn_hz * T
    diff = np.degrees(bed.theta(T) - SpoolBed(spool_radius_mm=1.0).theta(T))
    X = np.column_stack([np.sin(wave) * stroke, np.cos(wave) * stroke, np.ones_like(T),
                         stroke.astype(float)])
    c, *_ = np.linalg.lstsq(X, diff, rcond=None)
    amp = np.hypot(found["terms"].get("ripple sin", 0.0), found["terms"].get("ripple cos", 0.0))
    assert amp == pytest.approx(np.hypot(c[0], c[1]), rel=0.2)
    assert found["rmse_after_deg"] < 0.5 * found["rmse_before_deg"]


@pytest.mark.parametrize("seed", range(20))
def test_nothing_is_proposed_for_tracker_noise(seed):
    bed = SpoolBed()
    model = np.degrees(bed.theta(T))
    noise = measured_table(bed.theta(T), T, 0.02, seed=seed, correlation=0.5)["theta_deg"]
    assert discover(T, noise.to_numpy() - model, model, 0.02, ripple_hz=2.0) is None
