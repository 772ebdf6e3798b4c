"""labcut.validation.check_number: whole numbers kept exactly, the messages' bounds as written.

Seeds are whole numbers up to 2**63 - 1. Read through a float, any seed above 2**53 was rounded
(``2**53 + 1`` ran as ``2**53``: two seeds a user gave ran identically) and ``2**63 - 1``, the largest
documented, was refused as ``9.22337e+18``.
"""

from __future__ import annotations


import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from labcut.errors import ParameterError
from labcut.validation import check_number

TOP = 2**63 - 1


@given(st.integers(min_value=0, max_value=TOP))
def test_every_seed_in_range_is_kept_exactly(seed):
    out = check_number(seed, "seed", 0, TOP, integer=True)
    assert out == seed and type(out) is int


@given(st.integers(min_value=TOP + 1, max_value=2**200))
def test_every_seed_above_the_range_is_refused(seed):
    with pytest.raises(ParameterError, match=r"seed must lie in \[0, 9223372036854775807\]"):
        check_number(seed, "seed", 0, TOP, integer=True)


def test_neighbouring_large_seeds_stay_apart():
    a = check_number(2**53, "seed", 0, TOP, integer=True)
    b = check_number(2**53 + 1, "seed", 0, TOP, integer=True)
    assert (a, b) == (2**53, 2**53 + 1)
    assert check_number(np.int64(TOP), "seed", 0, TOP, integer=True) == TOP
    assert check_number(np.uint64(2**63), "seed", 0, 2**64, integer=True) == 2**63


@pytest.mark.parametrize("value, message", [
    (TOP + 1, "seed must lie in [0, 9223372036854775807], got 9223372036854775808"),
    (-1, "seed must lie in [0, 9223372036854775807], got -1"),
    (10**400, "seed must lie in [0, 9223372036854775807], got a number too large to use"),
    (1e300, "seed must lie in [0, 9223372036854775807], got 1e+300"),
    (2.5, "seed must be a whole number, got 2.5"),
    (float("nan"), "seed must be a finite number, got nan"),
    (True, "seed must be a number, got True"),
    ("7", None),
])
def test_seed_messages(value, message):
    if message is None:
        assert check_number(value, "seed", 0, TOP, integer=True) == 7
        return
    with pytest.raises(ParameterError) as err:
        check_number(value, "seed", 0, TOP, integer=True)
    assert str(err.value) == message and err.value.parameter == "seed"


def test_whole_floats_are_whole_numbers():
    assert check_number(7.0, "n", 1, 10, integer=True) == 7 and type(check_number(7.0, "n", 1, 10, integer=True)) is int


def test_bounds_of_whole_numbers_are_written_in_full_and_others_as_before():
    with pytest.raises(ParameterError, match=r"^spp must lie in \[1, 1048576\], got 2000000$"):
        check_number(2_000_000, "spp", 1, 1 << 20, integer=True)
    with pytest.raises(ParameterError, match=r"^size must lie in \(0, 1e\+06\] mm, got 2e\+06$"):
        check_number(2e6, "size", 0, 1e6, low_open=True, unit="mm")
    with pytest.raises(ParameterError, match=r"^x must be at most 0.5, got 0.75$"):
        check_number(0.75, "x", high=0.5)
    with pytest.raises(ParameterError, match=r"^x must be greater than 0 \(a stone's size\), got 0$"):
        check_number(0, "x", 0, low_open=True, why="a stone's size")
    assert check_number(3, "x", 0, 10) == 3.0 and type(check_number(3, "x", 0, 10)) is float
