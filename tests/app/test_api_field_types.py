"""The public API's request objects check their fields by the core's types (issue 62): numpy scalars are numbers, a
number beyond a double's range is a value the command refuses (never an OverflowError), a string is no boolean, and a
misspelt keyword names the field it is closest to. Property tests over generated values."""

from __future__ import annotations

import difflib
import math
from dataclasses import fields

import numpy as np
import pytest
import tiltload as tl
from hypothesis import given, settings
from hypothesis import strategies as st

REQUESTS = (tl.Case, tl.RunOptions, tl.CampaignOptions, tl.FalsifyOptions)
NUMPY_INTS = (np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64)
NUMPY_FLOATS = (np.float32, np.float64)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(NUMPY_INTS), st.integers(0, 100))
def test_a_numpy_integer_is_a_whole_number_and_arrives_as_a_python_int(kind, value):
    case = tl.Case(seed=kind(value), scenario="fsi")
    assert type(case.seed) is int and case.seed == value
    options = tl.RunOptions(log_every=kind(value + 1))
    assert type(options.log_every) is int and options.log_every == value + 1


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(NUMPY_FLOATS), st.floats(0.05, 1000.0))
def test_a_numpy_float_is_a_number_and_arrives_as_a_python_float(kind, value):
    case = tl.Case(stop_time=kind(value), max_tilt=kind(min(value, 180.0)), scenario="fsi")
    assert type(case.stop_time) is float and case.stop_time == float(kind(value))
    assert type(case.max_tilt) is float


@settings(max_examples=40, deadline=None)
@given(st.one_of(st.integers(min_value=2**1024, max_value=2**4096), st.integers(max_value=-(2**1024), min_value=-(2**4096)),
                 st.sampled_from([math.inf, -math.inf, math.nan])))
def test_a_number_beyond_a_double_is_the_command_s_refusal_never_an_overflow(value):
    for build in (lambda: tl.Case(stop_time=value), lambda: tl.RunOptions(realtime=value),
                  lambda: tl.FalsifyOptions(seconds=value), lambda: tl.Case(set={"plant.m_L": value}),
                  lambda: tl.Case(max_tilt=value)):
        with pytest.raises(tl.TiltloadError) as err:
            build()
        line = str(err.value)
        assert line.startswith("argument --") and "\n" not in line


@settings(max_examples=40, deadline=None)
@given(st.one_of(st.text(max_size=5), st.integers(), st.floats(allow_nan=False), st.none()))
def test_a_flag_is_true_or_false_nothing_else(value):
    for build, name in ((lambda: tl.Case(delay=value), "Case.delay"), (lambda: tl.RunOptions(no_log=value), "RunOptions.no_log"),
                        (lambda: tl.run(progress=value if value is not None else "", scenario="fsi"), "run().progress")):
        with pytest.raises(TypeError, match=name.replace("(", r"\(").replace(")", r"\)")):
            build()


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(REQUESTS), st.data())
def test_a_misspelt_keyword_names_the_field_it_is_closest_to(request, data):
    names = [f.name for f in fields(request) if f.init]
    name = data.draw(st.sampled_from([n for n in names if len(n) > 3]))
    at = data.draw(st.integers(0, len(name) - 1))
    typo = name[:at] + name[at + 1:]  # one letter dropped
    if typo in names:
        return
    with pytest.raises(TypeError) as err:
        request(**{typo: None})
    message = str(err.value)
    assert repr(typo) in message and request.__name__ in message
    close = difflib.get_close_matches(typo, names, n=1)
    assert (f"did you mean {close[0]!r}" in message) if close else "its fields are" in message
