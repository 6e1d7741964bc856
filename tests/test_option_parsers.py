"""Property tests for every parser of an option's text: whatever a user types, the
parser returns a value inside its contract or raises its one error type (which the
command line turns into a sentence); and what it should accept comes back intact."""

from __future__ import annotations

import argparse
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cranktrack.arguments import (
    _count,
    _non_negative,
    _positive,
    _positive_int,
    _roi,
    _size,
    _time_or_frame,
)
from cranktrack.calibration.known_length import parse_known_length
from cranktrack.cli import parse_board, parse_effects, parse_known
from cranktrack.errors import CranktrackError
from cranktrack.tracker.markers import parse_markers

#: Text a user might type: numbers in every spelling, separators, junk.
typed = st.one_of(
    st.text(max_size=24),
    st.text(alphabet="0123456789.,-+xXfe=@#AaBbCc infINFnaN", max_size=24),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers().map(str),
    st.just("9" * 400),
)


def _either(parse, text, error):
    """The parser's value, or None when it refused with its own error type."""
    try:
        return parse(text)
    except error:
        return None


@settings(max_examples=300, deadline=None)
@given(text=typed)
def test_numbers_are_finite_and_of_the_right_sign(text):
    for parse, ok in ((_positive, lambda v: v > 0), (_non_negative, lambda v: v >= 0),
                      (_count, lambda v: v >= 0 and v == int(v)),
                      (_positive_int, lambda v: v > 0 and v == int(v))):
        v = _either(parse, text, argparse.ArgumentTypeError)
        finite = isinstance(v, int) or (v is not None and math.isfinite(v))
        assert v is None or (finite and ok(v)), (parse.__name__, text, v)


@settings(max_examples=200, deadline=None)
@given(x=st.floats(min_value=1e-9, max_value=1e9))
def test_a_positive_number_comes_back(x):
    assert _positive(repr(x)) == x and _non_negative(repr(x)) == x


@settings(max_examples=300, deadline=None)
@given(text=typed)
def test_sizes_boards_and_rois_are_whole_and_large_enough(text):
    size = _either(_size, text, argparse.ArgumentTypeError)
    assert size is None or (min(size) >= 16 and all(isinstance(v, int) for v in size))
    board = _either(parse_board, text, CranktrackError)
    assert board is None or min(board) >= 2
    roi = _either(_roi, text, argparse.ArgumentTypeError)
    assert roi is None or (roi[0] >= 0 and roi[1] >= 0 and roi[2] > 0 and roi[3] > 0)


@settings(max_examples=200, deadline=None)
@given(x=st.integers(0, 5000), y=st.integers(0, 5000), w=st.integers(1, 5000),
       h=st.integers(1, 5000))
def test_a_rectangle_and_a_size_come_back(x, y, w, h):
    assert _roi(f"{x},{y},{w},{h}") == (x, y, w, h)
    if min(w, h) >= 16:
        assert _size(f"{w}x{h}") == (w, h)


@settings(max_examples=300, deadline=None)
@given(text=typed)
def test_a_time_or_frame_is_finite_and_a_frame_is_whole(text):
    v = _either(_time_or_frame, text, argparse.ArgumentTypeError)
    if v is not None:
        value, unit = v
        assert math.isfinite(value) and value >= 0 and unit in ("s", "frame")
        assert unit == "s" or value == int(value)


@given(n=st.integers(0, 10**6), t=st.floats(0, 1e6))
def test_a_frame_number_and_seconds_come_back(n, t):
    assert _time_or_frame(f"{n}f") == (n, "frame")
    assert _time_or_frame(repr(t)) == (t, "s")


names = st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZabcxyz_", min_size=1, max_size=6)


@settings(max_examples=300, deadline=None)
@given(text=typed)
def test_a_known_length_is_two_markers_and_a_finite_length(text):
    v = _either(parse_known_length, text, CranktrackError)
    if v is not None:
        a, b, length = v
        assert a and b and a != b and math.isfinite(length) and length > 0


@given(a=names, b=names, length=st.floats(1e-6, 1e6))
def test_a_known_length_comes_back(a, b, length):
    if a != b:
        assert parse_known_length(f"{a}-{b}={length!r}") == (a, b, length)


@settings(max_examples=300, deadline=None)
@given(items=st.lists(typed, max_size=3))
def test_markers_are_named_with_finite_places_and_hues_in_range(items):
    specs = _either(parse_markers, items, CranktrackError)
    if specs is not None:
        assert len({s.name for s in specs}) == len(specs) and all(s.name for s in specs)
        for s in specs:
            assert s.near_px is None or all(math.isfinite(v) for v in s.near_px)


def test_c_none_leaves_the_crank_slider_without_its_slider_marker():
    assert [s.name for s in parse_markers(["C=none"])] == ["A", "B"]
    specs = parse_markers(["A=red@305,245", "B=120@423,111", "C=none"])
    assert [s.name for s in specs] == ["A", "B"] and all(s.flat for s in specs)
    for items, words in ((["B=none"], "only C"), (["C=none", "C=blue"], "both"),
                         (["C=none", "ball=white"], "crank-slider")):
        with pytest.raises(CranktrackError, match=words):
            parse_markers(items)


@given(name=names, hue=st.floats(0, 359.9), x=st.integers(0, 4000), y=st.integers(0, 4000))
def test_a_marker_by_hue_and_place_comes_back(name, hue, x, y):
    (spec,) = [s for s in parse_markers([f"{name}={hue!r}@{x},{y}"]) if s.name == name]
    assert spec.near_px == (x, y)


@pytest.mark.parametrize("parse", [parse_known, parse_effects])
@settings(max_examples=150, deadline=None)
@given(items=st.lists(typed, max_size=3))
def test_known_values_and_effects_are_named_numbers(parse, items):
    v = _either(parse, items, CranktrackError)
    assert v is None or all(isinstance(x, float) for x in v.values())
    if parse is parse_known and v is not None:
        assert all(math.isfinite(x) for x in v.values())
