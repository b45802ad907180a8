"""Property-based tests of validation (hypothesis)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squealkit import InputError
from squealkit._validation import parse_range
from squealkit.models import PinOnDisc3DOF, get_preset

POSITIVE = ["m1", "m2", "k1", "k2", "k3", "kc"]


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(POSITIVE), value=st.floats(max_value=0.0, allow_nan=False))
def test_non_positive_physical_parameters_rejected(name, value):
    with pytest.raises(InputError, match=name):
        get_preset("lv2013").replace(**{name: value})


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from([*POSITIVE, "c1", "alpha", "P"]),
       value=st.sampled_from([math.nan, math.inf, -math.inf]))
def test_non_finite_rejected(name, value):
    with pytest.raises(InputError, match="finite"):
        get_preset("lv2013").replace(**{name: value})


@settings(max_examples=60, deadline=None)
@given(deg=st.floats(min_value=90.0, max_value=1e6) | st.floats(min_value=-1e6, max_value=-90.0))
def test_angles_of_90_deg_or_more_rejected(deg):
    with pytest.raises(InputError, match="between -90 and 90"):
        PinOnDisc3DOF(alpha=math.radians(deg))


@settings(max_examples=60, deadline=None)
@given(value=st.floats(min_value=1e-6, max_value=1e12, allow_nan=False))
def test_valid_positive_values_accepted(value):
    assert get_preset("lv2013").replace(k3=value).k3 == value


@settings(max_examples=80, deadline=None)
@given(start=st.floats(-1e3, 1e3), stop=st.floats(-1e3, 1e3), n=st.integers(2, 500))
def test_parse_range_is_linspace(start, stop, n):
    np.testing.assert_array_equal(parse_range("x", f"{start!r}:{stop!r}:{n}"), np.linspace(start, stop, n))


@settings(max_examples=60, deadline=None)
@given(text=st.text(alphabet="0123456789:.-eabc ", max_size=12))
def test_parse_range_never_crashes(text):
    try:
        out = parse_range("x", text)
    except InputError:
        return
    assert np.all(np.isfinite(out))
